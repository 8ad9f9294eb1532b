"""associate() per scan, or the LiDAR tracker's step per scan, for this checkout against other
checkouts of the package, in alternating processes (a shared machine's speed drifts: each round
times every checkout once).

    git worktree add /tmp/before <commit>
    python benchmarks/compare_checkouts.py /tmp/before --algorithm jcbb --rounds 5
    python benchmarks/compare_checkouts.py /tmp/before --lidar race --rounds 5

Scans (--scans): the clutter_range_bearing bag's scans (bag, the default) or the 12 denser
random scans (dense), those of run_benchmarks' jcbb section.  Per round
and checkout: the minimum of 7 calls per scan, then the median and the sum over the scans;
printed: the median over the rounds of both, and each checkout's ratio to this one.

--lidar race: the core tracker (pipelines.lidar_tracking, as da_lidar_eval offline) over the
lidar_f1tenth_race bag with the F1Tenth preset, twice per round; --lidar KIND (car_static,
f1tenth_moving, ...): generated scenes of that kind, seeds 100-102, with the kind's preset.
Per round and checkout: the median and 95th percentile of the step times [ms] over the scans.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCANS = {'bag': 'clutter_range_bearing', 'dense': 'dense random'}
"""--scans: the scan set's name."""


def measure(algorithm: str, scans: str) -> dict:
    """Per-scan minima over `scans` ('bag' or 'dense') with the package on sys.path (child
    process)."""
    sys.path[:0] = [str(HERE), str(HERE.parent / 'test')]
    import numpy as np
    from run_benchmarks import bag_scenes, hard_scans

    from data_association_ros.core.api import associate
    scenes = bag_scenes((2, 5)) if scans == 'bag' else hard_scans(12)
    inputs = [scene.inputs() for scene in scenes]
    for each in inputs:
        associate(**each, algorithm=algorithm)
    minima = []
    for each in inputs:
        times = []
        for _ in range(7):
            started = time.perf_counter()
            associate(**each, algorithm=algorithm)
            times.append(time.perf_counter() - started)
        minima.append(min(times))
    return {'median_ms': float(np.median(minima)) * 1e3, 'total_ms': float(np.sum(minima)) * 1e3}


def measure_lidar(workload: str) -> dict:
    """Median and p95 [ms] of the tracker's step per scan on `workload` (--lidar) with the
    package on sys.path (child process)."""
    import numpy as np

    from data_association_ros.bag.lidar_eval import read_scans, run_offline, scans_from_messages
    from data_association_ros.bag.lidar_seeds import configuration
    from data_association_ros.core.lidar import TrackerConfig
    if workload == 'race':
        runs = [read_scans(HERE.parent / 'bags' / 'lidar_f1tenth_race')] * 2
        config = configuration('race', TrackerConfig())
    else:
        from data_association_ros.bag.lidar_random_scene import KINDS
        runs = [scans_from_messages(KINDS[workload](seed).messages()) for seed in (100, 101, 102)]
        config = configuration(workload, TrackerConfig())
    run_offline(runs[0], config)   # imports loaded, kernels compiled (a fresh checkout: seconds)
    elapsed = np.concatenate([run_offline(scans, config)[1] for scans in runs])
    return {'median_ms': float(np.median(elapsed)), 'p95_ms': float(np.percentile(elapsed, 95))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('checkouts', nargs='*', help='other checkouts (repository roots)')
    parser.add_argument('--algorithm', default='jcbb')
    parser.add_argument('--rounds', type=int, default=5)
    parser.add_argument('--scans', choices=list(SCANS), default='bag',
                        help="the clutter_range_bearing bag's scans or 12 denser random ones")
    parser.add_argument('--lidar', metavar='WORKLOAD',
                        help="the LiDAR tracker's step instead: race (the F1Tenth race bag) or "
                             'a generated scene kind')
    parser.add_argument('--child', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure_lidar(args.lidar) if args.lidar else
                         measure(args.algorithm, args.scans)))
        return
    roots = [str(HERE.parent)] + [str(Path(c).resolve()) for c in args.checkouts]
    workload = ['--lidar', args.lidar] if args.lidar else ['--algorithm', args.algorithm,
                                                           '--scans', args.scans]
    results: dict[str, list[dict]] = {root: [] for root in roots}
    for _ in range(args.rounds):
        for root in roots:
            environment = {**os.environ, 'PYTHONPATH': root}
            output = subprocess.run([sys.executable, __file__, '--child', *workload],
                                    env=environment, cwd=root, check=True, capture_output=True,
                                    text=True).stdout
            results[root].append(json.loads(output.strip().splitlines()[-1]))
    keys = ('median_ms', 'p95_ms') if args.lidar else ('median_ms', 'total_ms')
    mine = {key: statistics.median(r[key] for r in results[roots[0]]) for key in keys}
    print(f'LiDAR tracker step, {args.lidar}' if args.lidar else
          f'{args.algorithm}, {SCANS[args.scans]} scans', f'{args.rounds} alternating rounds',
          sep=', ')
    names = [key.replace('_ms', '') for key in keys]
    print(f'{"checkout":<40}' + ''.join(f'{n + " ms":>11}' for n in names)
          + ''.join(f'{n + " x":>10}' for n in names))
    for root in roots:
        values = [statistics.median(r[key] for r in results[root]) for key in keys]
        print(f'{root:<40}' + ''.join(f'{v:>11.3f}' for v in values)
              + ''.join(f'{v / mine[k]:>10.2f}' for v, k in zip(values, keys)))


if __name__ == '__main__':
    main()
