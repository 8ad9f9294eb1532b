"""ACFR "Car Park" (Sydney, Nebot): a car with a SICK laser among 15 surveyed reflective beacons,
as a `SlamSequence`.

Source: `acfr_car_park/data_set.mat` (wheel speed and steering at 40 Hz, GPS at 5 Hz, 586 laser
scans of 361 beams over 180 deg with return intensities) and `beac_juan3.mat` (the 15 beacons'
surveyed positions); see that folder's SOURCES.md.  Nothing in this data set was used to choose
parameters of the package: it is converted with choices made here from its own calibration
(below) and run with the parameters every SLAM bag has.

Robot frame = the laser: (LASER_FORWARD, LASER_LEFT) from the rear axle's centre, heading the
car's; bearings 0 straight ahead, positive to the left (beam i at i * 0.5 deg - 90 deg).

Odometry: the wheel speed v is measured at the rear left wheel, ENCODER_OFFSET to the side of
the axle's centre, so the centre moves at v_c = v / (1 - tan(steering) H / L) and turns at
w = v_c tan(steering) / L (L = WHEELBASE), the car model the data's users apply.  (v_c, w) is
integrated as a zero-order hold (dead_reckoning.integrate_hold); the laser's path is the rear
axle's path composed with the laser's mounting, and step k's increment the SE(2) difference of
the laser poses of scan k-1 and scan k.

Steps: one per laser scan with at least one beacon detection (returns with non-zero intensity,
consecutive ones within JOIN_DISTANCE of each other joined; their mean range and mean
bearing).  Ranges of NO_RETURN (81.9 m) are no return.

Truth (derived here; the data set has no association): the laser's true position is the GPS
position (the antenna sits at the laser: with the antenna at (3.78, 0.5) m from the rear axle
the dead-reckoned path fits the first 100 GPS fixes to 0.11 m median, at the axle 2.6 m), its
heading the odometry heading rotated by the rigid fit of the odometry path to the GPS fixes
within HEADING_WINDOW metres travelled (a window in distance, so a standing car keeps the
heading it stopped with).  A detection placed from that pose is the surveyed beacon nearest to
it when within CERTAIN_RADIUS (certain), the nearest one but uncertain (left out of the scores)
up to CLUTTER_RADIUS, clutter beyond.  Beacons are 2.0 m apart at the closest.
true_landmarks: beacon row r -> id r + 1.  true_pose: the GPS position and that heading.
initial_pose: the true pose at the first odometry sample, with zero covariance (the map is in
the beacons' frame).

Calibration against that truth (586 scans, 506 with beacons, 892 detections; a scratch script,
docs/slam.md "The ACFR car park"): range residuals 0.008 +- 0.032 m, bearing residuals
0.63 +- 0.96 deg; see the constants' docstrings.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.io import loadmat

from ...core.models.base import wrap_angle
from ...core.multi_hypothesis.motion import between, compose
from ...core.transforms import estimate_rigid_transform
from .dead_reckoning import increment_covariances, integrate_hold, milliseconds
from .sequence import CLUTTER, COURSE_SIGNIFICANCE, SlamSequence, SlamStep

FOLDER = 'acfr_car_park'
WHEELBASE = 2.83
"""L [m], rear axle to front axle."""
ENCODER_OFFSET = 0.76
"""H [m], the speed-measuring rear wheel's distance to the side of the rear axle's centre."""
LASER_FORWARD = 3.78
"""The laser ahead of the rear axle's centre [m] (L + a)."""
LASER_LEFT = 0.5
"""The laser to the left of the rear axle's centre [m] (b)."""
NO_RETURN = 80.0
"""Ranges at or beyond this [m] are no return (the file's 81.9)."""
JOIN_DISTANCE = 0.5
"""Consecutive reflective returns at most this far apart [m] are one beacon (beacons are 2.0 m
apart at the closest; a near beacon's tape can leave a few dark beams within it)."""
HEADING_WINDOW = 4.0
"""GPS fixes within this distance travelled [m] of a scan fix its true heading."""
CERTAIN_RADIUS = 0.5
"""A detection this close [m] to its nearest beacon (placed from the true pose) is that beacon."""
CLUTTER_RADIUS = 1.5
"""A detection farther [m] than this from every beacon is clutter; in between: uncertain."""
SIGMA_RANGE = 0.05
"""Measurement range standard deviation [m] (calibration)."""
SIGMA_BEARING = np.deg2rad(1.2)
"""Measurement bearing standard deviation [rad] (calibration)."""
POSITION_FLOOR = 0.01 ** 2
"""Increment var_x, var_y floor [m^2]."""
POSITION_PER_METRE = 0.003
"""Increment var_x, var_y per metre travelled [m^2 / m] (calibration)."""
YAW_FLOOR = 0.002 ** 2
"""Increment var_yaw floor [rad^2]."""
YAW_PER_RADIAN = 0.003
"""Increment var_yaw per radian turned [rad^2 / rad] (calibration)."""
YAW_PER_METRE = 0.0003
"""Increment var_yaw per metre travelled [rad^2 / m] (calibration)."""


def beacon_detections(ranges: np.ndarray, intensities: np.ndarray) -> np.ndarray:
    """(D, 2) range [m], bearing [rad] of the beacons in one scan of ranges (361,) and
    intensities (361,): the mean range and bearing of each run of reflective returns."""
    beams = np.nonzero((intensities > 0) & (ranges < NO_RETURN))[0]
    if not len(beams):
        return np.zeros((0, 2))
    bearings = np.deg2rad(0.5 * beams) - np.pi / 2
    points = ranges[beams, None] * np.column_stack([np.cos(bearings), np.sin(bearings)])
    breaks = np.nonzero(np.hypot(*np.diff(points, axis=0).T) > JOIN_DISTANCE)[0] + 1
    return np.array([(ranges[beams[run]].mean(), bearings[run].mean())
                     for run in np.split(np.arange(len(beams)), breaks)])


