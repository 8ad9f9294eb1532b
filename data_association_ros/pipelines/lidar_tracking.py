"""LiDAR tracking per scan with the ego motion (ROS-free glue of lidar_tracker_node and
da_lidar_eval): odometry poses in, scans in, tracks in the odometry frame out.

Without odometry (a static sensor) the tracks live in the scan's frame, as before.  Once an
odometry pose has arrived, each scan point k (sensor frame, beam k taken at stamp + k
time_increment) goes to the odometry frame with the sensor pose at its own time, linearly
interpolated between the odometry poses around it (yaw unwrapped), or extrapolated at the last
two poses' velocity for at most `max_extrapolation` [s]: this compensates the motion between
scans and, when time_increment > 0, within one.  The scan frame is taken to be the odometry's
child frame (the sensor is where the odometry pose is).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..core.errors import InvalidInputError
from ..core.lidar import LidarObjectTracker, TrackerConfig
from ..core.lidar.free_space import beam_directions

ODOMETRY_CAPACITY = 400
"""Odometry poses kept (10 s at 40 Hz)."""


class PoseHistory:
    """Stamped 2-D poses (x, y, yaw), interpolated at any times within their span."""

    def __init__(self, capacity: int = ODOMETRY_CAPACITY) -> None:
        self.capacity = capacity
        self.times = np.zeros(0)
        self.poses = np.zeros((0, 3))

    def __len__(self) -> int:
        return len(self.times)

    def add(self, time: float, pose: np.ndarray) -> None:
        """Insert a pose at `time` [s] (an equal time replaces it; the oldest drop out)."""
        pose = np.asarray(pose, dtype=float).reshape(3)
        if not (np.isfinite(time) and np.all(np.isfinite(pose))):
            raise InvalidInputError(f'odometry: pose {pose.tolist()} at {time!r} not finite')
        index = int(np.searchsorted(self.times, time))
        if index < len(self.times) and self.times[index] == time:
            self.poses[index] = pose
            return
        self.times = np.insert(self.times, index, time)[-self.capacity:]
        self.poses = np.insert(self.poses, index, pose, axis=0)[-self.capacity:]

    def clear(self) -> None:
        self.times, self.poses = np.zeros(0), np.zeros((0, 3))

    def at(self, times: np.ndarray, max_extrapolation: float) -> np.ndarray:
        """Poses (T, 3) at `times` (T,) [s]: linear in x, y and unwrapped yaw; beyond the ends
        at the velocity of the two end poses, for at most max_extrapolation [s]
        (InvalidInputError further out, or with no pose)."""
        times = np.asarray(times, dtype=float)
        if not len(self.times):
            raise InvalidInputError('odometry: none received')
        low, high = times.min(), times.max()
        if low < self.times[0] - max_extrapolation or high > self.times[-1] + max_extrapolation:
            raise InvalidInputError(
                f'odometry: scan times {low:.3f}-{high:.3f} s not covered by the odometry '
                f'({self.times[0]:.3f}-{self.times[-1]:.3f} s, extrapolation up to '
                f'{max_extrapolation} s)')
        poses = self.poses.copy()
        poses[:, 2] = np.unwrap(poses[:, 2])
        if len(self.times) == 1:
            result = np.repeat(poses, len(times), axis=0)
        else:
            index = np.clip(np.searchsorted(self.times, times) - 1, 0, len(self.times) - 2)
            t0, t1 = self.times[index], self.times[index + 1]
            weight = ((times - t0) / (t1 - t0))[:, None]
            result = poses[index] * (1 - weight) + poses[index + 1] * weight
        result[:, 2] = np.arctan2(np.sin(result[:, 2]), np.cos(result[:, 2]))
        return result


def to_frame(points: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Points (K, 2) of the sensor frame into the frame of poses (K, 3) or (3,): R(yaw) p + t."""
    poses = np.broadcast_to(np.asarray(poses, float), (len(points), 3))
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    return np.column_stack([c * points[:, 0] - s * points[:, 1] + poses[:, 0],
                            s * points[:, 0] + c * points[:, 1] + poses[:, 1]])


class LidarTracking:
    """Odometry + scans -> tracks (module docstring).  `frame` is the tracks' frame: the
    odometry's frame once odometry arrived, else the last scan's."""

    def __init__(self, config: Optional[TrackerConfig] = None,
                 max_extrapolation: float = 0.1) -> None:
        self.tracker = LidarObjectTracker(config)
        self.odometry = PoseHistory()
        self.max_extrapolation = max_extrapolation
        self.odometry_frame: Optional[str] = None
        self.frame: Optional[str] = None

    def add_odometry(self, time: float, pose: np.ndarray, frame: str = 'odom') -> None:
        """An odometry pose (x, y, yaw) of the sensor at `time` [s] in `frame`."""
        self.odometry.add(time, pose)
        self.odometry_frame = frame

    def covers(self, time: float) -> bool:
        """Whether the odometry reaches `time` [s] (a scan's last beam) without extrapolation."""
        return bool(len(self.odometry)) and self.odometry.times[-1] >= time

    def reset(self) -> None:
        """Forget tracks and odometry (a bag played again)."""
        self.tracker.reset()
        self.odometry.clear()

    def step(self, points: np.ndarray, time: float, time_increment: float = 0.0,
             scan_frame: str = 'laser', max_range: Optional[float] = None,
             full_turn: bool = False) -> list:
        """Reported tracks after the scan stamped `time` [s] with points (K, 2) in the sensor
        frame in beam order (non-finite: no return), the sensor's range_max `max_range` [m]
        (None: unknown); full_turn: a 360 deg scan, its last beam next to its first
        (LidarObjectTracker.step).  InvalidInputError when the odometry does
        not cover the scan, or the time is not after the previous scan's."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if not np.isfinite(time_increment) or time_increment < 0:
            time_increment = 0.0
        offsets = np.arange(len(points)) * time_increment
        if not len(self.odometry):  # the tracker finds the beam directions itself
            self.frame = scan_frame
            return self.tracker.step(points, time, offsets=offsets, max_range=max_range,
                                     full_turn=full_turn)
        poses = self.odometry.at(time + (offsets if len(points) else np.zeros(1)),
                                 self.max_extrapolation)
        world = to_frame(points, poses) if len(points) else points
        directions = beam_directions(points)  # in the sensor frame, turned with each beam
        if len(points):
            directions = to_frame(directions, np.column_stack([np.zeros((len(poses), 2)),
                                                               poses[:, 2]]))
        self.frame = self.odometry_frame
        sensor = poses[0]   # at `time`: the first beam's (offset 0), or an empty scan's
        return self.tracker.step(world, time, sensor=sensor[:2], offsets=offsets,
                                 directions=directions, max_range=max_range,
                                 origins=poses[:, :2] if len(points) else None,
                                 full_turn=full_turn)
