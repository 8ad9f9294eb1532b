"""PointCloud2 read from and written to CDR bytes (msg_adapters/serialized_cloud.py), checked
against rclpy's own serialization and an independent CDR writer."""
import struct

import numpy as np
from builtin_interfaces.msg import Time
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

from msg_adapters.pointcloud import POINTFIELD_DTYPES, packed_cloud, packed_points
from msg_adapters.serialized_cloud import SerializedCloud, packed_cloud_cdr
from ros_harness import cdr

ATTRIBUTES = ('header', 'height', 'width', 'is_bigendian', 'point_step', 'row_step', 'is_dense')


def assert_same_cloud(read, msg: PointCloud2) -> None:
    assert read is not None
    for name in ATTRIBUTES:
        assert getattr(read, name) == getattr(msg, name), name
    assert list(read.fields) == list(msg.fields)
    assert bytes(read.data) == bytes(msg.data)


TEXT = st.text(st.characters(blacklist_categories=('Cs',), blacklist_characters='\x00'),
               max_size=12)
FIELDS = st.lists(st.builds(PointField, name=TEXT, offset=st.integers(0, 2 ** 32 - 1),
                            datatype=st.integers(0, 255), count=st.integers(0, 2 ** 32 - 1)),
                  max_size=6)


@st.composite
def clouds(draw) -> PointCloud2:
    """Any PointCloud2 as a message (its layout need not make sense: only bytes are read)."""
    return PointCloud2(
        header=Header(stamp=Time(sec=draw(st.integers(-2 ** 31, 2 ** 31 - 1)),
                                 nanosec=draw(st.integers(0, 2 ** 32 - 1))),
                      frame_id=draw(TEXT)),
        height=draw(st.integers(0, 2 ** 32 - 1)), width=draw(st.integers(0, 2 ** 32 - 1)),
        fields=draw(FIELDS), is_bigendian=draw(st.booleans()),
        point_step=draw(st.integers(0, 2 ** 32 - 1)), row_step=draw(st.integers(0, 2 ** 32 - 1)),
        data=draw(st.binary(max_size=64)), is_dense=draw(st.booleans()))


@settings(max_examples=300, deadline=None)
@given(clouds())
def test_a_cloud_reads_from_rclpys_bytes_as_rclpy_reads_it(msg):
    raw = serialize_message(msg)
    assert_same_cloud(SerializedCloud.from_cdr(raw), msg)
    assert_same_cloud(SerializedCloud.from_cdr(raw), deserialize_message(raw, PointCloud2))


@settings(max_examples=150, deadline=None)
@given(clouds())
def test_the_independent_writer_is_rclpys_cdr_and_big_endian_reads_the_same(msg):
    little = cdr(msg, '<')
    assert deserialize_message(little, PointCloud2) == msg    # the writer checked by rclpy
    assert len(little) == len(serialize_message(msg))
    assert deserialize_message(cdr(msg, '>'), PointCloud2) == msg
    assert_same_cloud(SerializedCloud.from_cdr(cdr(msg, '>')), msg)


@settings(max_examples=100, deadline=None)
@given(st.lists(clouds(), min_size=2, max_size=5), st.lists(st.integers(0, 4), max_size=12))
def test_alternating_layouts_each_read_with_their_own_fields(messages, order):
    """The last fields block is reused only where the bytes repeat it."""
    for index in order:
        msg = messages[index % len(messages)]
        assert_same_cloud(SerializedCloud.from_cdr(serialize_message(msg)), msg)


@settings(max_examples=100, deadline=None)
@given(clouds(), st.data())
def test_cut_or_foreign_bytes_are_left_to_rclpy(msg, data):
    raw = serialize_message(msg)
    assert SerializedCloud.from_cdr(raw[:data.draw(st.integers(0, len(raw) - 1))]) is None
    foreign = data.draw(st.binary(min_size=2, max_size=2).filter(
        lambda head: head not in (b'\x00\x00', b'\x00\x01')))
    assert SerializedCloud.from_cdr(foreign + raw[2:]) is None    # e.g. XCDR2, PL_CDR


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=200))
def test_garbage_never_raises(raw):
    read = SerializedCloud.from_cdr(b'\x00\x01\x00\x00' + raw)
    assert read is None or isinstance(read.data, memoryview)


DTYPES = st.lists(st.tuples(TEXT, st.sampled_from(sorted(POINTFIELD_DTYPES))), min_size=1,
                  max_size=6, unique_by=lambda field: field[0]).map(
    lambda fields: np.dtype([(name, POINTFIELD_DTYPES[datatype].newbyteorder('<'))
                             for name, datatype in fields]))


@settings(max_examples=200, deadline=None)
@given(DTYPES, st.integers(0, 20), TEXT, st.integers(-2 ** 31, 2 ** 31 - 1), st.data())
def test_packed_bytes_are_the_message_packed_cloud_makes(dtype, count, frame_id, sec, data):
    points = np.frombuffer(data.draw(st.binary(min_size=count * dtype.itemsize,
                                               max_size=count * dtype.itemsize)), dtype)
    packed, count, packed_dtype, is_dense = packed_points(points)
    header = Header(stamp=Time(sec=sec, nanosec=7), frame_id=frame_id)
    raw = packed_cloud_cdr(packed, count, packed_dtype, header, is_dense)
    msg = packed_cloud(packed, count, packed_dtype, header, is_dense)
    assert deserialize_message(raw, PointCloud2) == msg
    assert raw == cdr(msg, '<')     # rclpy's bytes differ only in their padding
    assert_same_cloud(SerializedCloud.from_cdr(raw), msg)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.sampled_from([b'a', b'b', b'\x00', 'é'.encode()]), max_size=10).map(b''.join),
       clouds())
def test_a_string_reads_up_to_its_first_nul_as_rclpy_reads_it(content, msg):
    """A writer may leave out the final NUL or put one inside (a C++ std::string): the frame
    id is then what rclpy makes of it, up to the first NUL or all `length` bytes."""
    msg.header.frame_id = ''
    raw = serialize_message(msg)      # the empty frame id: length 1, NUL, 3 bytes padding
    raw = raw[:12] + struct.pack('<I', len(content)) + content + b'\x00' * (-len(content) % 4) \
        + raw[20:]
    expected = deserialize_message(raw, PointCloud2)
    assert expected.header.frame_id == content.split(b'\x00')[0].decode()
    assert_same_cloud(SerializedCloud.from_cdr(raw), expected)
