"""Hypothesis strategies for malformed and hostile input messages (issue: robustness).

PointCloud2 with arbitrary field sets, datatypes (valid and not), offsets (overlapping, past
point_step), counts, point_step, width x height (0 and large), data shorter or longer than
width * height * point_step, values with NaN, inf, huge and negative numbers, duplicate ids,
any frame id and stamps in any order; PoseArray, Odometry and state_covariance clouds likewise.
"""
from __future__ import annotations

import os

import numpy as np
from geometry_msgs.msg import Pose, PoseArray
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

from msg_adapters import array_to_cloud, state_covariance_cloud

SCALE = {'ci': 1, 'long': 20}[os.environ.get('DA_FUZZ_PROFILE', 'ci')]
"""Examples per test: the CI profile x 1, DA_FUZZ_PROFILE=long x 20 (scripts/fuzz.sh)."""
FIELD_NAMES = ('x', 'y', 'z', 'id', 'range', 'bearing', 'width', 'height', 'cov_xx', 'cov_xy',
               'cov_yy', 'var_range', 'var_bearing', 'score', 'intensity')
FRAMES = ('map', 'base_link', 'camera', '', 'never_matches')
NASTY = st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300, -1e-12, 1e12, -1e12, 1e300, -1e300,
                         float('nan'), float('inf'), float('-inf'), 3.4e38])
NUMBERS = st.one_of(st.floats(-50, 50), NASTY)


@st.composite
def headers(draw) -> Header:
    h = Header(frame_id=draw(st.sampled_from(FRAMES)))
    h.stamp.sec = draw(st.integers(0, 5))
    h.stamp.nanosec = draw(st.integers(0, 999_999_999))
    return h


@st.composite
def raw_clouds(draw) -> PointCloud2:
    """A layout anything goes: fields, datatypes 0-10, offsets, counts, sizes, data length."""
    names = draw(st.lists(st.sampled_from(FIELD_NAMES + ('x',)), max_size=8))
    fields = [PointField(name=n, offset=draw(st.integers(0, 40)),
                         datatype=draw(st.integers(0, 10)), count=draw(st.integers(0, 2)))
              for n in names]
    point_step = draw(st.integers(0, 48))
    width, height = draw(st.integers(0, 40)), draw(st.integers(0, 3))
    size = width * height * point_step
    length = draw(st.sampled_from([size, size, max(size - 1, 0), size + 3, 0]))
    data = draw(st.binary(min_size=length, max_size=length)) if length < 4000 else \
        bytes(np.random.default_rng(length).integers(0, 256, length, dtype=np.uint8))
    return PointCloud2(header=draw(headers()), height=height, width=width, fields=fields,
                       is_bigendian=draw(st.booleans()), point_step=point_step,
                       row_step=width * point_step + draw(st.sampled_from([0, 0, 1])),
                       data=data, is_dense=draw(st.booleans()))


@st.composite
def plausible_clouds(draw) -> PointCloud2:
    """A decodable layout with plausible field names and hostile values: NaN, inf, huge,
    negative and singular covariances, duplicate ids, 0 points."""
    names = sorted(set(draw(st.lists(st.sampled_from(FIELD_NAMES), min_size=1, max_size=8))))
    n = draw(st.integers(0, 25))
    dtype = [(name, '<i4' if name == 'id' else draw(st.sampled_from(['<f4', '<f8', '<i2',
                                                                       '>f8'])))
             for name in names]
    points = np.zeros(n, dtype=dtype)
    for name, kind in dtype:
        if name == 'id':
            points[name] = draw(st.lists(st.integers(-3, 5), min_size=n, max_size=n))
        elif kind == '<i2':
            points[name] = draw(st.lists(st.integers(-100, 100), min_size=n, max_size=n))
        else:
            with np.errstate(over='ignore'):  # 1e300 as float32 is inf: wanted
                points[name] = draw(st.lists(NUMBERS, min_size=n, max_size=n))
    return array_to_cloud(points.astype(points.dtype.newbyteorder('<')), draw(headers()))


@st.composite
def pose_arrays(draw) -> PoseArray:
    msg = PoseArray(header=draw(headers()))
    for _ in range(draw(st.integers(0, 6))):
        pose = Pose()
        pose.position.x, pose.position.y = draw(NUMBERS), draw(NUMBERS)
        pose.orientation.w = draw(NUMBERS)
        msg.poses.append(pose)
    return msg


@st.composite
def odometries(draw) -> Odometry:
    msg = Odometry(header=draw(headers()))
    msg.pose.pose.position.x, msg.pose.pose.position.y = draw(NUMBERS), draw(NUMBERS)
    q = msg.pose.pose.orientation
    q.x, q.y, q.z, q.w = (draw(NUMBERS) for _ in range(4))
    kind = draw(st.sampled_from(['random', 'zero', 'non_symmetric', 'negative']))
    if kind == 'random':
        cov = draw(st.lists(NUMBERS, min_size=36, max_size=36))
    else:
        m = np.eye(6) * 0.01
        if kind == 'zero':
            m[:] = 0.0
        elif kind == 'non_symmetric':
            m[0, 1] = 5.0
        else:
            m[5, 5] = -1.0
        cov = m.ravel().tolist()
    msg.pose.covariance = [float(c) for c in cov]
    return msg


@st.composite
def covariance_clouds(draw) -> PointCloud2:
    """state_covariance clouds: well-formed ones (any values, any ids) and broken layouts."""
    landmarks = draw(st.integers(0, 5))
    n = 3 + 2 * landmarks
    values = np.array(draw(st.lists(NUMBERS, min_size=n * n, max_size=n * n))).reshape(n, n)
    if draw(st.booleans()):
        with np.errstate(over='ignore', invalid='ignore'):
            values = values @ values.T     # symmetric PSD (or overflowing to inf, on purpose)
    ids = np.array(draw(st.lists(st.integers(-3, 5), min_size=landmarks, max_size=landmarks)),
                   dtype=np.int64)
    msg = state_covariance_cloud(Header(), ids, np.nan_to_num(values) if draw(st.booleans())
                                 else values)
    damage = draw(st.sampled_from(['none', 'count', 'datatype', 'data', 'width', 'axis']))
    if damage == 'count':
        msg.fields[2].count = max(0, n - 1)
    elif damage == 'datatype':
        msg.fields[0].datatype = 7
    elif damage == 'data':
        msg.data = bytes(msg.data)[:-draw(st.integers(1, 9))]
    elif damage == 'width':
        msg.width = draw(st.integers(0, n + 3))
    elif damage == 'axis':
        data = bytearray(msg.data)
        data[4] = 9
        msg.data = bytes(data)
    return msg