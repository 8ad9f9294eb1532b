"""What every measurement model provides: prediction, Jacobians, inverse, wrapped innovation."""
from __future__ import annotations

from typing import Optional

import numpy as np


TWO_PI = 2.0 * np.pi


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    """Angle(s) wrapped to (-pi, pi] [rad]: a - 2 pi floor((a + pi) / (2 pi)), -pi -> pi.  An
    angle inside is returned as it is (but within a rounding of pi); arrays take a few passes
    and no per-element remainder."""
    angle = np.asarray(angle, dtype=float)
    with np.errstate(invalid='ignore'):   # inf -> NaN, as remainder gives
        wrapped = angle - TWO_PI * np.floor((angle + np.pi) * (1.0 / TWO_PI))
    if wrapped.ndim == 0:
        wrapped = float(wrapped)
        return np.float64(wrapped + TWO_PI if wrapped <= -np.pi else
                          wrapped - TWO_PI if wrapped > np.pi else wrapped)
    # rounding near the ends (and of a large angle's turns) can leave a value just outside
    wrapped[wrapped <= -np.pi] += TWO_PI
    wrapped[wrapped > np.pi] -= TWO_PI
    return wrapped


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

    def in_map(self, values: np.ndarray, covariances: Optional[np.ndarray],
               pose: Optional[np.ndarray], pose_covariance: Optional[np.ndarray]
               ) -> tuple[np.ndarray, Optional[np.ndarray]]:
        """Map-frame positions (K, d) of measurements (K, m) by `inverse`, and their
        covariances G_z R G_z^T + G_pose P G_pose^T (K, d, d) for R = covariances (K, m, m) and
        P = pose_covariance (3, 3) (None: that term left out; covariances None: None)."""
        positions, j_z, j_pose = self.inverse(values, pose)
        if covariances is None:
            return positions, None
        out = j_z @ covariances @ np.swapaxes(j_z, 1, 2)
        if pose_covariance is not None:
            out = out + j_pose @ pose_covariance @ np.swapaxes(j_pose, 1, 2)
        return positions, out

    def innovation(self, values: np.ndarray, predictions: np.ndarray) -> np.ndarray:
        """nu[i, j] = z_i - h_j, angular components wrapped: (K, m), (N, m) -> (K, N, m) (a view
        of innovation_components)."""
        return np.moveaxis(self.innovation_components(values, predictions), 0, -1)

    def pair_innovations(self, values: np.ndarray, predictions: np.ndarray) -> np.ndarray:
        """nu[e] = z_e - h_e, angular components wrapped: (E, m), (E, m) -> (E, m) (the same
        numbers as innovation's [i, j] for z_i, h_j)."""
        nu = values - predictions
        for c in self.angular:
            nu[:, c] = wrap_angle(nu[:, c])
        return nu

    def innovation_components(self, values: np.ndarray, predictions: np.ndarray) -> np.ndarray:
        """nu[c, i, j] = z_ic - h_jc, angular components wrapped: (K, m), (N, m) -> (m, K, N),
        each component contiguous (a (K, N, m) broadcast costs about 10x its m passes)."""
        m = values.shape[1]
        nu = np.empty((m, values.shape[0], predictions.shape[0]))
        for c in range(m):
            np.subtract(values[:, c, None], predictions[None, :, c], out=nu[c])
            if c in self.angular:
                nu[c] = wrap_angle(nu[c])
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
