"""What every measurement model provides: prediction, Jacobians, inverse, wrapped innovation."""
from __future__ import annotations

from typing import Optional

import numpy as np


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angle(s) wrapped to (-pi, pi] [rad]: remainder(angle + pi, 2 pi) - pi, -pi -> pi.  The
    remainder is taken only where angle + pi is outside [0, 2 pi) (inside, it is the identity),
    so arrays of mostly wrapped angles cost a few passes instead of a division each."""
    shifted = np.add(angle, np.pi)
    if np.ndim(shifted) == 0:
        wrapped = np.remainder(shifted, 2.0 * np.pi) - np.pi
        return np.where(wrapped == -np.pi, np.pi, wrapped)
    outside = (shifted < 0.0) | (shifted >= 2.0 * np.pi) | np.isnan(shifted)
    if outside.any():
        shifted[outside] = np.remainder(shifted[outside], 2.0 * np.pi)
    shifted -= np.pi
    shifted[shifted == -np.pi] = np.pi
    return shifted


class MeasurementModel:
    """z = h(m, pose) + noise.

    Subclasses set `name`, `needs_pose` and `angular` (indices of z wrapped to (-pi, pi]) and
    implement `predict` and `inverse`.
    """

    name = ''
    needs_pose = False
    angular: tuple[int, ...] = ()

    def landmark_dim(self, measurement_dim: int) -> int:
        """d of the landmarks this model observes with an m-dimensional measurement."""
        return measurement_dim

    def predict(self, means: np.ndarray, pose: Optional[np.ndarray]):
        """h (N, m), dh/dm (N, m, d), dh/dpose (N, m, 3) for landmark means (N, d), pose (3,)."""
        raise NotImplementedError

    def inverse(self, values: np.ndarray, pose: Optional[np.ndarray]):
        """Landmark positions (K, d) in the map frame for measurements (K, m), with the
        Jacobians d/dz (K, d, m) and d/dpose (K, d, 3)."""
        raise NotImplementedError

    def innovation(self, values: np.ndarray, predictions: np.ndarray) -> np.ndarray:
        """nu[i, j] = z_i - h_j, angular components wrapped: (K, m), (N, m) -> (K, N, m)."""
        nu = values[:, None, :] - predictions[None, :, :]
        for index in self.angular:   # on a contiguous copy: faster than the strided view
            nu[..., index] = wrap_angle(values[:, None, index] - predictions[None, :, index])
        return nu


class IdentityModel(MeasurementModel):
    """z = m: the observation is the landmark's state in the map frame (no pose involved)."""

    def predict(self, means, pose):
        count, dim = means.shape
        return (means.copy(), np.broadcast_to(np.eye(dim), (count, dim, dim)).copy(),
                np.zeros((count, dim, 3)))

    def inverse(self, values, pose):
        count, dim = values.shape
        return (values.copy(), np.broadcast_to(np.eye(dim), (count, dim, dim)).copy(),
                np.zeros((count, dim, 3)))
