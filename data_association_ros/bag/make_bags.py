"""da_make_bags: regenerate the bags deterministically (bags/<name>/): simulated scenarios and
the real data sets converted from ../shared/data (bag/datasets).

Messages are built from fixed seeds and serialised by rclpy; its CDR leaves alignment padding
uninitialised, so two runs give the same messages when deserialised, not always the same bytes
(the tests compare deserialised messages).
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import Optional

from .scenarios import SCENARIOS
from . import topics
from .topics import scan_messages
from .writer import BagWriter

PARAMETERS_KEY = 'data_association_ros.parameters'
ALGORITHMS_KEY = 'data_association_ros.algorithms'
DEFAULT_DIRECTORY = Path(__file__).resolve().parents[2] / 'bags'


def _raw_bags() -> dict:
    """Bags that are not association scenarios: name -> generator of (topic, msg, log time)."""
    from .lidar_random_scene import scene_messages
    from .lidar_scene import lidar_messages
    return {'lidar_two_cars': lidar_messages,
            'lidar_f1tenth_race': scene_messages('lidar_f1tenth_race'),
            'lidar_urban_random': scene_messages('lidar_urban_random')}


def make_bag(name: str, directory: Path, data: Optional[Path] = None) -> Path:
    """Write bags/<name>/ (metadata.yaml + <name>_0.mcap) from scenario, raw bag or data set
    (converted from `data`, the shared data directory) `name`."""
    from .datasets import DEFAULT_DATA_DIRECTORY, SEQUENCES
    target = directory / name
    if target.exists():
        shutil.rmtree(target)
    if name in SEQUENCES:
        from .datasets.slam_bags import custom_data, sequence_messages
        sequence = SEQUENCES[name](data or DEFAULT_DATA_DIRECTORY)
        custom, messages = custom_data(sequence), sequence_messages(sequence)
    elif name in SCENARIOS:
        scenario = SCENARIOS[name]
        custom = {PARAMETERS_KEY: json.dumps(scenario.parameters, sort_keys=True),
                  ALGORITHMS_KEY: ','.join(scenario.algorithms)}
        messages = (m for scan in scenario.generate() for m in scan_messages(scan))
    else:
        custom, messages = {}, _raw_bags()[name]()
    prior_map = json.loads(custom.get(PARAMETERS_KEY, '{}')).get('prior_map', False)
    with BagWriter(target, name, custom_data=custom,
                   transient_local_topics=(topics.LANDMARKS,) if prior_map else ()) as bag:
        for topic, msg, log_time in messages:
            bag.write(topic, msg, log_time)
    return target


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='da_make_bags',
                                     description=' '.join(__doc__.split('\n\n')[0].split()))
    from .datasets import DEFAULT_DATA_DIRECTORY, SEQUENCES
    names = list(SCENARIOS) + list(_raw_bags()) + list(SEQUENCES)
    parser.add_argument('names', nargs='*', default=names,
                        help=f'bags (default: all of {", ".join(names)})')
    parser.add_argument('--out', type=Path, default=DEFAULT_DIRECTORY,
                        help='directory of the bags (default: the repository\'s bags/)')
    parser.add_argument('--data', type=Path, default=DEFAULT_DATA_DIRECTORY,
                        help='the shared data directory the real data sets are converted from '
                             '(default: <repo>/../shared/data)')
    args = parser.parse_args(argv)
    for name in args.names:
        if name not in names:
            parser.error(f'unknown bag {name!r} (valid: {", ".join(names)})')
        path = make_bag(name, args.out, args.data)
        size = sum(f.stat().st_size for f in path.iterdir())
        print(f'{path}: {size / 1e6:.2f} MB')
    return 0


if __name__ == '__main__':
    sys.exit(main())
