"""DLR Spatial Cognition data set (MATLAB conversion from GitHub sunzuolei/jcbb) as a
`SlamSequence`.

Source: `dlr_spatial_cognition/landmark.mat` (per step `z` 2 x m [m], `R` 2 x 2 x m [m^2],
`ID` m), `relMotion.mat` (per step `x` (dx, dy, dyaw) [m, m, rad], `P` 3 x 3) and `truth.mat`
(`x` 3 x 3298 poses, heading unwrapped); see that folder's SOURCES.md.

Alignment: step k (0-based, 3297 steps) = increment relMotion(k) then scan landmark(k), taken at
truth.x(:, k+1) (0-based column k+1, i.e. after the motion).  Determined empirically: projecting
every observation into the world with the truth pose after relMotion(k), the observations of
one ID lie 0.088 m RMS (median 0.042 m) from their ID's mean; with the pose before the motion,
0.247 m RMS (median 0.162 m).  relMotion(k) also matches the truth increment from column k to
k+1 (errors std 3 mm, 3 mm, 0.47 deg; dy is biased by -4.8 mm per step).  initial_pose = truth.x(:, 1) (zero), zero covariance.
true_pose = truth.x(:, k+1) with the heading wrapped to (-pi, pi].  truth.P is not used; whether
`truth` is an external measurement or a smoothed estimate is not stated by the source.

Values: z in the robot frame (x, y) [m], model 'point_robot' (z = R(-yaw) (l - p)), covariances
the file's R per observation; increment covariance the file's P.  Nothing is subsampled; the
118 steps without observations are kept (they carry motion).  14237 observations.

Truth: ID is the landmark id.  ID 23001 (21 observations at steps 2213-2216 and 2528-2546) is
outside the numbering of the other 559 IDs (1..589) and its meaning is not documented; its
observations project to one point (within 0.14 m, 0.78 m from the nearest other ID), so it is
kept as landmark 23001 (not CLUTTER) but with truth_certain False, left out of the scores.
All other observations are certain.  There is no landmark map: true_landmarks is None.
Note: a few labels look wrong: 15 observations of IDs 22, 179, 191 and 331 project more than
1 m from their ID's median position (e.g. ID 179 at steps 3015-3017, 2.6 m from its other 23
observations); the labels are kept as they are.

Times: the data has none; step k is stamped 1 s + k * 0.1 s.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.io

from ...core.models.base import wrap_angle
from .sequence import COURSE_SIGNIFICANCE, SlamSequence, SlamStep

FOLDER = 'dlr_spatial_cognition'
UNCERTAIN_ID = 23001
START_NS = 1_000_000_000
PERIOD_NS = 100_000_000
POSE_RECOVERY = {'recovery_position_std': 0.1, 'recovery_yaw_std': 0.05, 'recovery_min_new': 2}
"""association_node parameters for the DLR odometry's outliers (46 increments beyond the 99.9 %
chi2 of their covariance; step 884: 6 sigma in dy, 2 sigma in yaw, and all 9 landmarks of the
scan leave their gates): a scan that would start mostly new landmarks is associated again with
10 cm / 0.05 rad more pose noise (core/pose_recovery.py).  Full bag, jcbb closed loop: 97.08 %
correct without, 98.01 % with (0.2 m / 0.1 rad: 97.40 %)."""
MAP_REFINDING = {'refind_window_scans': 15, 'refind_min_landmarks': 7}
"""association_node parameters for DLR's loop closures (core/map_refinding.py): the filter
comes back 4-5 m and 10-20 deg off at the last one; the last 15 scans' observations registered
against the landmarks first seen 300 or more scans earlier.  Full bag, jcbb closed loop, with 8
landmarks to match (the default): 98.01 -> 98.78 % correct, duplicates 144 -> 77, pose RMSE
2.35 -> 0.99 m.  7 also takes the robot's return to its start at scan 1210 (7 old landmarks
matched), whose shifted copy of the first landmarks was most of the duplicates left after the
merging: with 7 and the 0.13 m floor below (8 and 0.15 m before), maximum_likelihood 98.30 ->
98.40 %, duplicates 29 -> 14; jcbb 97.93 -> 98.07 % (30 -> 15).  With 7 at 0.15 m, jcbb gives
97.20 % (18).  6 registers a wrong alignment (97.10 % with maximum_likelihood at 0.13 m)
(docs/slam.md, "DLR's set since 2026-12-06")."""
LANDMARK_MERGING = {'merge_probability': 0.99, 'merge_floor': 0.13}
"""ekf_slam_node parameters of the bag: merge two landmarks no scan saw together whose
difference passes the 0.99 chi-square test with 0.13 m of independent noise added to it (the
filter's covariances are centimetres while its pose drifts metres; core/slam/
landmark_management.py).  Full bag, closed loop, with the re-finding above: floors 0.12-0.15
give maximum_likelihood 98.28-98.40 % with 12-15 duplicates, 0.12-0.13 keep jcbb and
mahalanobis_nn at 98.04-98.12 % with 14-16; 0.10 loses the map (95.58 %, 47), 0.16 97.85 %
(docs/slam.md)."""


def _load(path: Path, name: str):
    return scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)[name]


def load(data_directory: Path) -> SlamSequence:
    """The DLR data set in `data_directory` (the dlr_spatial_cognition folder): 3297 steps,
    'point_robot'."""
    data_directory = Path(data_directory)
    landmarks = _load(data_directory / 'landmark.mat', 'landmark')
    motions = _load(data_directory / 'relMotion.mat', 'relMotion')
    truth = _load(data_directory / 'truth.mat', 'truth')
    poses = np.asarray(truth.x, dtype=float).T                        # (3298, 3)
    if not len(landmarks) == len(motions) == len(poses) - 1:
        raise ValueError('landmark, relMotion and truth.x lengths do not line up')
    steps = []
    for k, (scan, motion) in enumerate(zip(landmarks, motions)):
        count = np.size(scan.ID)
        ids = np.atleast_1d(np.asarray(scan.ID)).astype(np.int64)
        true_pose = poses[k + 1].copy()
        true_pose[2] = wrap_angle(true_pose[2])
        steps.append(SlamStep(
            time_ns=START_NS + k * PERIOD_NS,
            increment=np.asarray(motion.x, dtype=float).reshape(3).copy(),
            increment_covariance=np.asarray(motion.P, dtype=float).reshape(3, 3).copy(),
            values=np.asarray(scan.z, dtype=float).reshape(2, count).T.copy(),
            covariances=np.asarray(scan.R, dtype=float).reshape(2, 2, count)
            .transpose(2, 0, 1).copy(),
            truth=ids, truth_certain=ids != UNCERTAIN_ID, true_pose=true_pose))
    initial_pose = poses[0].copy()
    initial_pose[2] = wrap_angle(initial_pose[2])
    return SlamSequence(
        name='dlr_spatial_cognition',
        description='DLR Spatial Cognition: 3297 steps of odometry and Cartesian robot-frame '
                    'observations of white circles; truth = the data set IDs (23001 uncertain).',
        model='point_robot', initial_pose=initial_pose, initial_covariance=np.zeros((3, 3)),
        steps=steps, true_landmarks=None,
        parameters={**COURSE_SIGNIFICANCE, **POSE_RECOVERY, **MAP_REFINDING},
        slam_parameters=dict(LANDMARK_MERGING))
