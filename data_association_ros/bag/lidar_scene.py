"""The simulated LiDAR bag `lidar_two_cars` (seed 003's setting): a corridor, two rigid cars, one
overtaking the other, ray-cast scans.

A LiDAR at (-5, 0) scans 270 degrees (0.25 degree steps, 30 m) at 40 Hz for 3 s, range noise
sigma 0.02 m; walls at y = -6 and y = 6.  Car 1 (4.5 m x 1.8 m) starts at (0, -2) at 8 m/s and
changes lane to y = 2 between 0.1 s and 1.1 s (y = -2 + 4 smoothstep; heading along its
velocity, up to 37 degrees); car 2 (4.0 m x 1.8 m) drives straight at 4 m/s from (8, -2).  Car 1
passes between car 2 and the LiDAR, hiding car 2 completely for a while; the cars never touch
(an earlier version started car 2 at (5, -2), 0.75 m ahead of car 1, and car 1 drove through it
between 0.3 s and 0.8 s).  /scan: sensor_msgs/LaserScan (frame 'laser'), truth on
/ground_truth/objects: PointCloud2 id, x, y, yaw, vx, vy, yaw_rate (frame 'laser' = the world
shifted by the sensor position).
"""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import LaserScan

from msg_adapters import array_to_cloud

from ..core.lidar import raycast, rectangle_segments
from .topics import header

SCAN, OBJECTS = '/scan', '/ground_truth/objects'
SENSOR = np.array([-5.0, 0.0])
RATE_HZ, DURATION_S = 40.0, 3.0
ANGLE_MIN, ANGLE_INCREMENT, BEAMS = np.deg2rad(-135.0), np.deg2rad(0.25), 1081
MAX_RANGE, RANGE_SIGMA = 30.0, 0.02
LANE_CHANGE = (0.1, 1.1)
"""Car 1's lane change starts and ends at these times [s]."""
WALLS = np.array([[[-10.0, -6.0], [60.0, -6.0]], [[-10.0, 6.0], [60.0, 6.0]]])
OBJECT_DTYPE = np.dtype([('id', '<i4'), ('x', '<f4'), ('y', '<f4'), ('yaw', '<f4'),
                         ('vx', '<f4'), ('vy', '<f4'), ('yaw_rate', '<f4')])


def car_states(t: float) -> list[tuple[int, np.ndarray, np.ndarray, float, float, float]]:
    """[(id, centre (2,), velocity (2,), yaw, yaw rate, length)] at time t [s]."""
    s = np.clip((t - LANE_CHANGE[0]) / (LANE_CHANGE[1] - LANE_CHANGE[0]), 0.0, 1.0)
    duration = LANE_CHANGE[1] - LANE_CHANGE[0]
    smooth, slope = 3 * s ** 2 - 2 * s ** 3, (6 * s - 6 * s ** 2) if 0 < s < 1 else 0.0
    accel = (6 - 12 * s) if 0 < s < 1 else 0.0
    vx, vy = 8.0, 4.0 * slope / duration  # d/dt of -2 + 4 smoothstep(s)
    ay = 4.0 * accel / duration ** 2
    car1 = (1, np.array([8.0 * t, -2.0 + 4.0 * smooth]), np.array([vx, vy]),
            float(np.arctan2(vy, vx)), float(vx * ay / (vx ** 2 + vy ** 2)), 4.5)
    car2 = (2, np.array([8.0 + 4.0 * t, -2.0]), np.array([4.0, 0.0]), 0.0, 0.0, 4.0)
    return [car1, car2]


def lidar_messages(seed: int = 5):
    """(topic, message, log time ns) of the whole bag."""
    rng = np.random.default_rng(seed)
    angles = ANGLE_MIN + ANGLE_INCREMENT * np.arange(BEAMS)
    for k in range(int(DURATION_S * RATE_HZ)):
        t = k / RATE_HZ
        time_ns = 1_000_000_000 + int(round(t * 1e9))
        cars = car_states(t)
        segments = np.concatenate([WALLS] + [rectangle_segments(c, yaw, length, 1.8)
                                             for _, c, _, yaw, _, length in cars])
        ranges, _ = raycast(SENSOR, angles, segments, MAX_RANGE)
        ranges = ranges + rng.normal(0.0, RANGE_SIGMA, BEAMS)
        scan = LaserScan(header=header(time_ns, 'laser'), angle_min=float(ANGLE_MIN),
                         angle_max=float(angles[-1]), angle_increment=float(ANGLE_INCREMENT),
                         time_increment=0.0, scan_time=1.0 / RATE_HZ, range_min=0.05,
                         range_max=MAX_RANGE,
                         ranges=np.where(np.isfinite(ranges), ranges, np.inf).astype(
                             np.float32).tolist())
        yield SCAN, scan, time_ns
        truth = np.zeros(len(cars), dtype=OBJECT_DTYPE)
        for row, (i, centre, velocity, yaw, yaw_rate, _) in zip(truth, cars):
            row['id'] = i
            row['x'], row['y'] = centre - SENSOR
            row['yaw'], row['vx'], row['vy'], row['yaw_rate'] = yaw, *velocity, yaw_rate
        yield OBJECTS, array_to_cloud(truth, header(time_ns, 'laser')), time_ns
