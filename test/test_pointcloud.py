"""PointCloud2 codec: every datatype, padding, row_step, height > 1, big-endian, bad layouts."""
import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from msg_adapters import PointCloudFormatError, array_to_cloud, cloud_to_array
from msg_adapters.pointcloud import POINTFIELD_DTYPES

STRUCT = {PointField.INT8: 'b', PointField.UINT8: 'B', PointField.INT16: 'h',
          PointField.UINT16: 'H', PointField.INT32: 'i', PointField.UINT32: 'I',
          PointField.FLOAT32: 'f', PointField.FLOAT64: 'd'}


def hand_built(fields, rows, point_step, big_endian=False, height=1, row_padding=0):
    """A cloud whose bytes are written by struct, independently of the codec.
    fields: [(name, datatype, offset)]; rows: list of per-point value tuples."""
    order = '>' if big_endian else '<'
    width = len(rows) // height
    row_step = width * point_step + row_padding
    data = bytearray(b'\xee' * (row_step * height))
    for index, values in enumerate(rows):
        row, column = divmod(index, width)
        base = row * row_step + column * point_step
        for (name, datatype, offset), value in zip(fields, values):
            struct.pack_into(order + STRUCT[datatype], data, base + offset, value)
    msg = PointCloud2(height=height, width=width, point_step=point_step, row_step=row_step,
                      is_bigendian=big_endian)
    msg.fields = [PointField(name=n, datatype=d, offset=o, count=1) for n, d, o in fields]
    msg.data = bytes(data)
    return msg


def test_big_endian_with_padding_and_large_point_step():
    fields = [('id', PointField.INT32, 0), ('x', PointField.FLOAT64, 8),
              ('flag', PointField.UINT8, 20)]
    msg = hand_built(fields, [(7, 1.5, 3), (-2, -0.25, 255)], point_step=32, big_endian=True)
    points = cloud_to_array(msg)
    np.testing.assert_array_equal(points['id'], [7, -2])
    np.testing.assert_array_equal(points['x'], [1.5, -0.25])
    np.testing.assert_array_equal(points['flag'], [3, 255])
    assert points.dtype['x'].isnative


def test_height_greater_than_one_with_row_padding():
    fields = [('x', PointField.FLOAT32, 0), ('y', PointField.FLOAT32, 4)]
    rows = [(float(i), float(-i)) for i in range(6)]
    points = cloud_to_array(hand_built(fields, rows, point_step=8, height=2, row_padding=5))
    np.testing.assert_array_equal(points['x'], np.arange(6))
    np.testing.assert_array_equal(points['y'], -np.arange(6))


@pytest.mark.parametrize('datatype', sorted(POINTFIELD_DTYPES))
def test_every_datatype_round_trips(datatype):
    dtype = POINTFIELD_DTYPES[datatype]
    info = np.finfo(dtype) if dtype.kind == 'f' else np.iinfo(dtype)
    values = np.array([info.min, 0, 1, info.max], dtype=dtype)
    array = np.zeros(4, dtype=[('v', dtype), ('w', '<f8')])
    array['v'] = values
    msg = array_to_cloud(array)
    assert msg.fields[0].datatype == datatype
    back = cloud_to_array(deserialize_message(serialize_message(msg), PointCloud2))
    np.testing.assert_array_equal(back['v'], values)


def test_count_greater_than_one_is_rejected():
    msg = hand_built([('x', PointField.FLOAT32, 0)], [(1.0,)], point_step=12)
    msg.fields[0].count = 3
    with pytest.raises(PointCloudFormatError, match="field 'x' has count 3"):
        cloud_to_array(msg)


@pytest.mark.parametrize('change,message', [
    (lambda m: setattr(m, 'data', bytes(m.data)[:-1]), 'data has 15 bytes, expected 16'),
    (lambda m: setattr(m, 'data', bytes(m.data) + b'\x00'), 'data has 17 bytes, expected 16'),
    (lambda m: setattr(m.fields[0], 'datatype', 42), 'unknown datatype 42'),
    (lambda m: setattr(m.fields[1], 'offset', 6), 'overruns point_step'),
    (lambda m: setattr(m.fields[1], 'offset', 2), 'overlap'),
    (lambda m: setattr(m.fields[1], 'name', 'x'), 'appears twice'),
    (lambda m: setattr(m, 'row_step', 4), 'row_step 4 is smaller'),
    (lambda m: setattr(m, 'point_step', 0), 'point_step'),
])
def test_bad_layouts_are_rejected_with_a_reason(change, message):
    msg = hand_built([('x', PointField.FLOAT32, 0), ('y', PointField.FLOAT32, 4)],
                     [(1.0, 2.0), (3.0, 4.0)], point_step=8)
    change(msg)
    with pytest.raises(PointCloudFormatError, match=message):
        cloud_to_array(msg)


def test_empty_cloud_keeps_its_fields():
    msg = array_to_cloud(np.zeros(0, dtype=[('x', '<f4'), ('id', '<i4')]))
    points = cloud_to_array(msg)
    assert points.shape == (0,) and points.dtype.names == ('x', 'id')


def test_array_to_cloud_from_mapping_and_int64_range():
    msg = array_to_cloud({'id': np.array([1, 2], dtype=np.int64), 'ok': np.array([True, False])})
    assert [f.datatype for f in msg.fields] == [PointField.INT32, PointField.UINT8]
    with pytest.raises(PointCloudFormatError, match='do not fit INT32'):
        array_to_cloud({'id': np.array([2 ** 40])})
    nan_cloud = array_to_cloud({'x': np.array([np.nan, 1.0])})
    assert not nan_cloud.is_dense


LAYOUT = st.lists(st.tuples(st.sampled_from(sorted(STRUCT)), st.integers(0, 3)), min_size=1,
                  max_size=6)


@settings(max_examples=150, deadline=None)
@given(layout=LAYOUT, big_endian=st.booleans(), count=st.integers(0, 20),
       tail=st.integers(0, 9), height=st.sampled_from([1, 2]), seed=st.integers(0, 2 ** 31))
def test_any_hand_built_layout_decodes_exactly(layout, big_endian, count, tail, height, seed):
    rng = np.random.default_rng(seed)
    fields, offset = [], 0
    for k, (datatype, gap) in enumerate(layout):
        offset += gap
        fields.append((f'f{k}', datatype, offset))
        offset += POINTFIELD_DTYPES[datatype].itemsize
    point_step = offset + tail
    rows = []
    for _ in range(count * height):
        row = []
        for _, datatype, _ in fields:
            dtype = POINTFIELD_DTYPES[datatype]
            if dtype.kind == 'f':
                row.append(float(np.float32(rng.normal() * 100)))
            else:
                info = np.iinfo(dtype)
                row.append(int(rng.integers(info.min, info.max, endpoint=True)))
        rows.append(tuple(row))
    msg = hand_built(fields, rows, point_step, big_endian, height=height if count else 1)
    points = cloud_to_array(deserialize_message(serialize_message(msg), PointCloud2))
    assert len(points) == len(rows)
    for k, (name, _, _) in enumerate(fields):
        np.testing.assert_array_equal(points[name], [row[k] for row in rows])
    again = cloud_to_array(array_to_cloud(points))  # and back through the packed writer
    assert again.tobytes() == points.tobytes()
