"""Soak: observations at a fixed rate through a live association_node for a while.

For each algorithm and rate: sends K-observation scans against N landmarks for --duration
seconds (map and pose sent once; the node is told to accept them however old), then 3 s at
10 Hz to see that it recovers.  Prints messages sent and answered, latency median/p99 of the
answered ones, the node's resident memory at start and end and its peak, its CPU use, and what
its /diagnostics reported.

    python benchmarks/soak.py [--duration 60] [--rates 100,1000] [--algorithms mahalanobis_nn,jcbb]
"""
from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(20, 90)))

import rclpy  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sensor_msgs.msg import PointCloud2  # noqa: E402
from std_msgs.msg import Header  # noqa: E402

from msg_adapters import array_to_cloud  # noqa: E402
from ros_process import close, wait_until_matched  # noqa: E402
from node_latency import QOS, scene  # noqa: E402
from run_benchmarks import machine_line  # noqa: E402

PAGE = os.sysconf('SC_PAGE_SIZE')
TICKS = os.sysconf('SC_CLK_TCK')


def memory_mb(pid: int) -> tuple[float, float]:
    """(resident, peak resident) MB of a process, from /proc."""
    values = {}
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        key, _, rest = line.partition(':')
        if key in ('VmRSS', 'VmHWM'):
            values[key] = int(rest.split()[0]) / 1024
    return values['VmRSS'], values['VmHWM']


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def stamp_of(k: int) -> Header:
    """Unique stamp of message k (1 ms apart from 1000 s)."""
    h = Header(frame_id='base_link')
    h.stamp.sec, h.stamp.nanosec = 1000 + k // 1000, (k % 1000) * 1_000_000
    return h


def soak(algorithm: str, rate: float, args, index: int) -> dict:
    """One run; see the module docstring."""
    namespace = f'/soak{index}'
    command = [sys.executable, '-m', 'data_association_ros.nodes.association_node', '--ros-args',
               '-r', f'__ns:={namespace}', '-p', f'algorithm:={algorithm}',
               '-p', 'max_landmark_age:=1000000.0', '-p', 'pose_tolerance:=1000000.0',
               '-p', 'diagnostics_period:=0.5']
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    node = rclpy.create_node('soak_client', namespace=namespace)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    sent: dict[tuple[int, int], float] = {}
    received: dict[tuple[int, int], float] = {}
    diagnostics: dict[str, str] = {}

    def on_reply(msg):
        received[(msg.header.stamp.sec, msg.header.stamp.nanosec)] = time.perf_counter()

    def on_diagnostics(msg):
        for status in msg.status:
            if status.name.startswith(f'{namespace[1:]}') or 'association_node' in status.name:
                diagnostics.update({kv.key: kv.value for kv in status.values})
    node.create_subscription(PointCloud2, 'correspondences', on_reply, QOS)
    node.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)
    landmarks_pub = node.create_publisher(PointCloud2, 'landmarks', QOS)
    observations_pub = node.create_publisher(PointCloud2, 'observations', QOS)
    pose_pub = node.create_publisher(Odometry, 'robot_pose', QOS)
    landmark_points, observation_points, pose = scene(args.observations, args.landmarks)
    try:
        wait_until_matched(executor, node, observations_pub, 'correspondences')
        map_header = Header(frame_id='map')
        map_header.stamp.sec = 999
        landmarks_pub.publish(array_to_cloud(landmark_points, map_header))
        odometry = Odometry(header=map_header)
        odometry.pose.pose.position.x, odometry.pose.pose.position.y = pose[:2]
        odometry.pose.pose.orientation.z = np.sin(pose[2] / 2)
        odometry.pose.pose.orientation.w = np.cos(pose[2] / 2)
        odometry.pose.covariance = (np.diag([0.01, 0.01, 0, 0, 0, 0.003])).ravel().tolist()
        pose_pub.publish(odometry)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        rss_start, _ = memory_mb(process.pid)
        cpu_start, wall_start = cpu_seconds(process.pid), time.monotonic()
        k = 0

        def send_at(period: float, seconds: float) -> None:
            nonlocal k
            next_time = time.monotonic()
            stop = next_time + seconds
            while next_time < stop:
                message = array_to_cloud(observation_points, stamp_of(k))
                sent[(message.header.stamp.sec, message.header.stamp.nanosec)] = \
                    time.perf_counter()
                observations_pub.publish(message)
                k += 1
                next_time += period
                while (remaining := next_time - time.monotonic()) > 0:
                    executor.spin_once(timeout_sec=remaining)
        send_at(1.0 / rate, args.duration)
        loaded = set(sent)
        end = time.monotonic() + 5.0
        while time.monotonic() < end and not loaded <= set(received):
            executor.spin_once(timeout_sec=0.05)
        cpu = (cpu_seconds(process.pid) - cpu_start) / (time.monotonic() - wall_start)
        rss_end, rss_peak = memory_mb(process.pid)
        before = set(sent)
        send_at(0.1, 3.0)  # recovery at 10 Hz
        end = time.monotonic() + 3.0
        while time.monotonic() < end and not set(sent) <= set(received):
            executor.spin_once(timeout_sec=0.05)
        recovery = set(sent) - before
        latencies = np.array([(received[key] - sent[key]) * 1e3 for key in loaded
                              if key in received])
        return {'algorithm': algorithm, 'rate': rate, 'sent': len(loaded),
                'answered': len(loaded & set(received)),
                'median': float(np.median(latencies)) if len(latencies) else float('nan'),
                'p99': float(np.percentile(latencies, 99)) if len(latencies) else float('nan'),
                'rss_start': rss_start, 'rss_end': rss_end, 'rss_peak': rss_peak,
                'cpu': cpu * 100, 'recovered': f'{len(recovery & set(received))}/{len(recovery)}',
                'node_answered': diagnostics.get('messages_answered', '?'),
                'truncations': diagnostics.get('search_truncations', '?'),
                'alive': process.poll() is None}
    finally:
        close(executor, node, process)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=60.0)
    parser.add_argument('--rates', default='100,1000')
    parser.add_argument('--algorithms', default='mahalanobis_nn,jcbb')
    parser.add_argument('--observations', type=int, default=20)
    parser.add_argument('--landmarks', type=int, default=200)
    args = parser.parse_args()
    rclpy.init()
    print(f'**Soak: K = {args.observations}, N = {args.landmarks}, {args.duration:g} s per run, '
          f'default QoS (reliable, keep last 10)** ({machine_line()})\n')
    print('| algorithm | rate Hz | sent | answered | latency median ms | p99 ms | RSS start MB '
          '| end MB | peak MB | node CPU % | node answered (diagnostics) | search truncations '
          '| then 10 Hz answered | node alive |')
    print('|' + '---|' * 14)
    index = 0
    for algorithm in args.algorithms.split(','):
        for rate in (float(r) for r in args.rates.split(',')):
            r = soak(algorithm, rate, args, index)
            index += 1
            print(f"| {r['algorithm']} | {r['rate']:g} | {r['sent']} | {r['answered']} | "
                  f"{r['median']:.2f} | {r['p99']:.2f} | {r['rss_start']:.1f} | "
                  f"{r['rss_end']:.1f} | {r['rss_peak']:.1f} | {r['cpu']:.0f} | "
                  f"{r['node_answered']} | {r['truncations']} | {r['recovered']} | "
                  f"{r['alive']} |", flush=True)
    rclpy.shutdown()


if __name__ == '__main__':
    main()
