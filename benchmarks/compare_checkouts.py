"""associate() per scan for this checkout against other checkouts of the package, in alternating
processes (a shared machine's speed drifts: each round times every checkout once).

    git worktree add /tmp/before <commit>
    python benchmarks/compare_checkouts.py /tmp/before --algorithm jcbb --rounds 5

Scans (--scans): the clutter_range_bearing bag's scans (bag, the default) or the 12 denser
random scans (dense), those of run_benchmarks' jcbb section.  Per round
and checkout: the minimum of 7 calls per scan, then the median and the sum over the scans;
printed: the median over the rounds of both, and each checkout's ratio to this one.
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('checkouts', nargs='*', help='other checkouts (repository roots)')
    parser.add_argument('--algorithm', default='jcbb')
    parser.add_argument('--rounds', type=int, default=5)
    parser.add_argument('--scans', choices=list(SCANS), default='bag',
                        help="the clutter_range_bearing bag's scans or 12 denser random ones")
    parser.add_argument('--child', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(args.algorithm, args.scans)))
        return
    roots = [str(HERE.parent)] + [str(Path(c).resolve()) for c in args.checkouts]
    results: dict[str, list[dict]] = {root: [] for root in roots}
    for _ in range(args.rounds):
        for root in roots:
            environment = {**os.environ, 'PYTHONPATH': root}
            output = subprocess.run([sys.executable, __file__, '--child', '--algorithm',
                                     args.algorithm, '--scans', args.scans], env=environment,
                                    cwd=root, check=True, capture_output=True, text=True).stdout
            results[root].append(json.loads(output.strip().splitlines()[-1]))
    mine = {key: statistics.median(r[key] for r in results[roots[0]])
            for key in ('median_ms', 'total_ms')}
    print(f'{args.algorithm}, {SCANS[args.scans]} scans, {args.rounds} alternating rounds')
    print(f'{"checkout":<40}{"median ms":>11}{"total ms":>10}{"median x":>10}{"total x":>9}')
    for root in roots:
        median = statistics.median(r['median_ms'] for r in results[root])
        total = statistics.median(r['total_ms'] for r in results[root])
        print(f'{root:<40}{median:>11.3f}{total:>10.1f}{median / mine["median_ms"]:>10.2f}'
              f'{total / mine["total_ms"]:>9.2f}')


if __name__ == '__main__':
    main()
