"""UTIAS MRCLAM Dataset 1, Robot 1 (and, unchanged, Robot 2), as a `SlamSequence`.

Source: `utias_mrclam_ds1_robot<n>/` `Robot<n>_Odometry.dat` (time [s], v [m/s], w [rad/s]),
`Robot<n>_Measurement.dat` (time [s], barcode, range [m], bearing [rad]), `Barcodes.dat`,
`Landmark_Groundtruth.dat`; see that folder's SOURCES.md.  Every choice below (covariances,
calibration) was made on robot 1; robot 2 (same room, same time, same landmarks) is converted
with the same code and constants, as data nothing was tuned on.

Steps: one per distinct measurement time stamp (rows with the same stamp form one scan, in file
order); all scans and measurements are kept (robot 1: 3774 scans, 5723 measurements; robot 2:
4447 scans, 6699 measurements).  time_ns = the Unix time (the files have
millisecond stamps; converted exactly).

Increments: the odometry is integrated as a zero-order hold, sample i's (v, w) applying from
its time until the next sample's (the last sample holds on), on the grid of all odometry and
scan times, with the exact constant-(v, w) arc per grid interval (chord v dt sinc(w dt / 2) at
angle w dt / 2).  The arcs are accumulated into one dead-reckoning path in the frame of the
first odometry sample (numpy cumulative sums); step k's increment is the SE(2) difference of the
path between scan k-1 and scan k (for step 0: between the first odometry sample and scan 0).
Gaps in the odometry (robot 1: 11 longer than 0.5 s, the longest 1.0 s) are bridged by the
hold.  Odometry rows with the stamp of the next row (none for robot 1; 9 for robot 2, 8 of them
exact repeats) would hold for zero time: only the last row of a stamp is kept.

Increment covariance (the data gives none; a choice): diagonal in the previous robot frame,
  var_x = var_y = (0.005 m)^2 + 0.04 m * d,
  var_yaw = (0.005 rad)^2 + 0.025 rad * a + 0.01 rad^2/m * d,
with d = integral of |v| dt [m] and a = integral of |w| dt [rad] over the step.  The variances
grow linearly with distance and rotation (a random walk), so the total does not depend on how
often the camera fires (steps are 0.24 s apart in the median); the floors keep the covariance
positive definite when the robot stands still.  Calibration (rough): robot poses were fixed by
least squares from the scans with >= 3 landmark returns and the Vicon map (rows 11 and 17
swapped, see below); between consecutive fixes 0.5-5 m apart (28 pairs, mean 2.0 m and 2.5 rad
travelled) the mean squared odometry errors are (0.078 m^2, 0.134 m^2, 0.083 rad^2) for
(x, y, yaw) in the earlier fix's frame, including the fixes' own errors, against propagated
variances of (0.138, 0.153, 0.093) with these coefficients: slightly conservative.

Measurement covariance (a choice): sigma_range = 0.15 m, sigma_bearing = 1.1 deg, uncorrelated,
for every measurement.  The same pose-fix check gives range residuals of std 0.16 m (heavy
tailed; MAD-based 0.11 m) and bearing residuals of std 1.1 deg (after a degrees-of-freedom
correction).  The bearing sigma was 2 deg (a margin) until issue 20's second pass: with it the
oracle's NIS / dof was 0.33 (robot 1) and the wide bearing gates let wrong pairs in; with 1.1 deg
the closed loop (jcbb) goes 62.68 -> 70.23 % on robot 1 and 65.07 -> 68.10 % on robot 2, the
oracle 97.89 -> 98.43 and 98.52 -> 99.03 % (docs/slam.md).

Truth: barcode -> subject via Barcodes.dat.  Subjects 6-20 (the static landmarks) -> landmark
id = subject number; subjects 1-5 (the other robots, 952 returns) -> CLUTTER.  All certain.
true_landmarks: subject -> (x, y) [m] from Landmark_Groundtruth.dat, in the Vicon world frame,
rows as they are.  Caveat (SOURCES.md, confirmed by the pose-fix check above: with rows 11 and
17 exchanged, range residuals drop from 0.81 m to 0.16 m std): the rows (or barcodes) of
subjects 11 and 17 appear swapped in this copy; map-error metrics for them are unreliable.

Initial pose: there is no pose ground truth here (Robot<n>_Groundtruth.dat is missing), so the
robot starts at the zero pose with zero covariance at the first odometry sample; the estimated
map is in that start frame, not the Vicon frame (scoring must align the maps).  true_pose is
None.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ...core.multi_hypothesis.motion import between
from .dead_reckoning import increment_covariances, integrate_hold, milliseconds
from .sequence import CLUTTER, COURSE_SIGNIFICANCE, SlamSequence, SlamStep

FOLDER = 'utias_mrclam_ds1_robot1'
ROBOT2_FOLDER = 'utias_mrclam_ds1_robot2'
SIGMA_RANGE = 0.15
"""Measurement range standard deviation [m] (a choice, see the module docstring)."""
SIGMA_BEARING = np.deg2rad(1.1)
"""Measurement bearing standard deviation [rad]: the pose-fix check's 1.1 deg."""
POSITION_FLOOR = 0.005 ** 2
"""Increment var_x, var_y floor [m^2]."""
POSITION_PER_METRE = 0.04
"""Increment var_x, var_y per metre travelled [m^2 / m]."""
YAW_FLOOR = 0.005 ** 2
"""Increment var_yaw floor [rad^2]."""
YAW_PER_RADIAN = 0.025
"""Increment var_yaw per radian turned [rad^2 / rad]."""
YAW_PER_METRE = 0.01
"""Increment var_yaw per metre travelled [rad^2 / m]."""
FIRST_LANDMARK_SUBJECT = 6
LANDMARK_MANAGEMENT = {'drop_misses': 10, 'drop_max_sightings': 0, 'view_half_angle': 0.5,
                       'view_range': 5.0}
