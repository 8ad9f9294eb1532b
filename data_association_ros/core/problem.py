"""One association problem, prepared once: predictions, innovations, their covariances and NIS.

For observation i and landmark j, with joint state y = [pose (3), landmark 0 (d), ...] of
covariance P:  nu_ij = z_i - h(m_j, pose) (angles wrapped),  H_j = dh/dy (m, 3 + N d),
S_ij = H_j P H_j^T + R_i,  NIS d2_ij = nu_ij^T S_ij^-1 nu_ij.  Without `state_covariance`,
P = blockdiag(pose covariance, landmark covariances), so the pose still correlates predictions.
"""
from __future__ import annotations

from functools import cached_property
from typing import Optional

import numpy as np

from . import jit
from .errors import InvalidInputError
from .models import MODELS, MeasurementModel
from .types import Landmarks, Observations, RobotPose
from .validation import (as_float_array, check_covariance_matrix, check_positive_semidefinite,
                         check_shape, is_checked_covariance)


def symmetric_quadratic_form(vectors: np.ndarray, matrices: np.ndarray) -> np.ndarray:
    """v^T A v for vectors (..., m) and symmetric A (..., m, m) broadcast against them, from the
    upper triangle: sum_a A_aa v_a^2 + 2 sum_{a<b} A_ab v_a v_b (m^2 / 2 array operations)."""
    m = vectors.shape[-1]
    total = np.zeros(np.broadcast_shapes(vectors.shape[:-1], matrices.shape[:-2]))
    for a in range(m):
        total += matrices[..., a, a] * vectors[..., a] ** 2
        for b in range(a + 1, m):
            total += 2.0 * matrices[..., a, b] * vectors[..., a] * vectors[..., b]
    return total


def state_rows(columns: np.ndarray, dim: int) -> np.ndarray:
    """Rows (3 + L dim,) of the pose and of the landmarks at `columns` (L,) in a joint state
    [x, y, yaw, landmark 0 (dim), ...]."""
    first = 3 + dim * np.asarray(columns, dtype=np.intp)
    return np.concatenate([np.arange(3), (first[:, None] + np.arange(dim)).ravel()])


def landmark_blocks(state_covariance: np.ndarray, columns: np.ndarray, dim: int) -> np.ndarray:
    """The diagonal blocks (L, dim, dim) of the landmarks at `columns` (L,) in a joint covariance
    of [x, y, yaw, landmark 0 (dim), ...] (a copy)."""
    first = 3 + dim * np.asarray(columns, dtype=np.intp)
    blocks = np.empty((len(first), dim, dim))
    for a in range(dim):
        for b in range(dim):
            blocks[:, a, b] = state_covariance[first + a, first + b]
    return blocks


def _inverses(matrices: np.ndarray) -> np.ndarray:
    """Inverses of a stack (..., m, m); NaN for the numerically singular ones (then one matrix
    at a time, a rare path)."""
    try:
        return np.linalg.inv(matrices)
    except np.linalg.LinAlgError:
        flat = matrices.reshape(-1, *matrices.shape[-2:])
        out = np.full(flat.shape, np.nan)
        for k, matrix in enumerate(flat):
            try:
                out[k] = np.linalg.inv(matrix)
            except np.linalg.LinAlgError:
                pass
        return out.reshape(matrices.shape)


def prediction_covariances(h_x: np.ndarray, h_m: np.ndarray, pose_covariance: np.ndarray,
                           pose_landmark: Optional[np.ndarray], landmark_covariances: np.ndarray
                           ) -> np.ndarray:
    """H_j P H_j^T (N, m, m) from the Jacobians h_x (N, m, 3) and h_m (N, m, d), the pose
    covariance (3, 3), Cov(pose, m_j) (N, 3, d; None: zero) and Cov(m_j) (N, d, d)."""
    n, m, _ = h_x.shape
    h_x_p = (h_x.reshape(n * m, 3) @ pose_covariance).reshape(n, m, 3)
    out = h_x_p @ np.swapaxes(h_x, 1, 2) + h_m @ landmark_covariances @ np.swapaxes(h_m, 1, 2)
    if pose_landmark is not None:
        cross = h_x @ pose_landmark @ np.swapaxes(h_m, 1, 2)
        out += cross + np.swapaxes(cross, 1, 2)
    return out


