"""range_bearing: z = (range [m], bearing [rad] in the robot frame, wrapped to (-pi, pi])."""
import numpy as np

from .. import jit
from .base import MeasurementModel, wrap_angle


class RangeBearingModel(MeasurementModel):
    """r = |m - t|, b = wrap(atan2(m_y - y, m_x - x) - yaw)."""

    name = 'range_bearing'
    needs_pose = True
    angular = (1,)

    def landmark_dim(self, measurement_dim: int) -> int:
        return 2

    def predict(self, means, pose):
        kernels = jit.problem_kernels()
        if kernels is not None:
            return kernels.run_range_bearing_predict(means, pose)
        dx = means[:, 0] - pose[0]
        dy = means[:, 1] - pose[1]
        q = np.maximum(dx * dx + dy * dy, 1e-18)
        r = np.sqrt(q)
        h = np.stack([r, wrap_angle(np.arctan2(dy, dx) - pose[2])], axis=1)
        h_landmark = np.empty((means.shape[0], 2, 2))
        h_landmark[:, 0, 0] = dx / r
        h_landmark[:, 0, 1] = dy / r
        h_landmark[:, 1, 0] = -dy / q
        h_landmark[:, 1, 1] = dx / q
        h_pose = np.zeros((means.shape[0], 2, 3))
        h_pose[:, :, :2] = -h_landmark
        h_pose[:, 1, 2] = -1.0
        return h, h_landmark, h_pose

    def in_map(self, values, covariances, pose, pose_covariance):
        kernels = jit.problem_kernels() if covariances is not None else None
        if kernels is not None:
            return kernels.run_range_bearing_in_map(values, covariances, pose, pose_covariance)
        return super().in_map(values, covariances, pose, pose_covariance)

    def inverse(self, values, pose):
        r, b = values[:, 0], values[:, 1]
        angle = pose[2] + b
        c, s = np.cos(angle), np.sin(angle)
        positions = np.stack([pose[0] + r * c, pose[1] + r * s], axis=1)
        j_values = np.empty((values.shape[0], 2, 2))
        j_values[:, 0, 0] = c
        j_values[:, 0, 1] = -r * s
        j_values[:, 1, 0] = s
        j_values[:, 1, 1] = r * c
        j_pose = np.zeros((values.shape[0], 2, 3))
        j_pose[:, 0, 0] = 1.0
        j_pose[:, 1, 1] = 1.0
        j_pose[:, 0, 2] = -r * s
        j_pose[:, 1, 2] = r * c
        return positions, j_values, j_pose
