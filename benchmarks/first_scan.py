"""The first scan of a freshly started association_node against its later scans (no DDS).

For each algorithm, a new Python process creates the node (its constructor returns once it is
ready: parameters, topics and the start-up warm-up of pipelines/warm_up.py), then hands it
node_latency's K-observation scans through its subscription callbacks, one at a time, and times
each callback (conversion, association, publishing on the node's real topics).  Prints the time
to ready, the first scan, the median and p99 of the next ones and first / median; with
--no-warm-up the node is built without the warm-up (what the first scan cost before it).

    python benchmarks/first_scan.py [--algorithms mahalanobis_nn,gnn,jcbb] [--scans 100]
                                    [--runs 3] [--no-warm-up]

With --runs R each algorithm is started R times: first = the median of the R first scans,
median / p99 over all later scans.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(20, 90)))


def child(algorithm: str, scans: int, warm: bool, observations: int, landmarks: int) -> None:
    """Runs in the fresh process: prints one JSON line of timings [ms]."""
    started = time.perf_counter()
    from data_association_ros.nodes import association_node  # first: one BLAS thread
    import numpy as np
    import rclpy
    from rclpy.parameter import Parameter
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Header

    from msg_adapters import array_to_cloud, odometry_message
    from node_latency import scene
    if not warm:
        association_node.warm_up = lambda config: {}
    rclpy.init()
    node = association_node.AssociationNode(
        parameter_overrides=[Parameter('algorithm', value=algorithm)])
    ready_ms = (time.perf_counter() - started) * 1e3
    landmark_points, observation_points, pose = scene(observations, landmarks)
    pose_covariance = np.diag([0.01, 0.01, 0.003])
    times = []
    for k in range(scans):
        stamp = Header(frame_id='map')
        stamp.stamp.sec = 1000 + k
        node.pipeline.on_landmarks(array_to_cloud(landmark_points, stamp))
        odometry = odometry_message(stamp, pose, pose_covariance)
        node._on_robot_pose(odometry)
        message = serialize_message(array_to_cloud(
            observation_points, Header(stamp=stamp.stamp, frame_id='base_link')))
        t0 = time.perf_counter()
        node._on_serialized_observations(message)   # as the raw subscription delivers it
        times.append((time.perf_counter() - t0) * 1e3)
    node.destroy_node()
    rclpy.shutdown()
    print(json.dumps({'ready_ms': ready_ms, 'times': times,
                      'compiled': node.start_up_seconds.get('compiled')}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--algorithms', default='mahalanobis_nn,gnn,jcbb')
    parser.add_argument('--scans', type=int, default=100)
    parser.add_argument('--observations', type=int, default=50)
    parser.add_argument('--landmarks', type=int, default=200)
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--no-warm-up', action='store_true')
    parser.add_argument('--child', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.scans, not args.no_warm_up, args.observations, args.landmarks)
        return
    import numpy as np
    print(f'K={args.observations} observations, N={args.landmarks} landmarks, {args.scans} '
          f'scans, warm-up {"off" if args.no_warm_up else "on"}')
    print(f'{"algorithm":<16}{"ready ms":>10}{"first ms":>10}{"median ms":>11}{"p99 ms":>9}'
          f'{"first/median":>14}')
    here = os.path.dirname(os.path.abspath(__file__))
    for algorithm in args.algorithms.split(','):
        command = [sys.executable, os.path.abspath(__file__), '--child', algorithm,
                   '--scans', str(args.scans), '--observations', str(args.observations),
                   '--landmarks', str(args.landmarks)] + (['--no-warm-up'] if args.no_warm_up
                                                          else [])
        firsts, later, ready = [], [], []
        for _ in range(args.runs):
            output = subprocess.run(command, capture_output=True, text=True, check=True,
                                    env={**os.environ, 'PYTHONPATH': here + os.pathsep +
                                         os.environ.get('PYTHONPATH', '')}).stdout
            result = json.loads(output.strip().splitlines()[-1])
            firsts.append(result['times'][0])
            later += result['times'][1:]
            ready.append(result['ready_ms'])
        first, median = float(np.median(firsts)), float(np.median(later))
        print(f'{algorithm:<16}{np.median(ready):>10.0f}{first:>10.2f}{median:>11.2f}'
              f'{np.percentile(later, 99):>9.2f}{first / median:>14.2f}')


if __name__ == '__main__':
    main()
