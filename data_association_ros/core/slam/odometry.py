"""Odometry messages to motion increments: each message is a pose in the odometry frame with the
covariance of the increment since the previous message (DESIGN.md 4, `odometry`).

Increments of several messages compose: u = u1 (+) u2 with Q = V1' Q1 V1'^T + V2 Q2 V2^T, where
V1' = d(u1 (+) u2)/d u1 and V2 = d(u1 (+) u2)/d u2 (first order).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..multi_hypothesis.motion import between, compose, compose_jacobians


class OdometryIncrements:
    """Accumulates odometry poses; `take()` returns the increment since the last take."""

    def __init__(self) -> None:
        self.last_pose: Optional[np.ndarray] = None
        self.increment = np.zeros(3)
        self.noise = np.zeros((3, 3))

    def add(self, pose: np.ndarray, covariance: np.ndarray) -> None:
        """One odometry pose (x, y, yaw) with the 3x3 covariance of its increment."""
        pose = np.asarray(pose, dtype=float)
        if self.last_pose is None:   # the first message is the origin of the motion
            self.last_pose = pose
            return
        step = between(self.last_pose, pose)
        g, v = compose_jacobians(self.increment, step)
        self.increment = compose(self.increment, step)
        self.noise = g @ self.noise @ g.T + v @ np.asarray(covariance, dtype=float) @ v.T
        self.last_pose = pose

    def take(self) -> tuple[np.ndarray, np.ndarray]:
        """(increment (3,), its covariance (3, 3)) since the previous take; then reset."""
        out = self.increment, self.noise
        self.increment, self.noise = np.zeros(3), np.zeros((3, 3))
        return out
