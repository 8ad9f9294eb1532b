"""point_robot: the landmark position in the robot frame, z = R(yaw)^T (m - t)."""
import numpy as np

from .base import MeasurementModel


def _rotation_transposed(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, s], [-s, c]])


class PointRobotModel(MeasurementModel):
    """z = R(yaw)^T (m - t) [m], with t = (x, y) and R the 2-D rotation by yaw."""

    name = 'point_robot'
    needs_pose = True

    def predict(self, means, pose):
        rt = _rotation_transposed(pose[2])
        dx, dy = means[:, 0] - pose[0], means[:, 1] - pose[1]
        # elementwise, not delta @ rt.T: a BLAS product rounds a row differently by its
        # position in the batch, and a landmark's prediction must not depend on which other
        # landmarks are predicted with it (the spatial index predicts a subset)
        h = np.stack([rt[0, 0] * dx + rt[0, 1] * dy, rt[1, 0] * dx + rt[1, 1] * dy], axis=1)
        count = means.shape[0]
        h_landmark = np.broadcast_to(rt, (count, 2, 2)).copy()
        h_pose = np.empty((count, 2, 3))
        h_pose[:, :, :2] = -rt
        # d(R^T delta)/dyaw = [[-s, c], [-c, -s]] delta = (h_y, -h_x)
        h_pose[:, 0, 2] = h[:, 1]
        h_pose[:, 1, 2] = -h[:, 0]
        return h, h_landmark, h_pose

    def inverse(self, values, pose):
        r = _rotation_transposed(pose[2]).T
        positions = values @ r.T + pose[:2]
        count = values.shape[0]
        j_values = np.broadcast_to(r, (count, 2, 2)).copy()
        j_pose = np.zeros((count, 2, 3))
        j_pose[:, 0, 0] = 1.0
        j_pose[:, 1, 1] = 1.0
        rotated = values @ r.T
        j_pose[:, 0, 2] = -rotated[:, 1]
        j_pose[:, 1, 2] = rotated[:, 0]
        return positions, j_values, j_pose
