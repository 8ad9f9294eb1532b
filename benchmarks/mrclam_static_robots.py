"""How many of an MRCLAM robot's sightings of the other robots are of a robot standing still,
and the correct % a range-bearing front end can reach at most when it pairs them (docs/slam.md).

    python benchmarks/mrclam_static_robots.py [1 2]

The oracle run of bags/mrclam_robot<n> (ekf_slam_node fusing the true association) gives the
posterior pose per scan; each sighting of another robot (subjects 1-5, from the raw
Robot<n>_Measurement.dat and Barcodes.dat in ../shared/data) is put in the map frame with it.  A
sighting is "static" when it lies within STILL_M of the same robot's previous sighting less than
STILL_S earlier.  A static sighting looks like a landmark seen again, so a front end that sees
only range and bearing maps and pairs it, and the score counts that pair wrong (clutter paired):
correct <= 100 (1 - static / observations).
"""
from __future__ import annotations

import os
import random
import sys
from pathlib import Path

import numpy as np

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(60, 69)))

from data_association_ros.bag.datasets import DEFAULT_DATA_DIRECTORY  # noqa: E402
from data_association_ros.bag.datasets.mrclam import FIRST_LANDMARK_SUBJECT  # noqa: E402
from data_association_ros.bag.replay import bag_parameters  # noqa: E402
from data_association_ros.bag.slam_run import (bag_slam_parameters, read_inputs,  # noqa: E402
                                               run_offline)

ROOT = Path(__file__).resolve().parents[1]
STILL_M = 0.3
"""Two sightings of one robot this close [m] in the map frame: it stood still."""
STILL_S = 30.0
"""... when taken less than this apart [s]."""


def static_sightings(robot: int) -> tuple[int, int, int]:
    """(sightings of other robots, static ones, all observations) of MRCLAM robot `robot`."""
    bag = ROOT / 'bags' / f'mrclam_robot{robot}'
    run = run_offline(read_inputs(bag), 'jcbb', 'ground_truth', bag_parameters(bag),
                      bag_slam_parameters(bag))
    folder = DEFAULT_DATA_DIRECTORY / f'utias_mrclam_ds1_robot{robot}'
    subject_of = {int(b): int(s) for s, b in
                  np.loadtxt(folder / 'Barcodes.dat', comments='#', dtype=np.int64)}
    rows = np.loadtxt(folder / f'Robot{robot}_Measurement.dat', comments='#', ndmin=2)
    stamps = np.round(rows[:, 0] * 1000).astype(np.int64) * 1_000_000
    last: dict[int, tuple[np.ndarray, int]] = {}
    robots = still = 0
    for stamp, barcode, distance, bearing in zip(stamps, rows[:, 1], rows[:, 2], rows[:, 3]):
        subject = subject_of[int(barcode)]
        if subject >= FIRST_LANDMARK_SUBJECT:
            continue
        robots += 1
        pose = run.poses[int(stamp)]
        point = pose[:2] + distance * np.array([np.cos(pose[2] + bearing),
                                                np.sin(pose[2] + bearing)])
        if subject in last and np.hypot(*(point - last[subject][0])) < STILL_M \
                and stamp - last[subject][1] < STILL_S * 1e9:
            still += 1
        last[subject] = (point, int(stamp))
    return robots, still, len(rows)


def main(argv: list[str]) -> int:
    for robot in [int(a) for a in argv] or [1, 2]:
        robots, still, observations = static_sightings(robot)
        print(f'mrclam_robot{robot}: {robots} sightings of other robots in {observations} '
              f'observations; {still} within {STILL_M} m of the same robot\'s previous sighting '
              f'(< {STILL_S:.0f} s before); correct <= {100 * (1 - still / observations):.1f} % '
              'when they are paired')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
