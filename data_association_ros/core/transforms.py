"""Rigid SE(2) transforms between paired 2-D points: Kabsch least squares and RANSAC.

A transform maps source points into the target frame, q = R(yaw) p + t, with
R(yaw) = [[cos yaw, -sin yaw], [sin yaw, cos yaw]] and t = (x, y).  Lengths in metres,
angles in radians, yaw in (-pi, pi].  Bad input raises InvalidInputError naming the field.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .errors import InvalidInputError
from .validation import as_float_array, check_shape

_RELATIVE_TOLERANCE = 1e-10
"""Spreads below this times (1 + largest |coordinate|) count as coincident points."""
_MAX_CHUNK_ELEMENTS = 1 << 18
"""RANSAC evaluates hypotheses in chunks of at most this many (hypothesis, pair) residuals."""


@dataclass(frozen=True, eq=False)
class RigidTransform2D:
    """q = R(yaw) p + (x, y): maps source points p into the target frame.

    covariance: (3, 3) of (x, y, yaw) [m^2, m rad, rad^2], estimated from the residuals.
    inliers: (n,) bool, the pairs the estimate used.  rms_error: sqrt(mean |q_i - R p_i - t|^2)
    over the inliers (weighted mean when weights were given) [m].
    """

    x: float
    y: float
    yaw: float
    covariance: np.ndarray
    inliers: np.ndarray
    rms_error: float

    def rotation(self) -> np.ndarray:
        """R(yaw), (2, 2)."""
        return _rotation(self.yaw)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """(n, 2) source points -> (n, 2) target-frame points R p + t."""
        array = as_float_array(points, 'points', 2)
        check_shape(array, 'points', (None, 2))
        return array @ self.rotation().T + np.array([self.x, self.y])

    def matrix(self) -> np.ndarray:
        """3x3 homogeneous [[R, t], [0, 0, 1]]: [q; 1] = matrix() @ [p; 1]."""
        result = np.eye(3)
        result[:2, :2] = self.rotation()
        result[:2, 2] = (self.x, self.y)
        return result


def estimate_rigid_transform(source: np.ndarray, target: np.ndarray,
                             weights: Optional[np.ndarray] = None) -> RigidTransform2D:
    """Least-squares rigid transform (Kabsch/Umeyama, no scale) minimising
    sum_i w_i |R p_i + t - q_i|^2.

    source, target: (n, 2) paired points, n >= 2.  weights: (n,) >= 0 or None (all 1); pairs of
    weight 0 are ignored (inliers = weights > 0); at least 2 pairs with distinct source points
    must keep a positive weight.
    Weighted centroids c_s, c_t; H = sum_i w_i (p_i - c_s)(q_i - c_t)^T = U S V^T;
    R = V diag(1, d) U^T with d = sign det(V U^T) (never a reflection); t = c_t - R c_s.
    covariance = sigma2 (J^T W J)^-1, where J (2m x 3) is the Jacobian of the residuals
    r_i = R p_i + t - q_i w.r.t. (x, y, yaw) at the solution, m the number of pairs used and
    sigma2 = sum_i w_i |r_i|^2 / max(2m - 3, 1) (so weights need only be relative).
    """
    source, target = _check_pairs(source, target)
    if weights is None:
        weights = np.ones(len(source))
    else:
        weights = as_float_array(weights, 'weights', 1)
        check_shape(weights, 'weights', (len(source),))
        negative = np.flatnonzero(weights < 0)
        if negative.size:
            raise InvalidInputError(
                f'weights[{negative[0]}]: negative ({weights[negative[0]]})')
    used = weights > 0
    if used.sum() < 2:
        raise InvalidInputError(
            f'weights: need at least 2 positive weights, got {int(used.sum())}')
    return _kabsch(source[used], target[used], weights[used], used)


def ransac_rigid_transform(source: np.ndarray, target: np.ndarray,
                           inlier_threshold: float = 0.1, iterations: int = 200,
                           seed: Optional[int] = 0, min_inliers: int = 2) -> RigidTransform2D:
    """Robust rigid transform: RANSAC over minimal samples, then Kabsch on the best inliers.

    source, target: (n, 2) paired points, n >= 2.  Each of `iterations` hypotheses is the exact
    least-squares fit of 2 distinct random pairs (i, j): yaw = atan2(ds x dt, ds . dt) with
    ds = p_j - p_i, dt = q_j - q_i; samples with |ds| or |dt| ~ 0 are skipped.  A pair is an
    inlier of a hypothesis when |R p + t - q| <= inlier_threshold [m]; the best hypothesis has
    the most inliers (ties: lower inlier RMS).  Stops early once a hypothesis has all n pairs as
    inliers.  The result is estimate_rigid_transform on the best hypothesis's inliers.
    seed: for numpy.random.default_rng (None: fresh entropy).  Raises InvalidInputError when
    no hypothesis reaches min_inliers (>= 2) inliers.
    """
    source, target = _check_pairs(source, target)
    threshold = _check_positive_float(inlier_threshold, 'inlier_threshold')
    iterations = _check_int(iterations, 'iterations', 1)
    min_inliers = _check_int(min_inliers, 'min_inliers', 2)
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))
                             or seed < 0):
        raise InvalidInputError(f'seed: expected a non-negative int or None, got {seed!r}')
    rng = np.random.default_rng(seed)
    n = len(source)
    source_tolerance = _coincidence_tolerance(source) ** 2
    target_tolerance = _coincidence_tolerance(target) ** 2
    chunk = max(1, min(iterations, _MAX_CHUNK_ELEMENTS // n))
    best_count, best_rms, best_mask = -1, np.inf, None
    done = 0
    while done < iterations and best_count < n:
        k = min(chunk, iterations - done)
        done += k
        first = rng.integers(n, size=k)
        second = (first + rng.integers(1, n, size=k)) % n  # uniform over pairs j != i
        d_source = source[second] - source[first]
        d_target = target[second] - target[first]
        valid = (np.einsum('kd,kd->k', d_source, d_source) > source_tolerance) & \
            (np.einsum('kd,kd->k', d_target, d_target) > target_tolerance)
        if not valid.any():
            continue
        first, second = first[valid], second[valid]
        d_source, d_target = d_source[valid], d_target[valid]
        yaw = np.arctan2(d_source[:, 0] * d_target[:, 1] - d_source[:, 1] * d_target[:, 0],
                         np.einsum('kd,kd->k', d_source, d_target))
        cos, sin = np.cos(yaw), np.sin(yaw)
        rotations = np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], -2)
        source_mid = 0.5 * (source[first] + source[second])
        target_mid = 0.5 * (target[first] + target[second])
        translations = target_mid - np.einsum('kab,kb->ka', rotations, source_mid)
        # (k, n) squared residuals of every pair under every hypothesis
        residuals = np.einsum('kab,nb->kna', rotations, source) + translations[:, None, :] \
            - target[None, :, :]
        squared = np.einsum('kna,kna->kn', residuals, residuals)
        inliers = squared <= threshold ** 2
        counts = inliers.sum(axis=1)
        rms = np.sqrt(np.where(inliers, squared, 0.0).sum(axis=1) / np.maximum(counts, 1))
        winner = np.lexsort((rms, -counts))[0]
        if (counts[winner], -rms[winner]) > (best_count, -best_rms):
            best_count, best_rms, best_mask = int(counts[winner]), rms[winner], inliers[winner]
    if best_count < min_inliers:
        raise InvalidInputError(
            f'source/target: no RANSAC hypothesis reached min_inliers={min_inliers} '
            f'(best {max(best_count, 0)} of {n} pairs within {threshold} m)')
    try:
        return _kabsch(source[best_mask], target[best_mask], np.ones(best_count), best_mask)
    except InvalidInputError as error:
        raise InvalidInputError(f'source: inliers of the best RANSAC hypothesis are '
                                f'degenerate ({error})') from None


def _kabsch(source: np.ndarray, target: np.ndarray, weights: np.ndarray,
            mask: np.ndarray) -> RigidTransform2D:
    """Weighted Kabsch on the (m, 2) pairs actually used; `mask` is the (n,) inliers field."""
    total = weights.sum()
    source_centroid = weights @ source / total
    target_centroid = weights @ target / total
    source_centred = source - source_centroid
    spread = np.sqrt(weights @ np.einsum('md,md->m', source_centred, source_centred) / total)
    if spread <= _coincidence_tolerance(source):
        raise InvalidInputError('source: the points used all coincide; the rotation is undefined')
    cross = (source_centred * weights[:, None]).T @ (target - target_centroid)
    u, _, vt = np.linalg.svd(cross)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rotation = vt.T @ np.diag([1.0, d]) @ u.T
    yaw = float(np.arctan2(rotation[1, 0], rotation[0, 0]))
    if yaw <= -np.pi:
        yaw += 2.0 * np.pi
    rotation = _rotation(yaw)
    translation = target_centroid - rotation @ source_centroid
    rotated = source @ rotation.T
    residuals = rotated + translation - target
    squared = np.einsum('md,md->m', residuals, residuals)
    m = len(source)
    sigma2 = weights @ squared / max(2 * m - 3, 1)
    # J_i = [[1, 0, -(R p_i)_y], [0, 1, (R p_i)_x]]
    jacobian = np.zeros((m, 2, 3))
    jacobian[:, 0, 0] = jacobian[:, 1, 1] = 1.0
    jacobian[:, 0, 2] = -rotated[:, 1]
    jacobian[:, 1, 2] = rotated[:, 0]
    normal = np.einsum('m,mai,maj->ij', weights, jacobian, jacobian)
    covariance = sigma2 * np.linalg.inv(normal)
    covariance = 0.5 * (covariance + covariance.T)
    covariance.setflags(write=False)
    inliers = np.array(mask, dtype=bool)
    inliers.setflags(write=False)
    return RigidTransform2D(x=float(translation[0]), y=float(translation[1]), yaw=yaw,
                            covariance=covariance, inliers=inliers,
                            rms_error=float(np.sqrt(weights @ squared / total)))


def _check_pairs(source, target) -> tuple[np.ndarray, np.ndarray]:
    """Both as finite float64 (n, 2) arrays of the same n >= 2."""
    source = as_float_array(source, 'source', 2)
    check_shape(source, 'source', (None, 2))
    target = as_float_array(target, 'target', 2)
    check_shape(target, 'target', (len(source), 2))
    if len(source) < 2:
        raise InvalidInputError(f'source: need at least 2 pairs, got {len(source)}')
    return source, target


def _check_positive_float(value, field: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f'{field}: not a number ({value!r})') from None
    if not np.isfinite(number) or number <= 0:
        raise InvalidInputError(f'{field}: expected a finite number > 0, got {number}')
    return number


def _check_int(value, field: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InvalidInputError(f'{field}: expected an int >= {low}, got {value!r}')
    return int(value)


def _coincidence_tolerance(points: np.ndarray) -> float:
    return _RELATIVE_TOLERANCE * (1.0 + float(np.abs(points).max(initial=0.0)))


def _rotation(yaw: float) -> np.ndarray:
    cos, sin = np.cos(yaw), np.sin(yaw)
    return np.array([[cos, -sin], [sin, cos]])
