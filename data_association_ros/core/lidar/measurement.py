"""Seed 003's fictitious measurement and the filter model of a tracked rigid object.

State x = [x, y, yaw, vx, vy, yaw_rate] (constant velocity and turn rate over dt, linear).
The correction X that moved the predicted boundary (around the predicted centre c-, yaw-) onto
the scan gives the measurement
    z = [X(c-), yaw- + yaw_X, (X(c-) - c_last) / dt, (yaw- + yaw_X - yaw_last) / dt]
(c_last, yaw_last: the posterior at the track's last update, dt the time since), i.e. the motion
at constant linear and angular velocity.  Its noise: the seed's diagonal R (velocity terms
larger) plus, added here, the correction's own covariance C of (t_x, t_y, yaw) mapped by
G = [I3; I3 / dt]: R + G C G^T.  The velocity terms reuse the position difference the filter
already holds (they are not independent of its prior), so the tracker uses only the first three
terms unless velocity_measurement is set (README "LiDAR object tracking").
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..models.base import wrap_angle
from .shape import rotation


def transition(dt: float) -> np.ndarray:
    """F (6, 6): x += vx dt, y += vy dt, yaw += yaw_rate dt."""
    f = np.eye(6)
    f[0, 3] = f[1, 4] = f[2, 5] = dt
    return f


def turning_prediction(state: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(predicted state (6,), Jacobian F (6, 6)) of the velocity turning with the yaw rate w
    (a car on a curve): v' = R(w dt) v, position += R(w dt / 2) v dt, yaw += w dt; for w = 0
    it is transition(dt)."""
    w, v = state[5], state[3:5]
    half, full = rotation(w * dt / 2), rotation(w * dt)
    j = np.array([[0.0, -1.0], [1.0, 0.0]])
    predicted = state.copy()
    predicted[:2] = state[:2] + half @ v * dt
    predicted[2] = state[2] + w * dt
    predicted[3:5] = full @ v
    f = transition(dt)
    f[0:2, 3:5] = half * dt
    f[0:2, 5] = dt * dt / 2 * (j @ half @ v)
    f[3:5, 3:5] = full
    f[3:5, 5] = dt * (j @ full @ v)
    return predicted, f


def lateral_velocity(state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(innovation (1,), Jacobian H (1, 6)) of the pseudo-measurement 0 of the velocity across
    the heading (no slip), h(x) = -sin(yaw) vx + cos(yaw) vy [m/s]: innovation -h(x),
    H = [0, 0, -(cos(yaw) vx + sin(yaw) vy), -sin(yaw), cos(yaw), 0]."""
    yaw, vx, vy = state[2], state[3], state[4]
    c, s = np.cos(yaw), np.sin(yaw)
    return (np.array([s * vx - c * vy]),
            np.array([[0.0, 0.0, -(c * vx + s * vy), -s, c, 0.0]]))


def process_noise(dt: float, accel_sigma: float, yaw_accel_sigma: float,
                  lateral_sigma: Optional[float] = None, heading: float = 0.0) -> np.ndarray:
    """Q (6, 6) of white (angular) acceleration: per (position, velocity) pair the spectral
    density times [[dt^3/3, dt^2/2], [dt^2/2, dt]]; the density of (x, y) is accel_sigma^2 I
    [m^2/s^3], or with lateral_sigma R(heading) diag(accel_sigma^2, lateral_sigma^2)
    R(heading)^T (accel_sigma along the heading, lateral_sigma across it); that of yaw
    yaw_accel_sigma^2 [rad^2/s^3]."""
    density = accel_sigma ** 2 * np.eye(2)
    if lateral_sigma is not None:
        turn = rotation(heading)
        density = turn @ np.diag([accel_sigma ** 2, lateral_sigma ** 2]) @ turn.T
    d = np.zeros((3, 3))   # of (x, y, yaw); the state is (x, y, yaw, vx, vy, yaw rate)
    d[:2, :2], d[2, 2] = density, yaw_accel_sigma ** 2
    q = np.empty((6, 6))
    q[:3, :3], q[3:, 3:] = d * dt ** 3 / 3, d * dt
    q[:3, 3:] = q[3:, :3] = d * dt ** 2 / 2
    return q


def fictitious_measurement(centre: np.ndarray, yaw: float, previous_centre: np.ndarray,
                           previous_yaw: float, transform, dt: float) -> np.ndarray:
    """z (6,) of the module docstring; `transform` has apply((n, 2)) and yaw (a Correction or a
    RigidTransform2D), centre/yaw the predicted pose, previous_* the previous posterior."""
    moved = transform.apply(np.asarray(centre, dtype=float)[None])[0]
    new_yaw = wrap_angle(yaw + transform.yaw)
    velocity = (moved - np.asarray(previous_centre, float)) / dt
    return np.array([moved[0], moved[1], new_yaw, velocity[0], velocity[1],
                     wrap_angle(new_yaw - previous_yaw) / dt])


def measurement_covariance(correction_covariance: np.ndarray, dt: float,
                           sigmas) -> np.ndarray:
    """R (6, 6) = diag(sigmas)^2 + G C G^T with G = [I3; I3 / dt] (module docstring)."""
    g = np.vstack([np.eye(3), np.eye(3) / dt])
    return np.diag(np.square(np.asarray(sigmas, float))) + g @ correction_covariance @ g.T
