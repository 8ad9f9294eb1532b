"""Estimator state -> messages: a pose as nav_msgs/Odometry, a joint covariance as
std_msgs/Float64MultiArray, a point map as PointCloud2 (the ekf_slam_node's outputs, and the bag
tools' inputs)."""
from __future__ import annotations

import array
from typing import Mapping, Optional

import numpy as np
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64MultiArray, Header, MultiArrayDimension

from .inputs import POSE_COVARIANCE_INDEX
from .pointcloud import array_to_cloud


def odometry_message(header: Header, mean: np.ndarray, covariance: np.ndarray,
                     child_frame: str = 'base_link') -> Odometry:
    """nav_msgs/Odometry with pose (x, y, yaw) and the 3x3 covariance in its 6x6 slots."""
    msg = Odometry(header=header, child_frame_id=child_frame)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(mean[0]), float(mean[1])
    msg.pose.pose.orientation.z = float(np.sin(mean[2] / 2))
    msg.pose.pose.orientation.w = float(np.cos(mean[2] / 2))
    full = np.zeros((6, 6))
    full[POSE_COVARIANCE_INDEX] = covariance
    msg.pose.covariance = full.ravel().tolist()
    return msg


def covariance_message(matrix: np.ndarray) -> Float64MultiArray:
    """A square matrix (n, n) as Float64MultiArray (row-major, layout dims rows and cols)."""
    matrix = np.ascontiguousarray(matrix, dtype=np.float64)
    size = matrix.shape[0]
    data = array.array('d')
    data.frombytes(matrix.tobytes())   # no per-element conversion for large maps
    msg = Float64MultiArray(data=data)
    msg.layout.dim = [MultiArrayDimension(label='rows', size=size, stride=size * size),
                      MultiArrayDimension(label='cols', size=size, stride=size)]
    return msg


def point_map_cloud(header: Header, ids: np.ndarray, means: np.ndarray,
                    covariances: Optional[np.ndarray],
                    extra: Optional[Mapping[str, np.ndarray]] = None):
    """PointCloud2 of point landmarks: id (INT32), x, y, [cov_xx, cov_xy, cov_yy], then the
    `extra` columns (their dtypes kept)."""
    fields = [('id', '<i4'), ('x', '<f4'), ('y', '<f4')]
    if covariances is not None:
        fields += [('cov_xx', '<f4'), ('cov_xy', '<f4'), ('cov_yy', '<f4')]
    extra = dict(extra or {})
    fields += [(name, np.asarray(values).dtype.str) for name, values in extra.items()]
    points = np.zeros(len(ids), dtype=fields)
    points['id'] = ids
    if len(ids):
        points['x'], points['y'] = means[:, 0], means[:, 1]
        if covariances is not None:
            points['cov_xx'] = covariances[:, 0, 0]
            points['cov_xy'] = covariances[:, 0, 1]
            points['cov_yy'] = covariances[:, 1, 1]
    for name, values in extra.items():
        points[name] = values
    return array_to_cloud(points, header)
