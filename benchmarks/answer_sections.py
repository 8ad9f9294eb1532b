"""Where AssociationPipeline.answer spends a scan of node_latency's scene (K range-bearing
observations, N landmarks), per section, with caches as cold as in association_node: each scan
follows a sleep and a pass over 32 MB (another process's work), as a node's scan follows ~20 ms
of idling.  Checkouts alternate in child processes (a shared machine's speed drifts).

    python benchmarks/answer_sections.py [DIR ...] [--algorithm mahalanobis_nn] [--rounds 3]
                                         [--scans 150] [--sleep 0.02]

Per checkout: the median over the rounds of each section's median over the scans [us]; a
section is the time inside the functions the pipeline module calls by that name (those a
checkout lacks are left out), 'other' the rest of answer().
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
SECTIONS = ('cloud_to_array', 'cloud_points', 'observations_from_points',
            'associate_with_pose_recovery', 'observations_in_map', 'correspondences_cloud')
"""The functions of pipelines/association.py timed as sections (module-level names)."""


def measure(algorithm: str, scans: int, sleep: float) -> dict[str, float]:
    """Median [us] per section over `scans` cold scans, in this process (child)."""
    sys.path.insert(0, str(HERE))
    import numpy as np
    from node_latency import POSE_COVARIANCE, scene
    from std_msgs.msg import Header

    import data_association_ros.pipelines.association as pipeline_module
    from data_association_ros.pipelines.parameters import NODE_PARAMETERS
    from data_association_ros.pipelines.warm_up import warm_up
    from msg_adapters import array_to_cloud, odometry_message

    spent: dict[str, float] = defaultdict(float)

    def timed(function, name):
        def wrapper(*args, **kwargs):
            started = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                spent[name] += time.perf_counter() - started
        return wrapper
    for name in SECTIONS:
        if hasattr(pipeline_module, name):
            setattr(pipeline_module, name, timed(getattr(pipeline_module, name), name))
    pipe_class = pipeline_module.AssociationPipeline
    pipe_class._confirm = timed(pipe_class._confirm, 'candidates (_confirm)')
    pipe_class.inputs_pending = timed(pipe_class.inputs_pending, 'inputs_pending')
    config = {parameter.name: parameter.default for parameter in NODE_PARAMETERS}
    config['algorithm'] = algorithm
    warm_up(config)
    pipeline = pipe_class(config)
    landmark_points, observation_points, pose = scene(50, 200)
    thrash = np.zeros(4_000_000)
    samples = defaultdict(list)
    for k in range(scans + 20):
        header = Header(frame_id='map')
        header.stamp.sec = 1000 + k
        pipeline.on_landmarks(array_to_cloud(landmark_points, header))
        pipeline.on_robot_pose(odometry_message(header, pose, POSE_COVARIANCE))
        scan = array_to_cloud(observation_points, Header(stamp=header.stamp, frame_id='base'))
        thrash += 1.0
        time.sleep(sleep)
        spent.clear()
        pipeline.inputs_pending(scan)
        started = time.perf_counter()
        if pipeline.answer(scan, frozenset()) is None:
            raise RuntimeError('a scan was not answered')
        total = time.perf_counter() - started
        for name, seconds in spent.items():
            samples[name].append(seconds)
        samples['other'].append(total - sum(s for n, s in spent.items() if n != 'inputs_pending'))
        samples['answer (total)'].append(total)
    return {name: float(np.median(values[20:])) * 1e6 for name, values in samples.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('checkouts', nargs='*', help='other checkouts (repository roots)')
    parser.add_argument('--algorithm', default='mahalanobis_nn')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--scans', type=int, default=150)
    parser.add_argument('--sleep', type=float, default=0.02)
    parser.add_argument('--child', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(args.algorithm, args.scans, args.sleep)))
        return
    roots = [str(HERE.parent)] + [str(Path(c).resolve()) for c in args.checkouts]
    results: dict[str, list[dict]] = {root: [] for root in roots}
    for _ in range(args.rounds):
        for root in roots:
            output = subprocess.run(
                [sys.executable, __file__, '--child', '--algorithm', args.algorithm, '--scans',
                 str(args.scans), '--sleep', str(args.sleep)], cwd='/', check=True,
                env={**os.environ, 'PYTHONPATH': root}, capture_output=True, text=True).stdout
            results[root].append(json.loads(output.strip().splitlines()[-1]))
    print(f'{args.algorithm}, K=50 N=200, {args.scans} cold scans x {args.rounds} rounds [us]')
    for root in roots:
        names = results[root][0]
        print(root)
        for name in names:
            print(f'  {name:<32}{statistics.median(r[name] for r in results[root]):8.0f}')


if __name__ == '__main__':
    main()
