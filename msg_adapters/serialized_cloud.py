"""sensor_msgs/PointCloud2 straight from and to its serialized form (what DDS carries).

A subscription with `raw=True` hands the callback the message's bytes: classic CDR (OMG
DDS-XTypes 1.3, 7.4.3.5; a 4-byte encapsulation header, then each primitive aligned to its
size from the end of that header).  Reading the few header fields and pointing at the data
skips rclpy's conversion into Python message objects, and packing an answer into bytes skips
it on publishing (issue 18: together about 0.17 ms of a 1.1 ms loopback round trip, measured
with a bare echo).  Only plain CDR is read here (little- or big-endian); anything else is left
to rclpy.serialization.deserialize_message (`from_cdr` returns None).
"""
from __future__ import annotations

import struct
from functools import lru_cache
from typing import Optional

import numpy as np
from builtin_interfaces.msg import Time
from sensor_msgs.msg import PointField
from std_msgs.msg import Header

from .pointcloud import packed_layout

_BYTE_ORDERS = {b'\x00\x00': '>', b'\x00\x01': '<'}
"""Encapsulation identifier -> struct byte order: CDR_BE, CDR_LE."""
CDR_LE_HEADER = b'\x00\x01\x00\x00'
"""Encapsulation header of what this module writes: CDR_LE, options 0 (as rclpy writes)."""
_PAYLOAD = 4
"""Offset of the payload, from which CDR aligns (a multiple of 4, so 4-alignment is kept)."""


def _aligned4(offset: int) -> int:
    return (offset + 3) & ~3


class SerializedCloud:
    """A PointCloud2 read from its CDR bytes: the message's attributes (header and fields as
    rclpy message objects, `data` a read-only memoryview into the bytes), for code that reads a
    PointCloud2.  Build it with `from_cdr`."""

    __slots__ = ('header', 'height', 'width', 'fields', 'is_bigendian', 'point_step',
                 'row_step', 'data', 'is_dense')

    _last_fields: tuple[bytes, tuple[PointField, ...]] = (b'', ())
    """The serialized fields block last read and its PointFields: a sensor sends one layout,
    and a CDR block that repeats byte for byte reads the same (it delimits itself)."""

    @classmethod
    def from_cdr(cls, raw: bytes) -> Optional['SerializedCloud']:
        """The cloud in `raw` (serialized sensor_msgs/PointCloud2), or None when `raw` is not
        plain CDR or does not hold a whole cloud (deserialize_message then decides)."""
        raw = raw if isinstance(raw, bytes) else bytes(raw)
        order = _BYTE_ORDERS.get(raw[:2])
        if order is None:
            return None
        try:
            return cls._read(raw, order)
        except (struct.error, IndexError, UnicodeDecodeError, ValueError):
            return None

    @classmethod
    def _read(cls, raw: bytes, order: str) -> 'SerializedCloud':
        cloud = cls.__new__(cls)
        sec, nanosec, length = struct.unpack_from(order + 'iII', raw, _PAYLOAD)
        at = _PAYLOAD + 12
        frame_id = _string(raw, at, length)
        at = _aligned4(at + length)
        cloud.header = Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id)
        cloud.height, cloud.width = struct.unpack_from(order + 'II', raw, at)
        at += 8
        block, fields = cls._last_fields
        if not (block and raw.startswith(block, at)) or order != '<':
            end, fields = _read_fields(raw, at, order)
            if order == '<':
                cls._last_fields = (raw[at:end], fields)
            block = raw[at:end]
        cloud.fields = fields
        at += len(block)
        cloud.is_bigendian = bool(raw[at])
        cloud.point_step, cloud.row_step, size = struct.unpack_from(
            order + 'III', raw, _aligned4(at + 1))
        at = _aligned4(at + 1) + 12
        if at + size >= len(raw):
            raise ValueError('data runs past the message')
        cloud.data = memoryview(raw)[at:at + size]
        cloud.is_dense = bool(raw[at + size])
        return cloud


def _string(raw: bytes, at: int, length: int) -> str:
    """The CDR string of `length` bytes at `at`, up to its first NUL (as rclpy reads it: all
    `length` bytes when none is NUL)."""
    if at + length > len(raw):
        raise ValueError('string runs past the message')
    end = raw.find(b'\x00', at, at + length)
    return raw[at:at + length if end < 0 else end].decode()


def _read_fields(raw: bytes, at: int, order: str) -> tuple[int, tuple[PointField, ...]]:
    """(end offset, PointFields) of the fields sequence at `at`."""
    (count,) = struct.unpack_from(order + 'I', raw, at)
    if count > len(raw):
        raise ValueError('more fields than bytes')
    at += 4
    fields = []
    for _ in range(count):
        (length,) = struct.unpack_from(order + 'I', raw, at)
        name = _string(raw, at + 4, length)
        at = _aligned4(at + 4 + length)
        offset, datatype = struct.unpack_from(order + 'IB', raw, at)
        (field_count,) = struct.unpack_from(order + 'I', raw, at + 8)
        at += 12
        fields.append(PointField(name=name, offset=offset, datatype=datatype,
                                 count=field_count))
    return at, tuple(fields)


def packed_cloud_cdr(data: bytes, count: int, dtype: np.dtype, header: Optional[Header] = None,
                     is_dense: bool = True) -> bytes:
    """The CDR_LE bytes of pointcloud.packed_cloud(data, count, dtype, header, is_dense), as
    rclpy.serialization.serialize_message writes them (publishable with a PointCloud2
    publisher)."""
    header = Header() if header is None else header
    frame_id = header.frame_id.encode()
    head = struct.pack('<4siII', CDR_LE_HEADER, header.stamp.sec, header.stamp.nanosec,
                       len(frame_id) + 1) + frame_id
    point_step, fields = _fields_cdr(dtype)
    return b''.join((head, b'\x00' * (4 - (len(head) - _PAYLOAD) % 4),   # NUL and padding
                     struct.pack('<II', 1, count), fields,
                     struct.pack('<III', point_step, point_step * count, len(data)), data,
                     b'\x01' if is_dense else b'\x00'))


@lru_cache(maxsize=32)
def _fields_cdr(dtype: np.dtype) -> tuple[int, bytes]:
    """(point_step, the serialized fields sequence and is_bigendian False with its padding) of
    the packed layout of `dtype` (pointcloud.packed_layout)."""
    packed_dtype, fields, _ = packed_layout(dtype)
    parts = [struct.pack('<I', len(fields))]
    for name, offset, datatype in fields:
        encoded = name.encode() + b'\x00'
        parts += [struct.pack('<I', len(encoded)), encoded,
                  b'\x00' * (-len(encoded) % 4), struct.pack('<IB3xI', offset, datatype, 1)]
    parts.append(b'\x00\x00\x00\x00')   # is_bigendian False, padding to point_step
    return packed_dtype.itemsize, b''.join(parts)