"""ekf_slam_node parameters of the MRCLAM bags (both robots, chosen on robot 1 only): drop any
landmark predicted in the camera's view (|bearing| <= 0.5 rad, range <= 5 m: 95 % of robot 1's
sightings lie within 0.48 rad and 5.35 m) on 10 scans in a row without being seen - the other
robots, mapped while seen and gone once they have crept on.  On robot 1's first 1500 scans
(jcbb, closed loop) 10 misses gave 72.0 % correct, 7: 73.5 % (5 true landmarks missing),
20: 71.5 %, a 0.4 rad / 4 m view 51.5 %, dropping only landmarks seen once or twice 40-59 %
(docs/slam.md)."""


def _increment_covariances(distance: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """(M, 3, 3) increment covariances of the model in the module docstring."""
    return increment_covariances(distance, rotation, POSITION_FLOOR, POSITION_PER_METRE,
                                 YAW_FLOOR, YAW_PER_RADIAN, YAW_PER_METRE)


def subjects_of(data_directory: Path, barcodes: np.ndarray) -> np.ndarray:
    """The subject (1-5 robots, 6-20 landmarks) of each measurement barcode (n,), by the
    folder's Barcodes.dat; ValueError for a barcode it does not list."""
    table = np.loadtxt(Path(data_directory) / 'Barcodes.dat', comments='#', dtype=np.int64,
                       ndmin=2)
    subject_of = np.full(table[:, 1].max() + 1, -1, dtype=np.int64)
    subject_of[table[:, 1]] = table[:, 0]
    subjects = subject_of[np.asarray(barcodes).astype(np.int64)]
    if np.any(subjects < 0):
        raise ValueError('a measurement barcode is not in Barcodes.dat')
    return subjects


def load(data_directory: Path, robot: int = 1) -> SlamSequence:
    """MRCLAM Dataset 1 robot `robot` in `data_directory` (the utias_mrclam_ds1_robot<robot>
    folder), 'range_bearing'; robot 1: 3774 steps."""
    data_directory = Path(data_directory)
    odometry = np.loadtxt(data_directory / f'Robot{robot}_Odometry.dat', comments='#', ndmin=2)
    measurements = np.loadtxt(data_directory / f'Robot{robot}_Measurement.dat', comments='#',
                              ndmin=2)
    ground = np.loadtxt(data_directory / 'Landmark_Groundtruth.dat', comments='#', ndmin=2)

    odometry_ms = milliseconds(odometry[:, 0])
    last = np.append(odometry_ms[1:] != odometry_ms[:-1], True)   # zero-length holds dropped
    odometry, odometry_ms = odometry[last], odometry_ms[last]
    measurement_ms = milliseconds(measurements[:, 0])
    if np.any(np.diff(odometry_ms) <= 0) or np.any(np.diff(measurement_ms) < 0):
        raise ValueError('odometry or measurement times are not sorted')
    subjects = subjects_of(data_directory, measurements[:, 1])
    truth = np.where(subjects >= FIRST_LANDMARK_SUBJECT, subjects, CLUTTER)

    scan_ms, first = np.unique(measurement_ms, return_index=True)
    poses, distance, rotation = integrate_hold(odometry_ms, odometry[:, 1], odometry[:, 2],
                                               scan_ms)
    previous = np.vstack([np.zeros(3), poses[:-1]])
    increments = between(previous, poses)
    covariances = _increment_covariances(np.diff(distance, prepend=0.0),
                                        np.diff(rotation, prepend=0.0))
    measurement_covariance = np.diag([SIGMA_RANGE, SIGMA_BEARING]) ** 2
    bounds = np.append(first, len(measurements))
    steps = []
    for k, stamp in enumerate(scan_ms):
        rows = slice(bounds[k], bounds[k + 1])
        count = bounds[k + 1] - bounds[k]
        steps.append(SlamStep(
            time_ns=int(stamp) * 1_000_000, increment=increments[k],
            increment_covariance=covariances[k], values=measurements[rows, 2:4].copy(),
            covariances=np.broadcast_to(measurement_covariance, (count, 2, 2)).copy(),
            truth=truth[rows].copy(), truth_certain=np.ones(count, dtype=bool)))
    return SlamSequence(
        name=f'mrclam_robot{robot}',
        description=f'UTIAS MRCLAM Dataset 1 Robot {robot}: {len(steps)} camera scans (range, '
                    'bearing) of 15 landmarks and 4 robots (clutter), odometry integrated '
                    'between scans; start frame = first odometry pose.',
        model='range_bearing', initial_pose=np.zeros(3), initial_covariance=np.zeros((3, 3)),
        steps=steps,
        true_landmarks={int(row[0]): row[1:3].copy() for row in ground},
        parameters=dict(COURSE_SIGNIFICANCE), slam_parameters=dict(LANDMARK_MANAGEMENT))
