"""Exact spatial gating: the landmarks that an observation's gate can accept, found with k-d trees.

A landmark j can pass observation i's gate only if its mean lies within a radius D_i of the
observation's map-frame point q_i (the inverse measurement model at the mean pose).  D_i comes
from an upper bound on the innovation covariance S' (S = H P H^T + R_i, its diagonal floored at
f = min_innovation_variance, so S' <= S + f I), using sd(a + b) <= sd(a) + sd(b), which holds for
correlated terms (the joint covariance's cross terms included).  With sigma_m = sqrt(lambda_max)
of the landmark's covariance, sigma_xy = sqrt(lambda_max) of the pose's position block,
sigma_yaw = sqrt(P_yaw), gamma_i the NIS bound of the gate:

* point_map, box (z = m):  |nu|^2 <= gamma lambda_max(S') and D^2 = gamma (sigma_m^2 +
  lambda_max(R_i) + f).
* point_robot (z = R^T (m - t)): |nu| = |q_i - m_j|, lambda_max(S) <= (sigma_xy + rho_j sigma_yaw +
  sigma_m)^2 + lambda_max(R_i) with rho_j = |m_j - t| <= |z_i| + D, so
  D = (sqrt(gamma) (sigma_xy + |z_i| sigma_yaw + sigma_m) + sqrt(gamma (lambda_max(R_i) + f)))
  / (1 - sqrt(gamma) sigma_yaw), unbounded (every landmark) when sqrt(gamma) sigma_yaw >= 1.
* range_bearing: |q_i - m_j|^2 = dr^2 + 2 r_i rho_j (1 - cos db) <= dr^2 + r_i rho_j min(db^2, 4),
  with dr^2 <= gamma S'_rr <= gamma ((sigma_xy + sigma_m)^2 + R_rr + f) =: Dr^2 and
  db^2 <= gamma S'_bb <= gamma (((sigma_xy + sigma_m) / rho_j + sigma_yaw)^2 + R_bb + f); with
  a = sigma_xy + sigma_m, min(4 rho, gamma a^2 / rho) <= 2 sqrt(gamma) a and rho_j <= r_i + Dr:
  D^2 = Dr^2 + max(r_i, 0) (2 sqrt(gamma) a + 2 gamma a sigma_yaw + gamma (sigma_yaw^2 + R_bb + f)
  (r_i + Dr)).
* A Euclidean gate |nu| <= g: D = g for the point models; range_bearing D^2 = g^2 +
  max(r_i, 0) (r_i + g) min(g^2, 4).

Landmarks are grouped by sigma_m in powers of two, one k-d tree per group queried with that
group's largest sigma_m, so a few uncertain landmarks never widen the search for the rest.
Radii get a relative margin of 1e-6 and an absolute one of 1e-9 (1 + |q_i| + |t|) against
rounding.  The trees depend only on the means and spreads: they are built once per map (and
per joint covariance) and kept with the Landmarks object, which is immutable.
"""
from __future__ import annotations

import itertools
import weakref
from typing import Callable, Optional

import numpy as np
from scipy.spatial import cKDTree

from .gating import Gate
from .problem import landmark_blocks
from .types import Landmarks, Observations

INDEX_MIN_LANDMARKS = 64
"""associate(spatial_index=None) uses an index already built for maps of at least this many
landmarks (a prior map, a map that serves several scans); below it one vectorised pass over all
pairs is as fast."""
INDEX_BUILD_MIN_LANDMARKS = 512
"""associate(spatial_index=None) builds an index for maps of at least this many landmarks:
below it, building the trees for one scan costs more than the pairs it saves (measured with a
new map per scan, 2-100 range-bearing observations: docs/large_maps.md)."""
MAX_SPREAD_CLASSES = 12
"""At most this many k-d trees per map (spread classes are merged to powers of 4, 16, ...)."""
_RELATIVE_MARGIN = 1e-6
_ABSOLUTE_MARGIN = 1e-9
_CACHE_ATTRIBUTE = '_spatial_index'


