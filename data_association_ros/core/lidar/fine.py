"""Fine association (seed 003): pair one object's scan points with its predicted boundary points.

`jcbb_points` (the seed's choice) runs this package's JCBB point matcher with the boundary's
joint covariance: boundary point b_i = c + R(yaw) B_i moves with the track's pose, so
Cov(b_i, b_j) = A_i P A_j^T + delta_ij s_b^2 I with A_i = d b_i / d(x, y, yaw) = [I, J (b_i - c)],
J = [[0, -1], [1, 0]], P the predicted (x, y, yaw) covariance and s_b = `point_sigma`; a rigid
shift of all pairs is then cheap in the joint NIS and inconsistent pairs are not.
jNIS coordinates (`jnis`):
* cartesian: scan points z = (x, y) with R = s_b^2 I (the seed's recommendation);
* polar: z = (range, bearing) from the sensor with R = diag(s_b^2, `bearing_sigma`^2): a fixed
  bearing tolerance is bearing_sigma x range in metres, loose far from the sensor (the seed's
  reason to prefer Cartesian).
`nearest` (the seed's rejected alternative): every scan point takes its nearest boundary point
when within `nearest_cutoff` [m]; several scan points may share one.
"""
from __future__ import annotations

import numpy as np

from ..api import associate
from ..types import Landmarks, Observations, RobotPose

FINE_METHODS = ('jcbb_points', 'nearest')
JNIS_COORDINATES = ('cartesian', 'polar')
_ORIGIN = RobotPose(np.zeros(3))


def boundary_covariance(boundary: np.ndarray, centre: np.ndarray, pose_covariance: np.ndarray,
                        point_sigma: float) -> np.ndarray:
    """Joint covariance (2N, 2N) of N boundary points (N, 2) of a rectangle at `centre` whose
    (x, y, yaw) covariance is `pose_covariance` (3, 3); see the module docstring."""
    n = len(boundary)
    a = np.zeros((n, 2, 3))
    a[:, 0, 0] = a[:, 1, 1] = 1.0
    offset = boundary - centre
    a[:, 0, 2], a[:, 1, 2] = -offset[:, 1], offset[:, 0]
    flat = a.reshape(2 * n, 3)
    return flat @ pose_covariance @ flat.T + point_sigma ** 2 * np.eye(2 * n)


def match(scan: np.ndarray, boundary: np.ndarray, joint: np.ndarray, method: str = 'jcbb_points',
          jnis: str = 'cartesian', point_sigma: float = 0.05, bearing_sigma: float = 0.01,
          nearest_cutoff: float = 0.3, gate_probability: float = 0.99,
          time_budget_ms: float = 0.0, max_nodes: int = 500,
          sensor: np.ndarray = np.zeros(2)) -> np.ndarray:
    """Pairs (n, 2) int: (scan index, boundary index), for scan points (K, 2) and boundary points
    (N, 2) with joint covariance `joint` (2N, 2N) (see the module docstring); polar jNIS: range
    and bearing from `sensor` (2,)."""
    if not len(scan) or not len(boundary):
        return np.zeros((0, 2), dtype=int)
    if method == 'nearest':
        difference = scan[:, None, :] - boundary[None, :, :]
        distance = np.hypot(difference[..., 0], difference[..., 1])
        nearest = distance.argmin(axis=1)
        keep = distance[np.arange(len(scan)), nearest] <= nearest_cutoff
        return np.column_stack([np.flatnonzero(keep), nearest[keep]]).astype(int)
    state = np.zeros((3 + joint.shape[0],) * 2)
    state[3:, 3:] = joint
    landmarks = Landmarks(np.arange(len(boundary)), boundary)
    if jnis == 'polar':
        relative = scan - sensor
        values = np.column_stack([np.hypot(relative[:, 0], relative[:, 1]),
                                  np.arctan2(relative[:, 1], relative[:, 0])])
        noise = np.diag([point_sigma ** 2, bearing_sigma ** 2])
        observations = Observations(values, np.broadcast_to(noise, (len(scan), 2, 2)),
                                    'range_bearing')
        pose = RobotPose(np.array([sensor[0], sensor[1], 0.0])) if np.any(sensor) else _ORIGIN
    else:
        observations = Observations(scan, np.broadcast_to(point_sigma ** 2 * np.eye(2),
                                                          (len(scan), 2, 2)), 'point_map')
        pose = None
    result = associate(landmarks, observations, 'jcbb_points', pose=pose, state_covariance=state,
                       gate_probability=gate_probability, time_budget_ms=time_budget_ms,
                       max_nodes=max_nodes)
    paired = np.flatnonzero(result.assignment >= 0)
    return np.column_stack([paired, result.assignment[paired]]).astype(int)
