"""The local map of an EKF-SLAM state: the landmarks a scan can observe.

A landmark j can pass an observation's chi-square gate gamma only if its distance rho_j from
the robot's mean position t is bounded (sd(a + b) <= sd(a) + sd(b), as in
core/spatial_index.py; s = sqrt(gamma), r = the scan's largest observation distance,
sigma_xy = sqrt(lambda_max(P_pose[:2, :2])), sigma_yaw = sqrt(P_pose[2, 2]), sigma_j =
sqrt(lambda_max(P_j))):
* range_bearing: the range innovation r_i - rho_j has variance <= (sigma_xy + sigma_j)^2 + R_rr
  (the range does not depend on the yaw), so rho_j <= r + s (sigma_xy + sigma_j + sigma_z),
  sigma_z = max sqrt(R_rr);
* point_robot: |nu| >= rho_j - |z_i| and lambda_max(S) <= (sigma_xy + rho_j sigma_yaw +
  sigma_j)^2 + lambda_max(R_i), so rho_j <= (r + s (sigma_xy + sigma_j + sigma_z)) /
  (1 - s sigma_yaw), sigma_z = max sqrt(lambda_max(R_i)); every landmark when s sigma_yaw >= 1.
The local map takes s = LOCAL_MAP_SIGMAS (a gate of probability 1 - 1e-9) and adds
LOCAL_MAP_MARGIN, which covers a pose widened for a second try (pose recovery), Euclidean
gates up to that size and the associator's innovation variance floor.
"""
from __future__ import annotations

import numpy as np

from ..gating import chi2_threshold
from ..spatial_index import spreads

LOCAL_MAP_MARGIN = 5.0
"""Added to every landmark's bound [m]."""
LOCAL_MAP_SIGMAS = float(np.sqrt(chi2_threshold(1.0 - 1e-9, 2)))
"""s of the bound: 6.4, the chi-square gate of probability 1 - 1e-9 for 2-D observations."""


def scan_reach(values: np.ndarray, model: str) -> float:
    """The largest distance of a robot-frame observation (K, 2) from the robot [m]: |range|
    (range_bearing) or |(x, y)| (point_robot); 0 for none."""
    distance = np.abs(values[:, 0]) if model == 'range_bearing' else \
        np.hypot(values[:, 0], values[:, 1])
    return float(np.max(distance, initial=0.0))


def local_map_columns(model: str, pose: np.ndarray, pose_covariance: np.ndarray,
                      means: np.ndarray, covariances: np.ndarray, values: np.ndarray,
                      noise: np.ndarray, radius: float = 0.0) -> np.ndarray:
    """Sorted columns (L,) of the landmarks (means (N, 2), marginal covariances (N, 2, 2)) in
    the local map of a robot at `pose` (3,) with `pose_covariance` (3, 3) for a scan of
    robot-frame observations `values` (K, 2) with `noise` (K, 2, 2) of `model`
    (range_bearing or point_robot): the landmarks within `radius` [m] when radius > 0, else
    those the module doc's bound lets the scan see."""
    distance = np.hypot(means[:, 0] - pose[0], means[:, 1] - pose[1])
    if radius > 0:
        return np.flatnonzero(distance <= radius)
    s = LOCAL_MAP_SIGMAS
    sigma_xy = float(spreads(pose_covariance[None, :2, :2])[0])
    sigma_landmark = spreads(covariances)
    reach = scan_reach(values, model)
    if model == 'range_bearing':
        sigma_z = float(np.sqrt(np.max(noise[:, 0, 0], initial=0.0)))
        bound = reach + s * (sigma_xy + sigma_landmark + sigma_z)
    else:
        sigma_z = float(np.max(spreads(noise), initial=0.0))
        shrink = 1.0 - s * float(np.sqrt(max(pose_covariance[2, 2], 0.0)))
        if shrink <= 0.0:
            return np.arange(len(means))
        bound = (reach + s * (sigma_xy + sigma_landmark + sigma_z)) / shrink
    return np.flatnonzero(distance <= bound + LOCAL_MAP_MARGIN)
