"""Latency from publishing an observation message to receiving its correspondences.

Starts association_node (per algorithm) and a bare rclpy echo node as separate processes on
loopback DDS, all at once, and sends the same K-observation scans to each, one message at a
time, the servers taking turns message by message (so that the echo, the baseline, is measured
on the same machine as the nodes: a shared host's speed drifts within a run).  Prints median
and p99 of the round trip (after --warmup messages) and their ratios to the echo's (same
message sizes, no work), and the first answered scan's round trip (after the server's topics
matched; a scan whose map or pose has not arrived yet is skipped by the node) against the
median.

    python benchmarks/node_latency.py [--observations 50] [--landmarks 200] [--messages 200]
                                      [--algorithms mahalanobis_nn,gnn,jcbb]
                                      (NAME:nojit: the node without the compiled JCBB search)
                                      [--baseline DIR]  (each algorithm also from the checkout
                                      DIR, e.g. a `git worktree` of an older commit, alternating)
"""
from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import time
from typing import Optional

import numpy as np

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(20, 90)))

import rclpy  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import PointCloud2  # noqa: E402
from std_msgs.msg import Header  # noqa: E402

from msg_adapters import array_to_cloud, odometry_message  # noqa: E402
from msg_adapters.outputs import CORRESPONDENCE_DTYPE  # noqa: E402
from ros_process import stop  # noqa: E402

QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
POSE_COVARIANCE = np.diag([0.01, 0.01, 0.003])
"""The robot pose's covariance (x, y, yaw) sent with every scan."""


def echo_main(observations: int, ros_arguments: list[str]) -> None:
    """Bare rclpy round trip: answer each observation message with a correspondences-sized
    cloud."""
    rclpy.init(args=[sys.argv[0]] + ros_arguments)
    node = rclpy.create_node('echo_node')
    reply = array_to_cloud(np.zeros(observations, dtype=CORRESPONDENCE_DTYPE))
    publisher = node.create_publisher(PointCloud2, 'correspondences', 10)

    def answer(msg):
        reply.header = msg.header
        publisher.publish(reply)
    node.create_subscription(PointCloud2, 'observations', answer, QOS)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass


