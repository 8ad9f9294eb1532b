"""The README's score tables: every bag, live (replayed through association_node at --rate)
and offline (throughput), as markdown.

    python benchmarks/bag_score_tables.py [--rate 2] [bags/NAME ...]
"""
from __future__ import annotations

import argparse
import os
import random
import sys
from pathlib import Path

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(20, 90)))

from data_association_ros.bag.evaluate import (bag_algorithms, evaluate_live,  # noqa: E402
                                               evaluate_offline)
from data_association_ros.bag.replay import bag_parameters  # noqa: E402
from run_benchmarks import machine_line  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def bag_table(bag: Path, rate: float) -> str:
    """One markdown table: a row per algorithm the bag names."""
    overrides = bag_parameters(bag)
    lines = [f'`{bag.name}`:', '',
             '| algorithm | precision | recall | new ok | new false | clutter paired | '
             'latency p50 / p99 ms | offline scans/s |', '|---|---|---|---|---|---|---|---|']
    for algorithm in bag_algorithms(bag):
        live = evaluate_live(bag, algorithm, overrides, rate)
        offline = evaluate_offline(bag, algorithm, overrides)
        for key in ('pair_precision', 'pair_recall', 'new_correct', 'new_false',
                    'clutter_paired'):
            if live[key] != offline[key]:
                raise SystemExit(f'{bag} {algorithm}: live {key} {live[key]} != offline '
                                 f'{offline[key]}')
        lines.append(
            f'| {algorithm} | {live["pair_precision"]:.3f} | {live["pair_recall"]:.3f} | '
            f'{live["new_correct"]} | {live["new_false"]} | '
            f'{live["clutter_paired"]}/{live["clutter"]} | {live["latency_median_ms"]:.2f} / '
            f'{live["latency_p99_ms"]:.2f} | {offline["scans_per_s"]:.0f} |')
    return '\n'.join(lines) + '\n'


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('bags', nargs='*', type=Path,
                        default=[ROOT / 'bags' / name for name in (
                            'easy_point_map', 'clutter_range_bearing', 'exploration', 'boxes')])
    parser.add_argument('--rate', type=float, default=2.0)
    args = parser.parse_args(argv)
    print(f'Scores ({machine_line()}; live at --rate {args.rate:g})\n')
    for bag in args.bags:
        print(bag_table(bag, args.rate), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
