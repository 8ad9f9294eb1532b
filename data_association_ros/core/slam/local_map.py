"""The local map of an EKF-SLAM state: the landmarks some observation of a scan can be paired with.

Landmark j is in the local map when, for some observation i of the scan, one of these gates
(the association node's, up to these sizes) could accept the pair:
* chi-square: d2_ij <= LOCAL_MAP_GATE = chi2(1 - 1e-9, 2) = 41.4, with S_ij from the joint
  covariance of [pose, landmark j] (cross terms included) whose pose block is widened by
  W = diag(p^2, p^2, psi^2) (p, psi: `position_std`, `yaw_std`).  A pose recovery's second pass
  adds at most W to the pose block; S only grows with it, so no NIS under the recovery is
  smaller than the one tested here;
* Euclidean: |nu_ij| <= g (`euclidean_gate`, measurement units).
Not covered: a min_innovation_variance of the order of the innovation variances, and a
maximum_likelihood gate beyond 41.4 (a measurement noise with log det R < -2 ln(alpha) - 45):
set a radius for those.

Two steps.  A distance bound first (no landmark beyond it can pass either gate): with
s = sqrt(LOCAL_MAP_GATE), r the scan's largest observation distance, sigma_xy =
sqrt(lambda_max(P_pose[:2, :2] + W[:2, :2])), sigma_yaw = sqrt(P_yaw + psi^2), sigma_j =
sqrt(lambda_max(P_j)) (sd(a + b) <= sd(a) + sd(b), as in core/spatial_index.py):
* range_bearing: the range innovation r_i - rho_j has variance <= (sigma_xy + sigma_j)^2 + R_rr
  (the range does not depend on the yaw), so rho_j <= r + s (sigma_xy + sigma_j + sigma_z),
  sigma_z = max sqrt(R_rr); |nu| >= |r_i - rho_j| gives rho_j <= r + g;
* point_robot: |nu| >= rho_j - |z_i| and lambda_max(S) <= (sigma_xy + rho_j sigma_yaw +
  sigma_j)^2 + lambda_max(R_i), so rho_j <= (r + s (sigma_xy + sigma_j + sigma_z)) /
  (1 - s sigma_yaw), sigma_z = max sqrt(lambda_max(R_i)) (every landmark when s sigma_yaw >= 1);
  and rho_j <= r + g.
Then the NIS and |nu| of every observation with every landmark inside the bound, from the
[pose, landmark] blocks of the joint covariance (core/problem.py's prediction_covariances, the
association's own computation).  A numerically singular S passes no chi-square gate, as in
the association; a landmark whose blocks are not finite is kept (the association node refuses
such a covariance and pairs with the marginal covariances instead).
"""
from __future__ import annotations

import numpy as np

from ..gating import chi2_threshold
from ..models import MODELS
from ..pose_recovery import added_pose_noise
from ..problem import landmark_blocks, nis_2d_of_sum, prediction_covariances
from ..spatial_index import spreads

LOCAL_MAP_GATE = chi2_threshold(1.0 - 1e-9, 2)
"""The chi-square gate the local map covers: probability 1 - 1e-9 for 2-D observations (41.4)."""
POSITION_STD = 0.5
"""Default p [m]: the robot position noise a second association pass may add."""
YAW_STD = 0.1
"""Default psi [rad]: the heading noise a second association pass may add."""
EUCLIDEAN_GATE = 1.0
"""Default g: the largest Euclidean gate covered (association_node's default euclidean_gate)."""


def scan_reach(values: np.ndarray, model: str) -> float:
    """The largest distance of a robot-frame observation (K, 2) from the robot [m]: |range|
    (range_bearing) or |(x, y)| (point_robot); 0 for none."""
    distance = np.abs(values[:, 0]) if model == 'range_bearing' else \
        np.hypot(values[:, 0], values[:, 1])
    return float(np.max(distance, initial=0.0))


