"""Estimator state -> messages: a pose as nav_msgs/Odometry, a joint covariance as a stamped
PointCloud2 of its rows, a point map as PointCloud2 (the ekf_slam_node's outputs, and the bag
tools' inputs)."""
from __future__ import annotations

from typing import Mapping, Optional

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

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


STATE_COVARIANCE_FIELDS = ('id', 'axis', 'row')
"""The fields of a state_covariance cloud: one point per row of the joint covariance of
[x, y, yaw, landmark 0 (d rows), ...]: `id` (INT32: -1 for the pose rows, else the landmark's
id), `axis` (INT32: 0, 1, 2 = x, y, yaw; 0 .. d-1 for a landmark), `row` (FLOAT64, count n =
3 + L d: that row)."""
POSE_ROW_ID = -1


def state_covariance_cloud(header: Header, landmark_ids: np.ndarray, matrix: np.ndarray
                           ) -> PointCloud2:
    """The joint covariance (n, n) of [pose, landmarks `landmark_ids` (L,)] as a PointCloud2
    with the landmarks message's header (see STATE_COVARIANCE_FIELDS)."""
    matrix = np.ascontiguousarray(matrix, dtype=np.float64)
    n = matrix.shape[0]
    count = len(landmark_ids)
    d = (n - 3) // count if count else 2
    points = np.zeros(n, dtype=[('id', '<i4'), ('axis', '<i4'), ('row', '<f8', (n,))])
    points['id'][:3] = POSE_ROW_ID
    points['axis'][:3] = np.arange(3)
    points['id'][3:] = np.repeat(np.asarray(landmark_ids, dtype=np.int64), d)
    points['axis'][3:] = np.tile(np.arange(d), count)
    points['row'] = matrix
    fields = [PointField(name='id', offset=0, datatype=PointField.INT32, count=1),
              PointField(name='axis', offset=4, datatype=PointField.INT32, count=1),
              PointField(name='row', offset=8, datatype=PointField.FLOAT64, count=n)]
    step = points.dtype.itemsize
    return PointCloud2(header=header, height=1, width=n, fields=fields, is_bigendian=False,
                       point_step=step, row_step=step * n, is_dense=True, data=points.tobytes())


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
