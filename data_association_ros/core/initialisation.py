"""Observations in the map frame with their covariance, by the inverse measurement model:
x = g(z, pose),  Cov(x) = G_z R G_z^T + G_pose P_pose G_pose^T (first order)."""
from __future__ import annotations

from typing import Optional

import numpy as np

from .models import MODELS
from .types import Observations, RobotPose


def observations_in_map(observations: Observations,
                        pose: Optional[RobotPose]) -> tuple[np.ndarray, Optional[np.ndarray]]:
    """Map-frame positions (K, d) of the observations and their covariances (K, d, d) (None
    when the observations carry no covariance)."""
    model = MODELS[observations.model]
    if len(observations) == 0:
        d = model.landmark_dim(observations.dim)
        return np.zeros((0, d)), np.zeros((0, d, d))
    mean = None if pose is None else pose.mean
    positions, j_z, j_pose = model.inverse(observations.values, mean)
    if observations.covariances is None:
        return positions, None
    covariances = j_z @ observations.covariances @ np.swapaxes(j_z, 1, 2)
    if pose is not None:
        covariances = covariances + j_pose @ pose.covariance @ np.swapaxes(j_pose, 1, 2)
    return positions, covariances