def largest_eigenvalues(matrices: np.ndarray) -> np.ndarray:
    """lambda_max of each symmetric matrix of a stack (n, d, d) -> (n,); closed form for d = 2."""
    if matrices.shape[0] == 0:
        return np.zeros(0)
    if matrices.shape[-1] == 2:
        a, b, c = matrices[:, 0, 0], matrices[:, 0, 1], matrices[:, 1, 1]
        return 0.5 * (a + c) + np.hypot(0.5 * (a - c), b)
    return np.linalg.eigvalsh(matrices)[:, -1]


def landmark_spreads(landmarks: Landmarks, state_covariance: Optional[np.ndarray]) -> np.ndarray:
    """sigma_m = sqrt(lambda_max(P_j)) of each landmark (N,) [landmark units]: from the joint
    covariance's diagonal blocks when given, else the marginal covariances (0 without any)."""
    n, d = len(landmarks), landmarks.dim if len(landmarks) else 2
    if state_covariance is not None:
        return spreads(landmark_blocks(state_covariance, np.arange(n), d))
    if landmarks.covariances is not None:
        return spreads(landmarks.covariances)
    return np.zeros(n)


def spreads(matrices: np.ndarray) -> np.ndarray:
    """sqrt(lambda_max) of each symmetric matrix of a stack (n, d, d) -> (n,) (the largest
    standard deviation along any direction; 0 for a matrix with no positive eigenvalue)."""
    return np.sqrt(np.maximum(largest_eigenvalues(matrices), 0.0))


class LandmarkIndex:
    """k-d trees over the landmark means (N, d), one per spread class."""

    def __init__(self, means: np.ndarray, spreads: np.ndarray) -> None:
        self.size = len(means)
        self.classes: list[tuple[float, np.ndarray, cKDTree]] = []
        if self.size == 0:
            return
        exponents = np.ceil(np.log2(np.maximum(spreads, 1e-300)))
        step = 1.0
        groups = np.ceil(exponents / step)
        while len(np.unique(groups)) > MAX_SPREAD_CLASSES:
            step *= 2.0
            groups = np.ceil(exponents / step)
        for group in np.unique(groups):
            members = np.flatnonzero(groups == group)
            self.classes.append((float(spreads[members].max()), members,
                                 cKDTree(means[members])))

    def candidates(self, points: np.ndarray, radius_of: Callable[[float], np.ndarray]
                   ) -> np.ndarray:
        """Sorted columns (L,) of the landmarks within radius_of(sigma)[i] of some points[i]
        (points (K, d); radius_of gives the (K,) radii for a class of spread <= sigma; inf:
        every landmark of the class)."""
        found = []
        for spread, members, tree in self.classes:
            radii = radius_of(spread)
            bounded = np.isfinite(radii)
            if not bounded.all():
                found.append(members)
                continue
            hits = tree.query_ball_point(points, radii, return_sorted=False)
            flat = np.fromiter(itertools.chain.from_iterable(hits), dtype=np.intp)
            found.append(members[flat])
        if not found:
            return np.zeros(0, dtype=np.intp)
        return np.unique(np.concatenate(found))


def has_index(landmarks: Landmarks, state_covariance: Optional[np.ndarray] = None) -> bool:
    """True when landmark_index(landmarks, state_covariance) is already built (no cost)."""
    cached = landmarks.__dict__.get(_CACHE_ATTRIBUTE)
    return cached is not None and _fits(cached[0], state_covariance)


def wants_index(landmarks: Landmarks, state_covariance: Optional[np.ndarray] = None) -> bool:
    """associate(spatial_index=None)'s choice: index maps of INDEX_BUILD_MIN_LANDMARKS or more,
    and maps of INDEX_MIN_LANDMARKS or more whose index is built already."""
    n = len(landmarks)
    return n >= INDEX_BUILD_MIN_LANDMARKS or (
        n >= INDEX_MIN_LANDMARKS and has_index(landmarks, state_covariance))


def _fits(reference, state_covariance: Optional[np.ndarray]) -> bool:
    """An index built with the joint covariance `reference` (a weak reference, None: the
    marginals) serves `state_covariance`."""
    return (state_covariance is None and reference is None) or (
        reference is not None and reference() is state_covariance)


