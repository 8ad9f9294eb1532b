"""Input messages -> core types: landmarks, observations, robot pose, joint covariance.

Field names follow DESIGN.md section 4. Content errors raise the core's InvalidInputError,
layout errors pointcloud.PointCloudFormatError; both name the field.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Optional, Sequence

import numpy as np

from data_association_ros.core import InvalidInputError, Landmarks, Observations, RobotPose
from data_association_ros.core.validation import check_covariance_matrix

from sensor_msgs.msg import PointField

from .pointcloud import PointCloudFormatError, cloud_to_array

MODEL_FIELDS = {
    'range_bearing': ('range', 'bearing'),
    'box': ('x', 'y', 'width', 'height'),
    'point_map': ('x', 'y'),
    'point_robot': ('x', 'y'),
}
"""The value fields each measurement model reads from an observation cloud, in order."""

COVARIANCE_FIELDS = {
    'range_bearing': ('var_range', None, 'var_bearing'),
    'point_map': ('cov_xx', 'cov_xy', 'cov_yy'),
    'point_robot': ('cov_xx', 'cov_xy', 'cov_yy'),
}
"""(var_0, cov_01, var_1) field names of the 2-D models; None: no such field (zero)."""


def detect_model(field_names: Sequence[str], observation_frame: str, landmark_frame: str) -> str:
    """measurement_model 'auto': range/bearing fields -> range_bearing; width/height -> box;
    x/y in the landmarks' frame -> point_map; x/y in another frame -> point_robot."""
    names = set(field_names)
    if {'range', 'bearing'} <= names:
        return 'range_bearing'
    if {'x', 'y', 'width', 'height'} <= names:
        return 'box'
    if {'x', 'y'} <= names:
        return 'point_map' if observation_frame == landmark_frame else 'point_robot'
    raise InvalidInputError(
        f'observations: cannot tell the measurement model from fields {sorted(names)} (need '
        'range+bearing, x+y+width+height or x+y)')


def _field(points: np.ndarray, name: str, what: str) -> np.ndarray:
    """The field `name` of a structured array (InvalidInputError naming it when missing)."""
    if points.dtype.names is None or name not in points.dtype.names:
        raise InvalidInputError(f'{what}: missing field {name!r} (has {points.dtype.names})')
    return points[name]


def _column(points: np.ndarray, name: str, what: str) -> np.ndarray:
    """The field `name` as float64 (a copy)."""
    return _field(points, name, what).astype(np.float64)


def _covariances_2d(points, names, fallback: np.ndarray) -> np.ndarray:
    """(n, 2, 2) from (var_0, cov_01, var_1) fields when both variances exist, else fallback."""
    n = len(points)
    available = points.dtype.names or ()
    if names[0] in available and names[2] in available:
        cov = np.zeros((n, 2, 2))
        cov[:, 0, 0] = points[names[0]]
        cov[:, 1, 1] = points[names[2]]
        if names[1] is not None and names[1] in available:
            cov[:, 0, 1] = cov[:, 1, 0] = points[names[1]]
        return cov
    return np.broadcast_to(fallback, (n,) + fallback.shape).copy()


def noise_matrix(variances: Sequence[float], dim: int) -> np.ndarray:
    """diag of `dim` variances from 1 value (repeated) or `dim` values (read-only; built once
    per flat sequence of numbers)."""
    try:
        return _noise_matrix(tuple(variances), dim)
    except TypeError:   # a scalar or nested values: not cached
        return _diagonal(variances, dim)


@lru_cache(maxsize=32)
def _noise_matrix(variances: tuple, dim: int) -> np.ndarray:
    matrix = _diagonal(variances, dim)
    matrix.flags.writeable = False
    return matrix


def _diagonal(variances, dim: int) -> np.ndarray:
    variances = np.asarray(variances, dtype=np.float64).ravel()
    if variances.size == 1:
        variances = np.repeat(variances, dim)
    if variances.size != dim:
        raise InvalidInputError(f'observation_noise: expected 1 or {dim} variances, '
                                f'got {variances.size}')
    return np.diag(variances)


