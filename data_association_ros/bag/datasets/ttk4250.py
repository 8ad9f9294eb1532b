"""TTK4250 simulated EKF-SLAM data set (NTNU Sensor Fusion course) as a `SlamSequence`.

Source: `ttk4250_simulated_slam/simulatedSLAM.mat` (`landmarks` 2 x 108, `poseGT` 3 x 1001,
`odometry` 3 x 1000, `z` 1000 cells of 2 x m range-bearing scans) and the derived association
`derived_gt_association.csv` (see that folder's SOURCES.md).

Alignment (checked against `poseGT`): scan z{k} is taken at poseGT(:,k) and odometry(:,k) is the
body-frame increment from poseGT(:,k) to poseGT(:,k+1) (MATLAB 1-based).  Pairing them this way
gives increment errors of std (0.050 m, 0.050 m, 0.99 deg) and range / bearing residuals of std
(0.050 m, 0.99 deg); shifting either by one step gives 0.06 m / 5.4 deg and 0.45 m / 5.4 deg.
So, with 0-based k:
- step 0: zero increment (zero covariance) and scan z{1}, at initial_pose = poseGT(:,1);
- step k >= 1: increment odometry(:,k) (1-based; the k-th column) and scan z{k+1}, true pose
  poseGT(:,k+1).
1000 steps, 9797 observations.  The last increment, odometry(:,1000) to poseGT(:,1001), has no
scan after it and is dropped.  Six odometry headings (columns 119, 355, 600, 603, 650, 896) are
near +-2 pi (e.g. -6.204 rad for a +0.079 rad turn: differences of wrapped headings); every
increment's dyaw is wrapped to (-pi, pi].

Values: (range [m], bearing [rad] relative to the heading), model 'range_bearing', in the
file's column order.  Covariances are the handout's tuning, larger than the simulated noise
in range and position (0.05 m): measurement R = diag(0.1 m, 1 deg)^2 per observation,
increment Q = diag(0.1 m, 0.1 m, 1 deg)^2.  initial_covariance is zero (the handout's
initialisation).

Truth: the CSV's `landmark` column (0-based column of `landmarks`) is the landmark id; the
single row with landmark -1 (no true landmark inside the gate) is CLUTTER with truth_certain
False; rows with ambiguous = 1 (another landmark also inside the gate; 58 rows, mostly beyond
60 m) keep their landmark id with truth_certain False.  true_pose = poseGT (heading wrapped to
(-pi, pi]); true_landmarks = id -> `landmarks` column.

Times: the data has none; step k is stamped 1 s + k * 0.1 s.

parameters: gate_probability 0.999 and joint_gate_probability 0.99999, i.e. individual
significance 1e-3 and joint 1e-5 as in the course's JCBB test vectors
(jcbb_test_vectors_ttk4250/testing/matrix.txt).  (The simulated data's SOURCES.md quotes joint 1e-3 / individual 1e-4 for the
handout; the test vectors are the ones reproduced exactly, so they are used here.)

`with_clutter` adds synthetic uniform clutter to a loaded sequence (see there).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.io

from ...core.models.base import wrap_angle
from .sequence import CLUTTER, COURSE_SIGNIFICANCE, SlamSequence, SlamStep

FOLDER = 'ttk4250_simulated_slam'
MEASUREMENT_COVARIANCE = np.diag([0.1, np.deg2rad(1.0)]) ** 2
"""Handout R: diag(0.1 m, 1 deg)^2 for (range, bearing)."""
INCREMENT_COVARIANCE = np.diag([0.1, 0.1, np.deg2rad(1.0)]) ** 2
"""Handout Q: diag(0.1 m, 0.1 m, 1 deg)^2 for (dx, dy, dyaw)."""
START_NS = 1_000_000_000
PERIOD_NS = 100_000_000


def _scan(cell) -> np.ndarray:
    """One z{k} cell as (m, 2) [range m, bearing rad] (squeeze_me turns 2 x 1 into (2,))."""
    values = np.asarray(cell, dtype=float)
    return values.reshape(2, -1).T.copy()


def load(data_directory: Path) -> SlamSequence:
    """The simulated data set in `data_directory` (the ttk4250_simulated_slam folder): 1000
    steps, 'range_bearing'."""
    data_directory = Path(data_directory)
    mat = scipy.io.loadmat(data_directory / 'simulatedSLAM.mat', squeeze_me=True,
                           struct_as_record=False)
    landmarks = np.asarray(mat['landmarks'], dtype=float).T          # (108, 2)
    poses = np.asarray(mat['poseGT'], dtype=float).T                  # (1001, 3)
    odometry = np.asarray(mat['odometry'], dtype=float).T             # (1000, 3)
    scans = [_scan(cell) for cell in mat['z']]                        # 1000 x (m, 2)
    table = np.loadtxt(data_directory / 'derived_gt_association.csv', delimiter=',',
                       comments='#', skiprows=2, dtype=float).reshape(-1, 5)
    rows = table[:, :4].astype(np.int64)                              # step, meas, lm, ambiguous

    counts = np.array([len(scan) for scan in scans])
    offsets = np.concatenate([[0], np.cumsum(counts)])
    flat = offsets[rows[:, 0]] + rows[:, 1]
    if (len(rows) != offsets[-1] or (rows[:, 1] >= counts[rows[:, 0]]).any()
            or np.bincount(flat, minlength=offsets[-1]).max() != 1):
        raise ValueError('derived_gt_association.csv does not cover every measurement once')
    flat_truth = np.empty(offsets[-1], dtype=np.int64)
    flat_certain = np.empty(offsets[-1], dtype=bool)
    flat_truth[flat] = np.where(rows[:, 2] >= 0, rows[:, 2], CLUTTER)
    flat_certain[flat] = (rows[:, 2] >= 0) & (rows[:, 3] == 0)
    truth = np.split(flat_truth, offsets[1:-1])
    certain = np.split(flat_certain, offsets[1:-1])

    steps = []
    for k, scan in enumerate(scans):
        increment = np.zeros(3) if k == 0 else odometry[k - 1].copy()
        increment[2] = wrap_angle(increment[2])
        increment_covariance = np.zeros((3, 3)) if k == 0 else INCREMENT_COVARIANCE.copy()
        true_pose = poses[k].copy()
        true_pose[2] = wrap_angle(true_pose[2])
        steps.append(SlamStep(
            time_ns=START_NS + k * PERIOD_NS, increment=increment,
            increment_covariance=increment_covariance, values=scan,
            covariances=np.broadcast_to(MEASUREMENT_COVARIANCE, (len(scan), 2, 2)).copy(),
            truth=truth[k], truth_certain=certain[k], true_pose=true_pose))
    initial_pose = poses[0].copy()
    initial_pose[2] = wrap_angle(initial_pose[2])
    return SlamSequence(
        name='ttk4250_simulated',
        description='TTK4250 simulated EKF-SLAM: 1000 range-bearing scans of 108 point '
                    'landmarks, odometry increments; truth = derived association CSV.',
        model='range_bearing', initial_pose=initial_pose, initial_covariance=np.zeros((3, 3)),
        steps=steps,
        true_landmarks={i: landmarks[i].copy() for i in range(len(landmarks))},
        parameters=dict(COURSE_SIGNIFICANCE))


CLUTTER_PARAMETERS = {'confirm_hits': 3, 'confirm_window': 3,
                      'candidate_pose_uncertainty': False}
"""association_node parameters of the clutter variants (M-of-N landmark confirmation)."""


def with_clutter(sequence: SlamSequence, per_scan: int, seed: int) -> SlamSequence:
    """`sequence` with `per_scan` synthetic clutter returns added to every scan.

    Each return is uniform in (range, bearing) over [1 m, largest observed range] x [smallest,
    largest observed bearing] of `sequence` (about 1-80 m x -90..+90 deg for the simulated
    data), truth CLUTTER (certain), covariance MEASUREMENT_COVARIANCE.  The returns are put at
    uniformly random positions of the scan; the original measurements keep their relative
    order.  Deterministic: numpy default_rng(seed), drawn scan by scan.  Name:
    '<name>_clutter<per_scan>'.  Steps are copied; the input is not changed.  parameters add
    CLUTTER_PARAMETERS: a landmark is started only after sightings in 3 scans in a row (every
    clutter return would otherwise become a map landmark in the closed loop; with 2 of 3, 402
    false landmarks in the first 300 scans with 20 clutter returns per scan, with 3 of 3: 16),
    matched with the observation noise alone (candidate_pose_uncertainty false: the filter's pose
    error is common to consecutive scans; over all 1000 scans 66 false landmarks with it, 5
    without).
    """
    if per_scan < 0:
        raise ValueError('per_scan must be >= 0')
    values = np.concatenate([step.values for step in sequence.steps])
    max_range = float(values[:, 0].max())
    low_bearing, high_bearing = float(values[:, 1].min()), float(values[:, 1].max())
    rng = np.random.default_rng(seed)
    steps = []
    for step in sequence.steps:
        count = len(step.truth)
        clutter = np.column_stack([rng.uniform(1.0, max_range, per_scan),
                                   rng.uniform(low_bearing, high_bearing, per_scan)])
        is_clutter = np.zeros(count + per_scan, dtype=bool)
        is_clutter[rng.choice(count + per_scan, size=per_scan, replace=False)] = True
        merged = np.empty((count + per_scan, 2))
        merged[~is_clutter], merged[is_clutter] = step.values, clutter
        covariances = np.empty((count + per_scan, 2, 2))
        covariances[~is_clutter], covariances[is_clutter] = step.covariances, MEASUREMENT_COVARIANCE
        truth = np.full(count + per_scan, CLUTTER, dtype=np.int64)
        truth[~is_clutter] = step.truth
        certain = np.ones(count + per_scan, dtype=bool)
        certain[~is_clutter] = step.truth_certain
        steps.append(replace(step, increment=step.increment.copy(),
                             increment_covariance=step.increment_covariance.copy(),
                             values=merged, covariances=covariances, truth=truth,
                             truth_certain=certain,
                             true_pose=None if step.true_pose is None else step.true_pose.copy()))
    return replace(sequence, name=f'{sequence.name}_clutter{per_scan}',
                   description=f'{sequence.description} Plus {per_scan} uniform clutter returns '
                               f'per scan (seed {seed}).',
                   steps=steps, parameters={**sequence.parameters, **CLUTTER_PARAMETERS})