def nis_2d(nu_0: np.ndarray, nu_1: np.ndarray, s_00: np.ndarray, s_01: np.ndarray,
           s_11: np.ndarray) -> np.ndarray:
    """nu^T S^-1 nu for 2-D innovations (nu_0, nu_1) and S = [[s_00, s_01], [s_01, s_11]], all
    broadcast together, in closed form (s_11 nu_0^2 - 2 s_01 nu_0 nu_1 + s_00 nu_1^2) / det S;
    inf where det S <= 0 or the value is not finite (a numerically singular S: never gated).
    The coefficients are formed on S's own shape (N, when one S serves a column), so the (K, N)
    part costs eight passes; a batched LAPACK inverse costs about 1 us per 2 x 2 matrix."""
    with np.errstate(invalid='ignore', over='ignore', divide='ignore'):
        det = s_00 * s_11 - s_01 * s_01
        scale = np.where(det > 0, 1.0 / det, np.nan)
        d2 = np.empty(np.broadcast_shapes(np.shape(nu_0), np.shape(nu_1), np.shape(scale)))
        term = np.empty_like(d2)
        np.multiply(nu_0, nu_0, out=d2)
        d2 *= s_11 * scale
        np.multiply(nu_0, nu_1, out=term)
        term *= -2.0 * s_01 * scale
        d2 += term
        np.multiply(nu_1, nu_1, out=term)
        term *= s_00 * scale
        d2 += term
        bad = ~(d2 < np.inf) | ~(d2 >= 0)   # NaN, inf, negative
    if bad.any():
        d2[bad] = np.inf
    return d2


def nis_2d_of_sum(nu_0: np.ndarray, nu_1: np.ndarray, p: np.ndarray, r: np.ndarray,
                  floor: float = -np.inf) -> np.ndarray:
    """nis_2d (K, N) of 2-D innovations nu_0, nu_1 (K, N) with S_ij = p_j + r_i, p (N, 2, 2),
    r (K, 2, 2), its diagonal raised to `floor`: S by components, never the (K, N, 2, 2)
    stack."""
    return nis_2d(nu_0, nu_1, np.maximum(p[:, 0, 0] + r[:, None, 0, 0], floor),
                  p[:, 0, 1] + r[:, None, 0, 1], np.maximum(p[:, 1, 1] + r[:, None, 1, 1], floor))


def nis_of_innovations(nu: np.ndarray, s: np.ndarray) -> np.ndarray:
    """nu^T S^-1 nu for innovations nu (..., m) and covariances S broadcast against them
    (..., m, m); inf where S is numerically singular (such a pair can never be gated).  m = 2
    in closed form (nis_2d); nu[..., a] should be contiguous (problem.innovations is)."""
    if nu.shape[-1] == 2:
        return nis_2d(nu[..., 0], nu[..., 1], s[..., 0, 0], s[..., 0, 1], s[..., 1, 1])
    with np.errstate(invalid='ignore', over='ignore'):
        d2 = symmetric_quadratic_form(nu, _inverses(s))
    return np.where(np.isfinite(d2) & (d2 >= 0), d2, np.inf)


