"""SE(2) odometry: pose (x, y, yaw) composed with an increment (dx, dy, dyaw) in the robot frame:
x' = x + R(yaw) (dx, dy),  yaw' = yaw + dyaw (wrapped)."""
from __future__ import annotations

import numpy as np

from ..models.base import wrap_angle


def compose(pose: np.ndarray, increment: np.ndarray) -> np.ndarray:
    """Poses (..., 3) moved by increments (..., 3) (broadcast)."""
    pose, increment = np.asarray(pose, dtype=float), np.asarray(increment, dtype=float)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    out = np.empty(np.broadcast_shapes(pose.shape, increment.shape))
    out[..., 0] = pose[..., 0] + c * increment[..., 0] - s * increment[..., 1]
    out[..., 1] = pose[..., 1] + s * increment[..., 0] + c * increment[..., 1]
    out[..., 2] = wrap_angle(pose[..., 2] + increment[..., 2])
    return out


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The increments u (..., 3) with compose(a, u) = b for poses (..., 3) (broadcast):
    R(yaw_a)^T (b - a) and the wrapped yaw difference."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[..., 2] - a[..., 2])],
                    axis=-1)


def compose_jacobians(pose: np.ndarray, increment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(d compose / d pose (3, 3), d compose / d increment (3, 3)) at one pose."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    g = np.eye(3)
    g[0, 2] = -s * increment[0] - c * increment[1]
    g[1, 2] = c * increment[0] - s * increment[1]
    v = np.eye(3)
    v[:2, :2] = [[c, -s], [s, c]]
    return g, v
