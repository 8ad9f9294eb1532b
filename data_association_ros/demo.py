"""A short demo of the library on a built-in scan: every algorithm on the same problem.

The scan: four landmarks 10 m ahead, a 0.12 rad yaw error shared by all observations (so each
observation lies nearer a wrong neighbour), plus one clutter return.  Run: `da_demo`.
"""
from __future__ import annotations

import argparse
from typing import Optional

import numpy as np

from . import Landmarks, Observations, RobotPose, associate, available_algorithms
from .core.associators import REGISTRY


def built_in_scan():
    """(landmarks, observations, pose, true assignment) of the demo scan."""
    bearings = np.array([0.0, 0.2, 0.4, 0.6])
    means = 10.0 * np.column_stack([np.cos(bearings), np.sin(bearings)])
    landmarks = Landmarks([0, 1, 2, 3], means, np.tile(np.eye(2) * 1e-4, (4, 1, 1)))
    pose = RobotPose([0.0, 0.0, 0.0], np.diag([1e-4, 1e-4, 0.1 ** 2]))
    values = np.vstack([np.column_stack([np.full(4, 10.0), bearings - 0.12]), [[4.0, -2.0]]])
    observations = Observations(values, np.tile(np.diag([0.01, 1e-4]), (5, 1, 1)),
                                'range_bearing')
    return landmarks, observations, pose, np.array([0, 1, 2, 3, -1])


def main(argv: Optional[list[str]] = None) -> None:
    """Print each algorithm's assignment and how many observations it got right."""
    argparse.ArgumentParser(prog='da_demo', description=' '.join(__doc__.split())).parse_args(
        argv)
    landmarks, observations, pose, truth = built_in_scan()
    print('range-bearing scan, shared yaw error 0.12 rad, truth:', truth.tolist())
    print(f'{"algorithm":<20}{"assignment":<26}{"correct":>8}')
    for name in available_algorithms():
        if observations.model not in REGISTRY[name].models:
            continue
        result = associate(landmarks, observations, name, pose=pose)
        correct = int((result.assignment == truth).sum())
        print(f'{name:<20}{str(result.assignment.tolist()):<26}{correct:>5}/{len(truth)}')


if __name__ == '__main__':
    main()