class AssociationProblem:
    """Landmarks, observations, pose and joint covariance checked against each other."""

    def __init__(self, landmarks: Landmarks, observations: Observations,
                 pose: Optional[RobotPose] = None, state_covariance=None,
                 min_innovation_variance: float = 0.0) -> None:
        if not isinstance(landmarks, Landmarks):
            raise InvalidInputError(f'landmarks: expected Landmarks, got {type(landmarks).__name__}')
        if not isinstance(observations, Observations):
            raise InvalidInputError(
                f'observations: expected Observations, got {type(observations).__name__}')
        if pose is not None and not isinstance(pose, RobotPose):
            raise InvalidInputError(f'pose: expected RobotPose or None, got {type(pose).__name__}')
        self.landmarks = landmarks
        self.observations = observations
        self.model: MeasurementModel = MODELS[observations.model]
        self.min_innovation_variance = min_innovation_variance
        if self.model.needs_pose and pose is None:
            raise InvalidInputError(f'pose: model {self.model.name!r} needs the robot pose')
        self.pose = pose
        want = self.model.landmark_dim(observations.dim)
        if len(landmarks) and landmarks.dim != want:
            raise InvalidInputError(
                f'landmarks.means: model {self.model.name!r} with {observations.dim}-D '
                f'observations needs {want}-D landmarks, got {landmarks.dim}-D')
        self.state_covariance = None
        if state_covariance is not None:
            size = 3 + len(landmarks) * landmarks.dim
            matrix = state_covariance if is_checked_covariance(state_covariance) else \
                as_float_array(state_covariance, 'state_covariance', 2)
            check_shape(matrix, 'state_covariance', (size, size))
            self.state_covariance = check_covariance_matrix(matrix, 'state_covariance')

    def check_definite(self) -> None:
        """Raise unless the joint covariance is positive semi-definite where the individual
        NIS reads it: the block of [pose, landmark j] for every landmark of this problem (a
        batched check of (N, 3 + d, 3 + d) blocks; the joint block of several landmarks is
        checked where it is used, in joint_prediction_covariance)."""
        if self.state_covariance is None or not len(self.landmarks):
            return
        n, d = len(self.landmarks), self.landmarks.dim
        kernels = jit.problem_kernels()
        if kernels is not None:
            if kernels.run_first_indefinite_block(self.state_covariance, n, d) >= 0:
                raise InvalidInputError('state_covariance: not positive semi-definite')
            return
        rows = np.concatenate([np.broadcast_to(np.arange(3), (n, 3)),
                               3 + d * np.arange(n)[:, None] + np.arange(d)], axis=1)
        blocks = self.state_covariance[rows[:, :, None], rows[:, None, :]]
        check_positive_semidefinite(blocks, 'state_covariance')

    def restricted(self, columns: np.ndarray) -> 'AssociationProblem':
        """The same problem over the landmarks `columns` (sorted, (L,)) only, with the rows and
        columns of the pose and of those landmarks of the joint covariance ((3 + L d)^2, the
        only part read); its positive semi-definiteness is checked here."""
        landmarks = self.landmarks.subset(columns)
        local = None
        if self.state_covariance is not None:
            rows = state_rows(columns, self.landmarks.dim)
            local = self.state_covariance[np.ix_(rows, rows)]
        problem = AssociationProblem(landmarks, self.observations, self.pose, local,
                                     self.min_innovation_variance)
        problem.check_definite()
        return problem

    @property
    def sizes(self) -> tuple[int, int]:
        """(K observations, N landmarks)."""
        return len(self.observations), len(self.landmarks)

    def require_covariances(self, algorithm: str) -> None:
        """Raise unless both landmark and observation covariances are given."""
        if self.landmarks.covariances is None and self.state_covariance is None:
            raise InvalidInputError(f'landmarks.covariances: required by {algorithm!r}')
        if self.observations.covariances is None:
            raise InvalidInputError(f'observations.covariances: required by {algorithm!r}')

    @property
    def has_covariances(self) -> bool:
        """True when S can be computed."""
        return self.observations.covariances is not None and (
            self.landmarks.covariances is not None or self.state_covariance is not None)

    @cached_property
    def _prediction(self):
        pose = None if self.pose is None else self.pose.mean
        if len(self.landmarks) == 0:
            m = self.observations.dim
            d = self.model.landmark_dim(m)
            return np.zeros((0, m)), np.zeros((0, m, d)), np.zeros((0, m, 3))
        return self.model.predict(self.landmarks.means, pose)

    @property
    def predictions(self) -> np.ndarray:
        """h_j (N, m)."""
        return self._prediction[0]

    @cached_property
    def innovations(self) -> np.ndarray:
        """nu_ij (K, N, m)."""
        return self.model.innovation(self.observations.values, self.predictions)

    def innovations_of(self, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """nu of the pairs (rows[e], columns[e]) (E, m): innovations[rows, columns], without the
        (K, N, m) array when it has not been computed."""
        if 'innovations' in self.__dict__:
            return self.innovations[rows, columns]
        return self.model.pair_innovations(self.observations.values[rows],
                                           self.predictions[columns])

    def pair_terms(self, rows: np.ndarray, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(nu (E, m), S (E, m, m)) of the pairs (rows[e], columns[e]): innovations and
        innovation_covariances at those pairs, without the (K, N) arrays."""
        kernels = jit.problem_kernels()
        if kernels is not None:
            return kernels.run_pair_terms(self.observations.values, self.predictions,
                                          self.model.angular, self.prediction_covariances,
                                          self.observations.covariances,
                                          self.min_innovation_variance, rows, columns)
        s = self.prediction_covariances[columns] + self.observations.covariances[rows]
        return self.innovations_of(rows, columns), self._floored(s)

    @property
    def pose_covariance(self) -> np.ndarray:
        """Covariance of the pose (3, 3): the joint covariance's block, else the pose's (zeros
        without a pose)."""
        return self._pose_covariance()

    def _pose_covariance(self) -> np.ndarray:
        if self.state_covariance is not None:
            return self.state_covariance[:3, :3]
        return np.zeros((3, 3)) if self.pose is None else self.pose.covariance

    def _landmark_block(self, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """Cov(m_rows, m_columns) as (len(rows), len(columns), d, d)."""
        d = self.landmarks.dim
        if self.state_covariance is not None:
            blocks = self.state_covariance[3:, 3:].reshape(len(self.landmarks), d,
                                                           len(self.landmarks), d)
            return blocks[rows][:, :, columns].transpose(0, 2, 1, 3)
        out = np.zeros((len(rows), len(columns), d, d))
        same = rows[:, None] == columns[None, :]
        a, b = np.nonzero(same)
        out[a, b] = self.landmarks.covariances[rows[a]]
        return out

    def _pose_landmark_block(self, columns: np.ndarray) -> np.ndarray:
        """Cov(pose, m_columns) as (len(columns), 3, d)."""
        d = self.landmarks.dim
        if self.state_covariance is None:
            return np.zeros((len(columns), 3, d))
        cross = self.state_covariance[:3, 3:].reshape(3, len(self.landmarks), d)
        return cross[:, columns].transpose(1, 0, 2)

    @cached_property
    def prediction_covariances(self) -> np.ndarray:
        """H_j P H_j^T (N, m, m): covariance of each prediction."""
        _, h_m, h_x = self._prediction
        n = len(self.landmarks)
        if n == 0:
            return np.zeros((0,) + (self.observations.dim,) * 2)
        kernels = jit.problem_kernels()
        if kernels is not None:
            return kernels.run_prediction_covariances(h_x, h_m, self._pose_covariance(),
                                                      self.landmarks.covariances,
                                                      self.state_covariance)
        index = np.arange(n)
        if self.state_covariance is not None:
            d = self.landmarks.dim
            blocks = self.state_covariance[3:, 3:].reshape(n, d, n, d)
            p_mm = blocks[index, :, index, :]
        else:
            p_mm = self.landmarks.covariances
        return prediction_covariances(h_x, h_m, self._pose_covariance(),
                                      None if self.state_covariance is None
                                      else self._pose_landmark_block(index), p_mm)

    def joint_prediction_covariance(self, landmark_indices: np.ndarray) -> np.ndarray:
        """Cov(h_a, h_b) for a, b in `landmark_indices` (L, L, m, m): H_a P H_b^T, as one
        product J P_sub J^T with J = [H_x stacked (L m, 3), blockdiag H_m (L m, L d)]."""
        _, h_m, h_x = self._prediction
        idx = np.asarray(landmark_indices, dtype=np.intp)
        count, m, d = len(idx), self.observations.dim, self.landmarks.dim
        jacobian = np.zeros((count, m, 3 + count * d))
        jacobian[:, :, :3] = h_x[idx]
        blocks = jacobian[:, :, 3:].reshape(count, m, count, d)
        blocks[np.arange(count), :, np.arange(count), :] = h_m[idx]
        covariance = np.empty((3 + count * d, 3 + count * d))
        covariance[:3, :3] = self._pose_covariance()
        p_xm = self._pose_landmark_block(idx).transpose(1, 0, 2).reshape(3, count * d)
        covariance[:3, 3:] = p_xm
        covariance[3:, :3] = p_xm.T
        covariance[3:, 3:] = self._landmark_block(idx, idx).transpose(0, 2, 1, 3).reshape(
            count * d, count * d)
        if self.state_covariance is not None:
            check_positive_semidefinite(covariance, 'state_covariance')
        flat = jacobian.reshape(count * m, 3 + count * d)
        joint = flat @ covariance @ flat.T
        return joint.reshape(count, m, count, m).transpose(0, 2, 1, 3)

    def _floored(self, s: np.ndarray) -> np.ndarray:
        """s with its diagonals raised to min_innovation_variance (in place)."""
        if self.min_innovation_variance > 0:
            diagonal = np.einsum('...ii->...i', s)
            diagonal[...] = np.maximum(diagonal, self.min_innovation_variance)
        return s

    @cached_property
    def innovation_covariances(self) -> np.ndarray:
        """S_ij = H_j P H_j^T + R_i (K, N, m, m), diagonal floored at min_innovation_variance."""
        return self._floored(self.prediction_covariances[None, :, :, :]
                             + self.observations.covariances[:, None, :, :])

    @cached_property
    def _one_noise(self) -> bool:
        """True when every observation has the same R (one sensor: S_ij = S_j)."""
        r = self.observations.covariances
        return len(r) > 0 and bool((r == r[0]).all())

    @cached_property
    def _shared_innovation_covariances(self) -> Optional[np.ndarray]:
        """S_j (N, m, m) when every observation has the same R, so N factorisations replace
        K N; None otherwise."""
        if not self._one_noise:
            return None
        return self._floored(self.prediction_covariances + self.observations.covariances[0])

    @cached_property
    def nis(self) -> np.ndarray:
        """d2_ij = nu_ij^T S_ij^-1 nu_ij (K, N)."""
        k, n = self.sizes
        if k == 0 or n == 0:
            return np.zeros((k, n))
        kernels = jit.problem_kernels() if self.observations.dim == 2 else None
        if kernels is not None and self.model.name == 'range_bearing' and \
                '_prediction' not in self.__dict__:
            return self._range_bearing_nis(kernels)
        if kernels is not None:
            return kernels.run_nis_2d(self.observations.values, self.predictions,
                                      self.model.angular, self.prediction_covariances,
                                      self.observations.covariances, self._one_noise,
                                      self.min_innovation_variance)
        nu = self.innovations
        shared = self._shared_innovation_covariances
        if shared is not None:
            return nis_of_innovations(nu, shared)
        if self.observations.dim == 2:
            return nis_2d_of_sum(nu[..., 0], nu[..., 1], self.prediction_covariances,
                                 self.observations.covariances,
                                 self.min_innovation_variance
                                 if self.min_innovation_variance > 0 else -np.inf)
        with np.errstate(invalid='ignore', over='ignore'):
            inverse = _inverses(self.innovation_covariances)
            d2 = np.einsum('knm,knm->kn', nu, np.einsum('knab,knb->kna', inverse, nu))
        # a numerically singular S (absurd magnitudes): that pair can never be gated
        return np.where(np.isfinite(d2) & (d2 >= 0), d2, np.inf)

    def _range_bearing_nis(self, kernels) -> np.ndarray:
        """nis (K, N) by one compiled call that also fills the caches of _prediction and
        prediction_covariances (range_bearing, whose three kernels it runs)."""
        prediction, covariances, nis = kernels.run_range_bearing_nis(
            self.landmarks.means, self.pose.mean, self._pose_covariance(),
            self.landmarks.covariances, self.state_covariance, self.observations.values,
            self.observations.covariances, self.min_innovation_variance)
        self.__dict__.update(_prediction=prediction, prediction_covariances=covariances)
        return nis

    @cached_property
    def log_likelihoods(self) -> np.ndarray:
        """log N(nu_ij; 0, S_ij) = -(d2 + log det(2 pi S)) / 2 (K, N)."""
        k, n = self.sizes
        if k == 0 or n == 0:
            return np.zeros((k, n))
        shared = self._shared_innovation_covariances
        _, logdet = np.linalg.slogdet(2.0 * np.pi * (
            self.innovation_covariances if shared is None else shared))
        with np.errstate(invalid='ignore'):
            loglik = -0.5 * (self.nis + logdet)
        return np.where(np.isfinite(loglik), loglik, -np.inf)

    @cached_property
    def euclidean_distances(self) -> np.ndarray:
        """|nu_ij| in measurement units (K, N)."""
        return np.linalg.norm(self.innovations, axis=-1)

    def nis_of(self, assignment: np.ndarray) -> np.ndarray:
        """Individual NIS of each chosen pair (K,), NaN where unpaired or S unavailable."""
        out = np.full(len(assignment), np.nan)
        if not self.has_covariances:
            return out
        paired = np.flatnonzero(assignment >= 0)
        if paired.size:
            column = {int(lid): j for j, lid in enumerate(self.landmarks.ids)}
            cols = np.array([column[int(a)] for a in assignment[paired]])
            out[paired] = self.nis[paired, cols]
        return out