def observations_from_points(points: np.ndarray, model: str,
                             observation_noise: Sequence[float]) -> Observations:
    """Observations of `model` from a structured array; missing covariance fields fall back to
    diag(`observation_noise`) (variances in the model's units, 1 or m values)."""
    columns = _float32_columns(points.dtype, model) if len(points) \
        and points.flags.c_contiguous else None
    if columns is not None:   # every field read a little-endian float32 word: one pass
        words = np.ndarray((len(points), points.dtype.itemsize // 4), np.float32, points)
        return Observations.from_float32_columns(words, columns, model,
                                                 noise_matrix(observation_noise, 2))
    names = MODEL_FIELDS[model]
    values = np.zeros((len(points), len(names)))
    if len(points):   # an empty cloud needs no fields
        for column, name in enumerate(names):
            values[:, column] = _field(points, name, 'observations')
    fallback = noise_matrix(observation_noise, len(names))
    if model in COVARIANCE_FIELDS:
        covariances = _covariances_2d(points, COVARIANCE_FIELDS[model], fallback)
    else:
        covariances = np.broadcast_to(fallback, (len(points),) + fallback.shape).copy()
    return Observations(values, covariances, model)


@lru_cache(maxsize=64)
def _float32_columns(dtype: np.dtype, model: str) -> Optional[np.ndarray]:
    """The 5 word indices Observations.from_float32_columns reads for a 2-D `model` (value 0,
    value 1, var 0, cov 01, var 1; -1: absent, the variances only when both are there) when
    the points of `dtype` are 4-byte words and those fields little-endian float32 ones at word
    boundaries; None otherwise (another layout, a missing value field: the general path)."""
    if model not in COVARIANCE_FIELDS or dtype.names is None or dtype.itemsize % 4:
        return None
    word = np.dtype('<f4')

    def index(name: Optional[str]) -> int:
        if name is None or name not in dtype.fields:
            return -1
        field_dtype, offset = dtype.fields[name][:2]
        return offset // 4 if field_dtype == word and field_dtype.isnative and not offset % 4 \
            else -2
    values = [index(name) for name in MODEL_FIELDS[model]]
    variance_0, covariance, variance_1 = map(index, COVARIANCE_FIELDS[model])
    if variance_0 == -1 or variance_1 == -1:   # diag(observation_noise) for every R
        variance_0 = covariance = variance_1 = -1
    columns = values + [variance_0, covariance, variance_1]
    if min(values) < 0 or -2 in columns:
        return None
    array = np.array(columns, dtype=np.int64)
    array.flags.writeable = False
    return array


def observations_from_cloud(msg, model: str, observation_noise: Sequence[float]) -> Observations:
    """Observations from a sensor_msgs/PointCloud2 (fields per MODEL_FIELDS)."""
    return observations_from_points(cloud_to_array(msg), model, observation_noise)


def landmarks_from_points(points: np.ndarray, default_variance: float,
                          box: bool = False) -> Landmarks:
    """Landmarks from a structured array with `id`, `x`, `y` [+ cov_xx, cov_xy, cov_yy]
    (boxes: `id`, `x`, `y`, `width`, `height`); missing covariances: default_variance * I."""
    names = MODEL_FIELDS['box'] if box else ('x', 'y')
    ids = _column(points, 'id', 'landmarks')
    means = np.column_stack([_column(points, name, 'landmarks') for name in names]) \
        if len(points) else np.zeros((0, len(names)))
    fallback = np.eye(len(names)) * default_variance
    covariances = np.broadcast_to(fallback, (len(points),) + fallback.shape).copy() if box \
        else _covariances_2d(points, COVARIANCE_FIELDS['point_map'], fallback)
    return Landmarks(ids, means, covariances)


def landmarks_from_cloud(msg, default_variance: float, box: bool = False) -> Landmarks:
    """Landmarks from a sensor_msgs/PointCloud2 (see landmarks_from_points)."""
    return landmarks_from_points(cloud_to_array(msg), default_variance, box)


def landmarks_from_pose_array(msg, default_variance: float) -> Landmarks:
    """Landmarks from a geometry_msgs/PoseArray: id = index, mean = (x, y),
    covariance = default_variance * I."""
    n = len(msg.poses)
    means = np.array([[p.position.x, p.position.y] for p in msg.poses]).reshape(n, 2)
    return Landmarks(np.arange(n), means, np.tile(np.eye(2) * default_variance, (n, 1, 1)))


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Rotation about z [rad] of a unit quaternion (ZYX Euler yaw)."""
    return float(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


POSE_COVARIANCE_INDEX = np.ix_([0, 1, 5], [0, 1, 5])
"""Rows/columns (x, y, yaw) of the 6x6 row-major pose covariance (x, y, z, roll, pitch, yaw)."""


def pose_from_odometry(msg) -> RobotPose:
    """RobotPose (x, y, yaw) and its 3x3 covariance from a nav_msgs/Odometry."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    norm = np.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)
    if not np.isfinite(norm) or norm < 1e-9:
        raise InvalidInputError(f'robot_pose.pose.orientation: not a rotation (norm {norm:g})')
    yaw = yaw_from_quaternion(q.x / norm, q.y / norm, q.z / norm, q.w / norm)
    covariance = np.asarray(msg.pose.covariance, dtype=np.float64).reshape(6, 6)
    return RobotPose([p.x, p.y, yaw], covariance[POSE_COVARIANCE_INDEX])


def state_covariance_from_cloud(msg) -> tuple[np.ndarray, np.ndarray]:
    """(landmark ids (L,), joint covariance (n, n)) from a state_covariance PointCloud2 (fields
    id, axis, row; see msg_adapters.state.STATE_COVARIANCE_FIELDS).  The matrix gets the checks
    that cost O(n^2) on arrival (finite, symmetric, non-negative diagonal); positive
    semi-definiteness is checked on the block an association uses."""
    n = msg.height * msg.width
    layout = {f.name: f for f in msg.fields}
    wanted = {'id': (PointField.INT32, 1), 'axis': (PointField.INT32, 1),
              'row': (PointField.FLOAT64, n)}
    for name, (datatype, count) in wanted.items():
        field = layout.get(name)
        if field is None or field.datatype != datatype or field.count != count:
            got = 'missing' if field is None else f'datatype {field.datatype}, count {field.count}'
            raise PointCloudFormatError(
                f'state_covariance.fields: {name!r} must be {"FLOAT64" if name == "row" else "INT32"}'
                f' with count {count} (one point per row, {n} rows), got {got}')
    if n < 3:
        raise InvalidInputError(f'state_covariance: {n} rows, expected 3 pose rows and more')
    if msg.is_bigendian:
        raise PointCloudFormatError('state_covariance: big-endian data is not supported')
    dtype = np.dtype({'names': ['id', 'axis', 'row'],
                      'formats': ['<i4', '<i4', ('<f8', (n,))],
                      'offsets': [layout['id'].offset, layout['axis'].offset,
                                  layout['row'].offset], 'itemsize': msg.point_step})
    if msg.point_step < dtype.itemsize or msg.row_step != msg.point_step * msg.width \
            or len(msg.data) != msg.row_step * msg.height:
        raise PointCloudFormatError(
            f'state_covariance: data of {len(msg.data)} bytes does not hold {n} rows of '
            f'point_step {msg.point_step}')
    points = np.frombuffer(bytes(msg.data), dtype=dtype, count=n)
    ids, axes = points['id'].astype(np.int64), points['axis'].astype(np.int64)
    if not (np.all(ids[:3] == -1) and np.array_equal(axes[:3], [0, 1, 2])):
        raise InvalidInputError('state_covariance.id: the first 3 rows must be the pose '
                                '(id -1, axis 0, 1, 2)')
    rest_ids, rest_axes = ids[3:], axes[3:]
    d = int(rest_axes.max()) + 1 if len(rest_axes) else 2
    if d < 1 or len(rest_ids) % d or not np.array_equal(
            rest_axes, np.tile(np.arange(d), len(rest_ids) // d)) or np.any(
            rest_ids.reshape(-1, d) != rest_ids.reshape(-1, d)[:, :1]):
        raise InvalidInputError('state_covariance.id, axis: landmark rows must come as '
                                '(id, 0), (id, 1), ... for each landmark')
    landmark_ids = rest_ids[::d].copy()
    matrix = check_covariance_matrix(np.array(points['row']), 'state_covariance')
    return landmark_ids, matrix
