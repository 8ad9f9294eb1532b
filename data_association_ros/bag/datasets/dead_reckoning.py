"""Dead reckoning of sampled (v, w) odometry and its increment covariances, shared by the
converters (mrclam, acfr_car_park)."""
from __future__ import annotations

import numpy as np


def milliseconds(seconds: np.ndarray) -> np.ndarray:
    """Unix times [s] with millisecond resolution as int64 milliseconds."""
    return np.round(np.asarray(seconds, dtype=float) * 1000.0).astype(np.int64)


def integrate_hold(odometry_ms: np.ndarray, v: np.ndarray, w: np.ndarray,
                   query_ms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dead reckoning of zero-order-hold (v [m/s], w [rad/s]) samples at odometry_ms (N,)
    [int ms, increasing], starting at the zero pose at odometry_ms[0].  Returns, at query_ms
    (M,) (>= odometry_ms[0]): poses (M, 3) [m, m, rad, heading unwrapped], travelled distance
    (M,) [m] and turned angle (M,) [rad] (integrals of |v| and |w|)."""
    query_ms = np.asarray(query_ms, dtype=np.int64)
    if len(query_ms) and query_ms.min() < odometry_ms[0]:
        raise ValueError('a query time precedes the first odometry sample')
    grid = np.union1d(odometry_ms, query_ms)                      # sorted, unique [ms]
    sample = np.searchsorted(odometry_ms, grid[:-1], side='right') - 1
    dt = np.diff(grid) * 1e-3
    speed, rate = v[sample], w[sample]
    turn = rate * dt
    heading = np.concatenate([[0.0], np.cumsum(turn)])
    chord = speed * dt * np.sinc(turn / (2.0 * np.pi))            # sin(turn/2) / (turn/2)
    angle = heading[:-1] + 0.5 * turn
    x = np.concatenate([[0.0], np.cumsum(chord * np.cos(angle))])
    y = np.concatenate([[0.0], np.cumsum(chord * np.sin(angle))])
    distance = np.concatenate([[0.0], np.cumsum(np.abs(speed) * dt)])
    rotation = np.concatenate([[0.0], np.cumsum(np.abs(turn))])
    at = np.searchsorted(grid, query_ms)
    return np.column_stack([x[at], y[at], heading[at]]), distance[at], rotation[at]


def increment_covariances(distance: np.ndarray, rotation: np.ndarray, position_floor: float,
                          position_per_metre: float, yaw_floor: float, yaw_per_radian: float,
                          yaw_per_metre: float) -> np.ndarray:
    """(M, 3, 3) diagonal increment covariances for steps of distance d (M,) [m] and absolute
    rotation a (M,) [rad]: var_x = var_y = position_floor + position_per_metre d [m^2],
    var_yaw = yaw_floor + yaw_per_radian a + yaw_per_metre d [rad^2] (a random walk in distance
    and rotation)."""
    covariances = np.zeros((len(distance), 3, 3))
    covariances[:, 0, 0] = covariances[:, 1, 1] = position_floor + position_per_metre * distance
    covariances[:, 2, 2] = yaw_floor + yaw_per_radian * rotation + yaw_per_metre * distance
    return covariances