def _laser_path(data: dict, query_ms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The laser's dead-reckoned poses (M, 3) at query_ms in the frame of the rear axle at the
    first odometry sample, and the travelled distance and turned angle (M,) up to them."""
    odometry_ms = milliseconds(data['Time_VS'].ravel())
    steering = data['Steering'].ravel()
    speed = data['Velocity'].ravel() / (1.0 - np.tan(steering) * ENCODER_OFFSET / WHEELBASE)
    axle, distance, rotation = integrate_hold(odometry_ms, speed,
                                              speed * np.tan(steering) / WHEELBASE, query_ms)
    return compose(axle, np.array([LASER_FORWARD, LASER_LEFT, 0.0])), distance, rotation


def _true_poses(data: dict, query_ms: np.ndarray, at_query: np.ndarray,
                travelled: np.ndarray) -> np.ndarray:
    """The laser's true poses (M, 3) at query_ms, given its dead-reckoned poses (M, 3) and
    travelled distances (M,) there (_laser_path): GPS position, odometry heading turned by the
    rigid fit (Kabsch) of the odometry path to the GPS fixes within HEADING_WINDOW travelled
    (module docstring)."""
    gps_ms = milliseconds(data['TimeGPS'].ravel())
    gps = np.column_stack([data['GPSLon'].ravel(), data['GPSLat'].ravel()])
    at_gps, travelled_gps, _ = _laser_path(data, gps_ms)
    poses = np.empty((len(query_ms), 3))
    poses[:, 0] = np.interp(query_ms, gps_ms, gps[:, 0])
    poses[:, 1] = np.interp(query_ms, gps_ms, gps[:, 1])
    for k in range(len(query_ms)):
        near = np.abs(travelled_gps - travelled[k]) <= HEADING_WINDOW
        poses[k, 2] = at_query[k, 2] + estimate_rigid_transform(at_gps[near, :2], gps[near]).yaw
    poses[:, 2] = wrap_angle(poses[:, 2])
    return poses


def _label(detections: np.ndarray, pose: np.ndarray,
           beacons: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(truth ids (D,), certain (D,), distance to the nearest beacon (D,) [m]) of detections
    (D, 2) placed from the true pose (module docstring)."""
    angle = pose[2] + detections[:, 1]
    placed = pose[:2] + detections[:, :1] * np.column_stack([np.cos(angle), np.sin(angle)])
    distance = np.linalg.norm(placed[:, None, :] - beacons[None, :, :], axis=2)
    nearest = distance.argmin(axis=1)
    gap = distance[np.arange(len(detections)), nearest]
    truth = np.where(gap <= CLUTTER_RADIUS, nearest + 1, CLUTTER)
    certain = (gap <= CERTAIN_RADIUS) | (gap > CLUTTER_RADIUS)
    return truth, certain, gap


def _read(data_directory: Path) -> tuple[dict, np.ndarray]:
    data_directory = Path(data_directory)
    data = loadmat(data_directory / 'data_set.mat')
    beacons = loadmat(data_directory / 'beac_juan3.mat')['estbeac'].astype(float)
    return data, beacons


def load(data_directory: Path) -> SlamSequence:
    """The car park from `data_directory` (the acfr_car_park folder), 'range_bearing'."""
    data, beacons = _read(data_directory)
    scan_ms = milliseconds(data['TimeLaser'].ravel())
    detections = [beacon_detections(ranges, intensities)
                  for ranges, intensities in zip(data['Laser'], data['Intensity'])]
    seen = np.array([len(found) > 0 for found in detections])
    scan_ms = scan_ms[seen]
    detections = [found for found, kept in zip(detections, seen) if kept]
    query_ms = np.concatenate([milliseconds(data['Time_VS'].ravel()[:1]), scan_ms])
    poses, distance, rotation = _laser_path(data, query_ms)
    increments = between(poses[:-1], poses[1:])
    covariances = increment_covariances(np.diff(distance), np.diff(rotation), POSITION_FLOOR,
                                        POSITION_PER_METRE, YAW_FLOOR, YAW_PER_RADIAN,
                                        YAW_PER_METRE)
    true_poses = _true_poses(data, query_ms, poses, distance)
    measurement_covariance = np.diag([SIGMA_RANGE, SIGMA_BEARING]) ** 2
    steps = []
    for k, (stamp, found) in enumerate(zip(scan_ms, detections)):
        truth, certain, _ = _label(found, true_poses[k + 1], beacons)
        steps.append(SlamStep(
            time_ns=int(stamp) * 1_000_000, increment=increments[k],
            increment_covariance=covariances[k], values=found,
            covariances=np.broadcast_to(measurement_covariance, (len(found), 2, 2)).copy(),
            truth=truth, truth_certain=certain, true_pose=true_poses[k + 1]))
    return SlamSequence(
        name='acfr_car_park',
        description=f'ACFR car park (Nebot): {len(steps)} laser scans with reflective beacons '
                    '(range, bearing from the laser), wheel odometry of the car integrated '
                    'between scans; truth from GPS and the 15 surveyed beacons.',
        model='range_bearing', initial_pose=true_poses[0], initial_covariance=np.zeros((3, 3)),
        steps=steps, true_landmarks={row + 1: beacons[row].copy() for row in range(len(beacons))},
        parameters=dict(COURSE_SIGNIFICANCE))
