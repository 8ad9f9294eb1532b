"""Observations in the map frame with their covariance, by the inverse measurement model:
x = g(z, pose),  Cov(x) = G_z R G_z^T + G_pose P_pose G_pose^T (first order)."""
from __future__ import annotations

from typing import Optional

import numpy as np

from .models import MODELS
from .types import Observations, RobotPose


def observations_in_map(observations: Observations, pose: Optional[RobotPose],
                        pose_uncertainty: bool = True
                        ) -> tuple[np.ndarray, Optional[np.ndarray]]:
    """Map-frame positions (K, d) of the observations and their covariances (K, d, d) (None
    when the observations carry no covariance); pose_uncertainty False: without the pose
    covariance's term (as for RobotPose(pose.mean))."""
    model = MODELS[observations.model]
    if len(observations) == 0:
        d = model.landmark_dim(observations.dim)
        return np.zeros((0, d)), np.zeros((0, d, d))
    return model.in_map(observations.values, observations.covariances,
                        None if pose is None else pose.mean,
                        pose.covariance if pose is not None and pose_uncertainty else None)
