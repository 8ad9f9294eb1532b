"""Filter consistency of SLAM runs: NIS of the EKF updates and NEES of the posterior pose.

    python -m data_association_ros.bag.slam_consistency [BAGS] [--modes ground_truth] [-s ...]

NIS per update: nu^T S^-1 nu of the stacked update of a scan, with dof = 2 x the fused
observations; NEES per scan with a true pose: e^T P^-1 e, e = true - estimated (x, y, yaw;
yaw wrapped), P = the posterior pose covariance (3 dof; scans whose P is singular, e.g. before
any motion with a zero initial covariance, are left out).  For a consistent filter both are
chi-square distributed (Bar-Shalom, Li & Kirubarajan 2001, 5.4): the ratio sum(value) /
sum(dof) is near 1 and 95 % of the values lie inside the two-sided 95 % interval
[chi2(0.025, dof), chi2(0.975, dof)].  Ratio > 1 (many values above the interval) = the filter
is overconfident; < 1 = too cautious.  NEES needs the estimate in the truth's frame: it is
computed only on bags whose initial pose is the true one (the ekf_slam_node parameters of the
bag put the filter there), i.e. bags with /ground_truth/pose.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Optional

import numpy as np
from scipy.stats import chi2

from ..core.models.base import wrap_angle
from .parameter_arguments import parse_assignments
from ..pipelines.slam import SLAM_BY_NAME
from .replay import bag_parameters
from .slam_eval import read_slam_truth, slam_bags
from .slam_run import MODES, SlamRun, bag_slam_parameters, read_inputs, run_offline
from .slam_scoring import SlamTruth

INTERVAL = 0.95


def chi_square_summary(values: np.ndarray, dof: np.ndarray) -> dict[str, float]:
    """ratio = sum(values) / sum(dof); inside / above = fraction of the values inside / above
    the two-sided INTERVAL chi-square interval of their dof; count."""
    values, dof = np.asarray(values, dtype=float), np.asarray(dof, dtype=float)
    if values.size == 0:
        return {'ratio': float('nan'), 'inside': float('nan'), 'above': float('nan'),
                'count': 0}
    tail = (1.0 - INTERVAL) / 2.0
    low, high = chi2.ppf(tail, dof), chi2.ppf(1.0 - tail, dof)
    return {'ratio': float(values.sum() / dof.sum()),
            'inside': float(np.mean((values >= low) & (values <= high))),
            'above': float(np.mean(values > high)), 'count': int(values.size)}


def update_nis(run: SlamRun) -> dict[str, float]:
    """chi_square_summary of the joint NIS of the run's EKF updates (those with >= 1 pair)."""
    pairs = [(nis, dof) for nis, dof in run.update_nis.values() if dof > 0]
    return chi_square_summary(np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))


def pose_nees(run: SlamRun, truth: SlamTruth) -> dict[str, float]:
    """chi_square_summary of the posterior pose NEES over the scans with a true pose."""
    values = []
    for stamp, true_pose in truth.poses.items():
        if stamp not in run.poses or stamp not in run.pose_covariances:
            continue
        error = np.asarray(true_pose, dtype=float) - run.poses[stamp]
        error[2] = wrap_angle(error[2])
        covariance = run.pose_covariances[stamp]
        try:
            factor = np.linalg.cholesky(covariance)
        except np.linalg.LinAlgError:
            continue
        whitened = np.linalg.solve(factor, error)
        values.append(float(whitened @ whitened))
    return chi_square_summary(np.array(values), np.full(len(values), 3.0))


def consistency(bag: Path, mode: str = 'ground_truth', algorithm: str = 'jcbb',
                steps: Optional[int] = None,
                slam_overrides: Optional[dict[str, Any]] = None) -> dict[str, Any]:
    """NIS and NEES summaries of one offline run of `bag`."""
    messages = read_inputs(bag, steps)
    run = run_offline(messages, algorithm, mode, bag_parameters(bag),
                      {**bag_slam_parameters(bag), **(slam_overrides or {})})
    truth = read_slam_truth(bag, steps)
    return {'bag': bag.name, 'mode': mode, 'nis': update_nis(run),
            'nees': pose_nees(run, truth)}


def format_row(row: dict[str, Any]) -> str:
    """One markdown row: bag, mode, NIS ratio / inside / above, NEES ratio / inside / above."""
    def cells(summary):
        if not summary['count']:
            return ['-', '-', '-']
        return [f'{summary["ratio"]:.2f}', f'{100 * summary["inside"]:.1f}',
                f'{100 * summary["above"]:.1f}']
    mode = 'oracle' if row['mode'] == 'ground_truth' else 'closed'
    return '| ' + ' | '.join([row['bag'], mode, str(row['nis']['count']), *cells(row['nis']),
                              str(row['nees']['count']), *cells(row['nees'])]) + ' |'


HEADER = ('| bag | mode | updates | NIS / dof | NIS in 95 % % | NIS above % | scans with true '
          'pose | NEES / 3 | NEES in 95 % % | NEES above % |\n|' + '---|' * 10)


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog='slam_consistency',
                                     description=' '.join(__doc__.split('\n\n')[0].split()))
    parser.add_argument('bags', type=Path, nargs='*')
    parser.add_argument('--modes', default='ground_truth')
    parser.add_argument('--steps', type=int)
    parser.add_argument('-s', dest='slam_parameters', action='append', default=[],
                        metavar='NAME:=VALUE', help='ekf_slam_node parameter (repeatable)')
    args = parser.parse_args(argv)
    overrides = parse_assignments(args.slam_parameters, SLAM_BY_NAME)
    print(HEADER, flush=True)
    for bag in args.bags or slam_bags():
        for mode in args.modes.split(','):
            if mode not in MODES:
                parser.error(f'--modes: valid are {", ".join(MODES)}')
            print(format_row(consistency(bag, mode, steps=args.steps,
                                         slam_overrides=overrides)), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
