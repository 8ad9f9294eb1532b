"""EKF-SLAM: state [x, y, yaw, l0x, l0y, l1x, ...] with covariance P (SI units, radians).

predict:  pose' = compose(pose, u),  P' = F P F^T + V Q V^T  (F, V = d compose / d pose, d u;
          only the pose rows and columns change).
update:   stacked EKF update with the model's h and Jacobians (the ones the associators gate
          with): S = H P H^T + R,  K = P H^T S^-1,  x += K nu (angular components of nu
          wrapped),  P -= K S K^T (symmetrised).
augment:  l = g(pose, z) (the model's inverse),  P_ll = G_p P_pp G_p^T + G_z R G_z^T,
          P_l* = G_p P_p*  (Durrant-Whyte & Bailey 2006; Sola, "Simulataneous localization
          and mapping with the extended Kalman filter", 2014).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..errors import InvalidInputError
from ..models import MODELS
from ..models.base import wrap_angle
from ..multi_hypothesis.motion import compose, compose_jacobians
from ..problem import landmark_blocks
from ..types import Landmarks, RobotPose

POSE = 3
LANDMARK = 2


class EkfSlam:
    """A 2-D EKF-SLAM filter over point landmarks observed with one measurement model
    (`range_bearing` or `point_robot`).  Landmark ids are the caller's (any distinct ints)."""

    def __init__(self, pose: Sequence[float], pose_covariance: np.ndarray, model: str) -> None:
        if model not in ('range_bearing', 'point_robot'):
            raise InvalidInputError(f'model: EKF-SLAM needs range_bearing or point_robot, '
                                    f'not {model!r}')
        self.model = MODELS[model]
        self.mean = np.asarray(pose, dtype=float).reshape(POSE).copy()
        self.covariance = np.asarray(pose_covariance, dtype=float).reshape(POSE, POSE).copy()
        self.ids = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def pose(self) -> RobotPose:
        """The robot pose estimate and its 3x3 covariance."""
        return RobotPose(self.mean[:POSE].copy(), self.covariance[:POSE, :POSE].copy())

    def landmarks(self) -> Landmarks:
        """The map: ids (N,), means (N, 2), marginal covariances (N, 2, 2) (checked)."""
        return Landmarks(*self.marginals())

    def marginals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ids (N,), means (N, 2), marginal covariances (N, 2, 2)): copies of the filter's own
        state, not checked again (the per-scan path)."""
        n = len(self.ids)
        return (self.ids.copy(), self.mean[POSE:].reshape(n, LANDMARK).copy(),
                landmark_blocks(self.covariance, np.arange(n), LANDMARK))

    def index_of(self, ids: np.ndarray) -> np.ndarray:
        """Landmark index (position in the map) of each id; -1 for ids not in the map."""
        ids = np.asarray(ids, dtype=np.int64)
        if len(self.ids) == 0:
            return np.full(ids.shape, -1)
        order = np.argsort(self.ids)
        position = np.searchsorted(self.ids, ids, sorter=order)
        position = np.minimum(position, len(self.ids) - 1)
        found = order[position]
        return np.where(self.ids[found] == ids, found, -1)

    def predict(self, increment: np.ndarray, noise: np.ndarray) -> None:
        """Move by an odometry increment u = (dx, dy, dyaw) in the robot frame with noise Q."""
        u = np.asarray(increment, dtype=float).reshape(POSE)
        f, v = compose_jacobians(self.mean[:POSE], u)
        self.mean[:POSE] = compose(self.mean[:POSE], u)
        p = self.covariance
        p[:POSE, :] = f @ p[:POSE, :]
        p[:, :POSE] = p[:, :POSE] @ f.T
        p[:POSE, :POSE] += v @ np.asarray(noise, dtype=float).reshape(POSE, POSE) @ v.T

    def update(self, values: np.ndarray, covariances: np.ndarray, ids: np.ndarray) -> float:
        """Fuse K observations (K, 2) with noise (K, 2, 2) of the landmarks `ids` (K,) (all in
        the map).  Returns the joint NIS nu^T S^-1 nu."""
        values = np.asarray(values, dtype=float).reshape(-1, LANDMARK)
        k = len(values)
        if k == 0:
            return 0.0
        index = self.index_of(ids)
        if np.any(index < 0):
            raise InvalidInputError(f'ids: not in the map: {np.asarray(ids)[index < 0]}')
        means = self.mean[POSE:].reshape(-1, LANDMARK)[index]
        h, h_landmark, h_pose = self.model.predict(means, self.mean[:POSE])
        nu = values - h
        for a in self.model.angular:
            nu[:, a] = wrap_angle(nu[:, a])
        size = len(self.mean)
        jacobian = np.zeros((LANDMARK * k, size))
        rows = np.arange(k) * LANDMARK
        for a in range(LANDMARK):
            jacobian[rows + a, :POSE] = h_pose[:, a, :]
            for b in range(LANDMARK):
                jacobian[rows + a, POSE + LANDMARK * index + b] = h_landmark[:, a, b]
        p = self.covariance
        p_ht = p @ jacobian.T
        s = jacobian @ p_ht
        for j in range(k):
            s[rows[j]:rows[j] + LANDMARK, rows[j]:rows[j] + LANDMARK] += covariances[j]
        factor = cho_factor(s)
        nu = nu.ravel()
        gain = cho_solve(factor, p_ht.T).T
        self.mean += gain @ nu
        self.mean[2] = wrap_angle(self.mean[2])
        p -= gain @ p_ht.T
        self.covariance = 0.5 * (p + p.T)
        return float(nu @ cho_solve(factor, nu))

    def add_landmarks(self, values: np.ndarray, covariances: np.ndarray,
                      ids: np.ndarray) -> None:
        """Augment the state with landmarks initialised from observations (K, 2) with noise
        (K, 2, 2) at the current pose; `ids` (K,) new and distinct."""
        values = np.asarray(values, dtype=float).reshape(-1, LANDMARK)
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        k = len(values)
        if k == 0:
            return
        if len(np.unique(ids)) != k or np.any(self.index_of(ids) >= 0):
            raise InvalidInputError('ids: new landmark ids must be distinct and not in the map')
        positions, g_z, g_pose = self.model.inverse(values, self.mean[:POSE])
        g_pose = g_pose.reshape(LANDMARK * k, POSE)
        p = self.covariance
        size = len(self.mean)
        cross = g_pose @ p[:POSE, :]                      # (2k, n)
        block = g_pose @ p[:POSE, :POSE] @ g_pose.T       # (2k, 2k)
        noise = g_z @ covariances @ np.swapaxes(g_z, 1, 2)
        for j in range(k):
            block[LANDMARK * j:LANDMARK * (j + 1), LANDMARK * j:LANDMARK * (j + 1)] += noise[j]
        grown = np.empty((size + LANDMARK * k, size + LANDMARK * k))
        grown[:size, :size] = p
        grown[size:, :size] = cross
        grown[:size, size:] = cross.T
        grown[size:, size:] = block
        self.covariance = grown
        self.mean = np.concatenate([self.mean, positions.ravel()])
        self.ids = np.concatenate([self.ids, ids])