def landmark_index(landmarks: Landmarks, state_covariance: Optional[np.ndarray] = None
                   ) -> LandmarkIndex:
    """The index of `landmarks` with the spreads of `state_covariance` (None: the marginal
    covariances).  Built at the first call and kept with the (immutable) Landmarks object for
    the next scans; a joint covariance is remembered by identity (it is read-only once
    checked), a new one rebuilds the index."""
    cached = landmarks.__dict__.get(_CACHE_ATTRIBUTE)
    if cached is not None and _fits(cached[0], state_covariance):
        return cached[1]
    index = LandmarkIndex(landmarks.means, landmark_spreads(landmarks, state_covariance))
    keep = state_covariance is None or not state_covariance.flags.writeable
    if keep:
        reference = None if state_covariance is None else weakref.ref(state_covariance)
        object.__setattr__(landmarks, _CACHE_ATTRIBUTE, (reference, index))
    return index


def search_radii(model: str, observations: Observations, pose_mean: Optional[np.ndarray],
                 pose_covariance: np.ndarray, gate: Gate, min_innovation_variance: float
                 ) -> tuple[np.ndarray, Callable[[float], np.ndarray]]:
    """(q (K, d): the observations in the map frame, radius_of(sigma_m) -> (K,) radii [m]): see
    the module doc for the bounds of each model."""
    from .models import MODELS    # models import types; keep this module importable alone
    values = observations.values
    points = MODELS[model].inverse(values, pose_mean)[0] if MODELS[model].needs_pose else values
    translation = 0.0 if pose_mean is None else float(np.hypot(pose_mean[0], pose_mean[1]))
    margin = _ABSOLUTE_MARGIN * (1.0 + np.linalg.norm(points, axis=1) + translation)
    f = min_innovation_variance
    ranges = values[:, 0] if model == 'range_bearing' else None

    def padded(radii: np.ndarray) -> np.ndarray:
        radii = radii * (1.0 + _RELATIVE_MARGIN) + margin
        return np.where(np.isnan(radii), np.inf, radii)

    if gate.distance is not None:
        g = gate.distance
        if model == 'range_bearing':
            radii = np.sqrt(g * g + np.maximum(ranges, 0.0) * np.maximum(ranges + g, 0.0)
                            * min(g * g, 4.0))
        else:
            radii = np.full(len(values), g)
        fixed = padded(radii)
        return points, lambda spread: fixed

    gamma = gate.nis_bound
    root = np.sqrt(gamma)
    noise = observations.covariances
    pose_cov = np.zeros((3, 3)) if pose_covariance is None else pose_covariance
    sigma_xy = float(spreads(pose_cov[None, :2, :2])[0])
    sigma_yaw = float(np.sqrt(max(pose_cov[2, 2], 0.0)))
    with np.errstate(over='ignore', invalid='ignore', divide='ignore'):
        if model == 'range_bearing':
            r_plus = np.maximum(ranges, 0.0)
            r_rr, r_bb = noise[:, 0, 0], noise[:, 1, 1]

            def radius_of(spread: float) -> np.ndarray:
                with np.errstate(over='ignore', invalid='ignore'):
                    a = sigma_xy + spread
                    dr = np.sqrt(gamma * (a * a + r_rr + f))
                    bearing = (2.0 * root * a + 2.0 * gamma * a * sigma_yaw
                               + gamma * (sigma_yaw ** 2 + r_bb + f) * np.maximum(ranges + dr, 0.0))
                    return padded(np.sqrt(dr * dr + r_plus * bearing))
            return points, radius_of
        noise_max = largest_eigenvalues(noise)
        if model == 'point_robot':
            distance = np.linalg.norm(values, axis=1)
            denominator = 1.0 - root * sigma_yaw

            def radius_of(spread: float) -> np.ndarray:
                with np.errstate(over='ignore', invalid='ignore', divide='ignore'):
                    numerator = root * (sigma_xy + distance * sigma_yaw + spread) \
                        + np.sqrt(gamma * (noise_max + f))
                    return padded(np.where(denominator > 0, numerator / denominator, np.inf))
            return points, radius_of

        def radius_of(spread: float) -> np.ndarray:
            with np.errstate(over='ignore', invalid='ignore'):
                return padded(np.sqrt(gamma * (spread * spread + noise_max + f)))
        return points, radius_of