def scene(observations: int, landmarks: int, seed: int = 0):
    """Range-bearing scan: N landmarks within 30 m, K - K//5 of them seen, K//5 clutter."""
    rng = np.random.default_rng(seed)
    means = rng.uniform(-30, 30, (landmarks, 2))
    pose = np.array([0.5, -0.3, 0.2])
    seen = rng.choice(landmarks, observations - observations // 5, replace=False)
    delta = means[seen] - pose[:2] + rng.normal(0, 0.05, (len(seen), 2))
    ranges = np.concatenate([np.hypot(*delta.T), rng.uniform(1, 30, observations // 5)])
    bearings = np.concatenate([np.arctan2(delta[:, 1], delta[:, 0]) - pose[2],
                               rng.uniform(-np.pi, np.pi, observations // 5)])
    landmark_points = np.zeros(landmarks, dtype=[('id', '<i4'), ('x', '<f4'), ('y', '<f4'),
                                                 ('cov_xx', '<f4'), ('cov_xy', '<f4'),
                                                 ('cov_yy', '<f4')])
    landmark_points['id'] = np.arange(landmarks)
    landmark_points['x'], landmark_points['y'] = means.T
    landmark_points['cov_xx'] = landmark_points['cov_yy'] = 0.01
    observation_points = np.zeros(observations, dtype=[('range', '<f4'), ('bearing', '<f4'),
                                                       ('var_range', '<f4'),
                                                       ('var_bearing', '<f4')])
    observation_points['range'], observation_points['bearing'] = ranges, bearings
    observation_points['var_range'], observation_points['var_bearing'] = 0.01, 1e-4
    return landmark_points, observation_points, pose


class Server:
    """One server process and the client's publishers and reply subscription in its
    namespace."""

    def __init__(self, node, name: str, namespace: str, command: list[str],
                 needs_inputs: bool, code: Optional[str]) -> None:
        no_jit = command[-1].endswith(':nojit')
        if no_jit:
            command = command[:-1] + [command[-1][:-len(':nojit')]]
        environment = dict(os.environ)
        if no_jit:
            environment['DATA_ASSOCIATION_ROS_NO_JIT'] = '1'
        if code is not None:
            environment['PYTHONPATH'] = os.pathsep.join(
                [code] + [p for p in [environment.get('PYTHONPATH')] if p])
        self.name, self.namespace, self.needs_inputs = name, namespace, needs_inputs
        self.process = subprocess.Popen(command + ['--ros-args', '-r', f'__ns:={namespace}'],
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                        env=environment)
        self.received: dict[int, float] = {}
        self.reply = node.create_subscription(
            PointCloud2, f'{namespace}/correspondences',
            lambda msg: self.received.__setitem__(msg.header.stamp.sec, time.perf_counter()),
            QOS)
        self.landmarks = node.create_publisher(PointCloud2, f'{namespace}/landmarks', QOS)
        self.observations = node.create_publisher(PointCloud2, f'{namespace}/observations', QOS)
        self.pose = node.create_publisher(Odometry, f'{namespace}/robot_pose', QOS)
        self.latencies: list[float] = []

    def matched(self, node) -> bool:
        """Every connection of the round trip matched (the first scan's time is its own)."""
        return bool(self.observations.get_subscription_count()
                    and node.count_publishers(f'{self.namespace}/correspondences')
                    and self.reply.get_publisher_count()
                    and (not self.needs_inputs or (self.landmarks.get_subscription_count()
                                                   and self.pose.get_subscription_count())))


def measure(servers: list[Server], node, executor, args, landmark_points, observation_points,
            pose) -> None:
    """Round-trip times [ms] of the args.warmup + args.messages observation messages through
    each server into server.latencies (NaN for a message not answered within 5 s).  The
    servers run together and take turns message by message (in a rotating order), so that all
    of them see the same machine: a shared host's speed drifts over a run."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not all(s.matched(node) for s in servers):
        executor.spin_once(timeout_sec=0.05)
    settle = time.monotonic() + 0.5   # matching is per side: let both sides finish it
    while time.monotonic() < settle:
        executor.spin_once(timeout_sec=0.05)
    for k in range(args.messages + args.warmup):
        stamp = Header()
        stamp.stamp.sec = 1000 + k
        stamp.frame_id = 'map'
        shift = k % len(servers)
        for server in servers[shift:] + servers[:shift]:
            server.landmarks.publish(array_to_cloud(landmark_points, stamp))
            server.pose.publish(odometry_message(stamp, pose, POSE_COVARIANCE))
            pause = time.monotonic() + 0.02   # let the map and pose arrive first
            while time.monotonic() < pause:
                executor.spin_once(timeout_sec=pause - time.monotonic())
            message = array_to_cloud(observation_points,
                                     Header(stamp=stamp.stamp, frame_id='base_link'))
            sent = time.perf_counter()
            server.observations.publish(message)
            wait = time.monotonic() + 5
            while stamp.stamp.sec not in server.received and time.monotonic() < wait:
                executor.spin_once(timeout_sec=0.005)
            answered = server.received.get(stamp.stamp.sec)
            server.latencies.append(np.nan if answered is None else (answered - sent) * 1000.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--observations', type=int, default=50)
    parser.add_argument('--landmarks', type=int, default=200)
    parser.add_argument('--messages', type=int, default=200)
    parser.add_argument('--warmup', type=int, default=10)
    parser.add_argument('--algorithms', default='mahalanobis_nn,gnn,jcbb')
    parser.add_argument('--baseline', metavar='DIR',
                        help='also run each algorithm from this checkout (alternating)')
    parser.add_argument('--echo', action='store_true', help=argparse.SUPPRESS)
    args, ros_arguments = parser.parse_known_args()
    if args.echo:
        echo_main(args.observations, ros_arguments)
        return
    rclpy.init()
    landmark_points, observation_points, pose = scene(args.observations, args.landmarks)
    here = os.path.abspath(__file__)
    commands = [('bare rclpy echo', [sys.executable, here, '--echo', '--observations',
                                     str(args.observations)], None)]
    for name in args.algorithms.split(','):
        command = [sys.executable, '-m', 'data_association_ros.nodes.association_node',
                   '--ros-args', '-p', f'algorithm:={name}']
        if args.baseline:
            commands.append((f'{name} (baseline)', command, os.path.abspath(args.baseline)))
        commands.append((name, command, None))
    print(f'K={args.observations} observations, N={args.landmarks} landmarks, '
          f'{args.messages} messages each, servers interleaved, '
          f'ROS_DOMAIN_ID={os.environ["ROS_DOMAIN_ID"]}')
    node = rclpy.create_node('latency_client')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    servers = [Server(node, name, f'/latency{index}', command, index > 0, code)
               for index, (name, command, code) in enumerate(commands)]
    try:
        measure(servers, node, executor, args, landmark_points, observation_points, pose)
    finally:
        executor.remove_node(node)
        node.destroy_node()
        for server in servers:
            stop(server.process)
    print(f'{"server":<26}{"answered":>9}{"median ms":>11}{"p99 ms":>9}{"x echo":>8}'
          f'{"p99 x echo":>11}{"first ms":>10}{"first/median":>13}')
    baseline = None
    for server in servers:
        everything = np.array(server.latencies)
        latencies = everything[args.warmup:]
        latencies = latencies[np.isfinite(latencies)]
        median = float(np.median(latencies)) if len(latencies) else float('nan')
        p99 = float(np.percentile(latencies, 99)) if len(latencies) else float('nan')
        answered = everything[np.isfinite(everything)]
        first = float(answered[0]) if len(answered) else float('nan')
        baseline = (median, p99) if baseline is None else baseline
        print(f'{server.name:<26}{len(latencies):>9}{median:>11.2f}{p99:>9.2f}'
              f'{median / baseline[0]:>8.2f}{p99 / baseline[1]:>11.2f}{first:>10.2f}'
              f'{first / median:>13.2f}')
    rclpy.shutdown()


if __name__ == '__main__':
    main()