def reach_bound(model: str, pose_covariance: np.ndarray, covariances: np.ndarray,
                values: np.ndarray, noise: np.ndarray, euclidean_gate: float) -> np.ndarray:
    """The distance from the robot (N,) [m] beyond which landmark j (marginal covariance
    covariances[j] (2, 2)) passes neither gate with any observation (values (K, 2), noise
    (K, 2, 2)) of a robot with (already widened) `pose_covariance` (3, 3): the module doc's
    bound; inf where none exists."""
    s = float(np.sqrt(LOCAL_MAP_GATE))
    reach = scan_reach(values, model)
    sigma_xy = float(spreads(pose_covariance[None, :2, :2])[0])
    sigma_landmark = spreads(covariances)
    if model == 'range_bearing':
        sigma_z = float(np.sqrt(np.max(noise[:, 0, 0], initial=0.0)))
        chi_square = reach + s * (sigma_xy + sigma_landmark + sigma_z)
    else:
        sigma_z = float(np.max(spreads(noise), initial=0.0))
        shrink = 1.0 - s * float(np.sqrt(max(pose_covariance[2, 2], 0.0)))
        if shrink <= 0.0:
            return np.full(len(covariances), np.inf)
        chi_square = (reach + s * (sigma_xy + sigma_landmark + sigma_z)) / shrink
    return np.maximum(chi_square, reach + euclidean_gate)


def local_map_columns(model: str, pose: np.ndarray, state_covariance: np.ndarray,
                      means: np.ndarray, covariances: np.ndarray, values: np.ndarray,
                      noise: np.ndarray, radius: float = 0.0,
                      position_std: float = POSITION_STD, yaw_std: float = YAW_STD,
                      euclidean_gate: float = EUCLIDEAN_GATE) -> np.ndarray:
    """Sorted columns (L,) of the local map: landmarks (means (N, 2), marginal covariances
    (N, 2, 2), joint covariance of [pose, landmarks] `state_covariance` (3 + 2N, 3 + 2N)) that
    a scan of robot-frame observations `values` (K, 2) with `noise` (K, 2, 2) of `model`
    (range_bearing or point_robot), seen from `pose` (3,), can be paired with (module doc);
    with radius > 0 instead every landmark within `radius` [m] of the robot."""
    distance = np.hypot(means[:, 0] - pose[0], means[:, 1] - pose[1])
    if radius > 0:
        return np.flatnonzero(distance <= radius)
    if len(values) == 0 or len(means) == 0:
        return np.zeros(0, dtype=np.intp)
    wide_pose = state_covariance[:3, :3] + added_pose_noise(position_std, yaw_std)
    near = np.flatnonzero(distance <= reach_bound(model, wide_pose, covariances, values, noise,
                                                  euclidean_gate))
    if len(near) == 0:
        return near
    return near[_pairable(model, pose, wide_pose, state_covariance, means, covariances, values,
                          noise, near, euclidean_gate)]


def _pairable(model: str, pose: np.ndarray, wide_pose: np.ndarray,
              state_covariance: np.ndarray, means: np.ndarray, covariances: np.ndarray,
              values: np.ndarray, noise: np.ndarray, columns: np.ndarray,
              euclidean_gate: float) -> np.ndarray:
    """Mask (L,) of the landmarks at `columns` that pass either gate with some observation:
    S_ij = H_j P_j H_j^T + R_i from the [pose, landmark j] blocks alone (core/problem.py's
    prediction_covariances; the individual NIS needs no other block), the pose block
    replaced by the widened `wide_pose` (3, 3)."""
    measurement = MODELS[model]
    predicted, h_m, h_x = measurement.predict(means[columns], pose)
    first = 3 + 2 * columns
    pose_landmark = np.stack([state_covariance[:3, first], state_covariance[:3, first + 1]],
                             axis=-1).transpose(1, 0, 2)
    s = prediction_covariances(h_x, h_m, wide_pose, pose_landmark,
                               landmark_blocks(state_covariance, columns, 2))
    nu = measurement.innovation_components(values, predicted)   # (2, K, L)
    nis = nis_2d_of_sum(nu[0], nu[1], s, noise)
    inside = (nis <= LOCAL_MAP_GATE) | (np.hypot(nu[0], nu[1]) <= euclidean_gate)
    # a non-finite block: the association refuses this covariance and falls back to the
    # marginals, which may pair the landmark - keep it
    return inside.any(axis=0) | ~np.isfinite(s).all(axis=(1, 2))
