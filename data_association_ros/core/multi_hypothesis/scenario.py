"""The paper's ten-step scenario (spec: positions read off the figure, about 0.1 m): eight
identical landmarks; at each step the robot observes the nearest landmark within
SENSING_RANGE as a relative position, or nothing (our choice: the paper does not say)."""
from __future__ import annotations

import numpy as np

from .motion import between, compose

LANDMARKS = np.array([[5, 3], [8, 3], [4, 5], [4, 7], [3, 8], [5, 9], [6, 8], [7, 7]], float)
POSITIONS = np.array([[0.75, 4.5], [2.75, 3.9], [4.85, 3.5], [5.15, 5.9], [6.7, 7.05],
                      [8.2, 7.75], [8.45, 10.3], [7.6, 12.1], [6.7, 13.5], [7.1, 15.7],
                      [6.6, 17.1]])
MOTION_NOISE = np.diag([0.5 ** 2, 0.5 ** 2, 1e-3 ** 2])
MEASUREMENT_NOISE = np.diag([0.48 ** 2, 0.48 ** 2])
SENSING_RANGE = 3.0


def true_poses() -> np.ndarray:
    """x0..x10 (11, 3), heading along the next leg of the path."""
    legs = np.diff(POSITIONS, axis=0)
    yaw = np.arctan2(legs[:, 1], legs[:, 0])
    return np.column_stack([POSITIONS, np.append(yaw, yaw[-1])])


def simulate(seed: int = 0) -> tuple[np.ndarray, list, list, list]:
    """(true poses, noisy increments, observations (None: nothing in range), true landmark index
    (-1: none)) of steps 1..10."""
    rng = np.random.default_rng(seed)
    poses = true_poses()
    increments, observations, truth = [], [], []
    for k in range(1, len(poses)):
        u = between(poses[k - 1], poses[k])
        increments.append(u + rng.multivariate_normal(np.zeros(3), MOTION_NOISE,
                                                      method='cholesky'))
        distances = np.hypot(*(LANDMARKS - poses[k, :2]).T)
        nearest = int(np.argmin(distances))
        if distances[nearest] > SENSING_RANGE:
            observations.append(None)
            truth.append(-1)
            continue
        c, s = np.cos(poses[k, 2]), np.sin(poses[k, 2])
        d = LANDMARKS[nearest] - poses[k, :2]
        z = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
        observations.append(z + rng.multivariate_normal(np.zeros(2), MEASUREMENT_NOISE,
                                                        method='cholesky'))
        truth.append(nearest)
    assert np.allclose(compose(poses[0], between(poses[0], poses[1])), poses[1])
    return poses, increments, observations, truth
