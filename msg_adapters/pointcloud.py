"""sensor_msgs/PointCloud2 <-> numpy structured arrays, for any field layout (numpy only).

Handles every PointField datatype, padding between fields, point_step larger than the fields,
row_step padding, height > 1 and big-endian data; rejects count != 1.  No per-point loops.
"""
from __future__ import annotations

from functools import lru_cache
from operator import attrgetter
from typing import Mapping, Sequence, Union

import numpy as np
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header


class PointCloudFormatError(ValueError):
    """A PointCloud2 whose layout cannot be decoded; the message names the problem."""


POINTFIELD_DTYPES = {
    PointField.INT8: np.dtype('i1'), PointField.UINT8: np.dtype('u1'),
    PointField.INT16: np.dtype('i2'), PointField.UINT16: np.dtype('u2'),
    PointField.INT32: np.dtype('i4'), PointField.UINT32: np.dtype('u4'),
    PointField.FLOAT32: np.dtype('f4'), PointField.FLOAT64: np.dtype('f8'),
}
"""PointField datatype constant -> numpy dtype (native byte order)."""
_DATATYPE_OF = {(dtype.kind, dtype.itemsize): datatype
                for datatype, dtype in POINTFIELD_DTYPES.items()}
_FIELD_LAYOUT = attrgetter('name', 'offset', 'datatype', 'count')
"""(name, offset, datatype, count) of a PointField."""


def cloud_dtype(fields: Sequence[PointField], point_step: int, is_bigendian: bool) -> np.dtype:
    """Structured dtype of one point: the fields at their offsets, itemsize point_step (cached
    by layout: a sensor sends the same one every message)."""
    return _cloud_dtype(tuple(map(_FIELD_LAYOUT, fields)), point_step, bool(is_bigendian))


@lru_cache(maxsize=256)
def _cloud_dtype(fields: tuple[tuple[str, int, int, int], ...], point_step: int,
                 is_bigendian: bool) -> np.dtype:
    names, formats, offsets = [], [], []
    order = '>' if is_bigendian else '<'
    for name, offset, datatype, count in fields:
        if datatype not in POINTFIELD_DTYPES:
            raise PointCloudFormatError(
                f'field {name!r} has unknown datatype {datatype}')
        if count != 1:
            raise PointCloudFormatError(
                f'field {name!r} has count {count}; only count 1 is supported')
        if name in names:
            raise PointCloudFormatError(f'field {name!r} appears twice')
        dtype = POINTFIELD_DTYPES[datatype].newbyteorder(order)
        if offset + dtype.itemsize > point_step:
            raise PointCloudFormatError(
                f'field {name!r} (offset {offset}, {dtype.itemsize} bytes) overruns '
                f'point_step {point_step}')
        names.append(name)
        formats.append(dtype)
        offsets.append(offset)
    spans = sorted((offset, offset + dtype.itemsize, name)
                   for offset, dtype, name in zip(offsets, formats, names))
    for (_, end, first), (start, _, second) in zip(spans, spans[1:]):
        if start < end:
            raise PointCloudFormatError(f'fields {first!r} and {second!r} overlap')
    return np.dtype({'names': names, 'formats': formats, 'offsets': offsets,
                     'itemsize': max(point_step, 1)})


def cloud_to_array(msg: PointCloud2) -> np.ndarray:
    """1-D structured array of the height*width points (row-major), native byte order."""
    points = cloud_points(msg)
    return points.astype(_native(points.dtype))


def cloud_points(msg: PointCloud2) -> np.ndarray:
    """The height*width points (row-major) as a read-only structured array over the message's
    data: the fields at their offsets in their byte order (copied only to drop row padding)."""
    count = msg.height * msg.width
    point_step, row_step = msg.point_step, msg.row_step
    if count and point_step <= 0:
        raise PointCloudFormatError(f'point_step is {point_step} for {count} points')
    dtype = cloud_dtype(msg.fields, point_step, msg.is_bigendian) if count else cloud_dtype(
        msg.fields, max(point_step, max((f.offset + POINTFIELD_DTYPES.get(
            f.datatype, np.dtype('u1')).itemsize for f in msg.fields), default=1)),
        msg.is_bigendian)
    data = memoryview(msg.data).cast('B') if not isinstance(msg.data, bytes) else msg.data
    if count == 0:
        if len(data):
            raise PointCloudFormatError(f'data has {len(data)} bytes, expected 0 for 0 points')
        return np.frombuffer(b'', dtype=dtype, count=0)
    if row_step < msg.width * point_step:
        raise PointCloudFormatError(
            f'row_step {row_step} is smaller than width * point_step = {msg.width * point_step}')
    expected = msg.height * row_step
    if len(data) != expected:
        raise PointCloudFormatError(f'data has {len(data)} bytes, expected {expected} '
                                    f'(height {msg.height} * row_step {row_step})')
    if row_step != msg.width * point_step:   # drop each row's padding
        data = np.frombuffer(data, dtype=np.uint8).reshape(
            msg.height, row_step)[:, :msg.width * point_step].copy()
    points = np.frombuffer(data, dtype=dtype, count=count)
    points.flags.writeable = False
    return points


@lru_cache(maxsize=256)
def _native(dtype: np.dtype) -> np.dtype:
    """Packed native-order copy of a structured dtype (fields kept, padding dropped)."""
    return np.dtype([(name, dtype.fields[name][0].newbyteorder('=')) for name in dtype.names])


def array_to_cloud(array: Union[np.ndarray, Mapping[str, np.ndarray]],
                   header=None) -> PointCloud2:
    """PointCloud2 (height 1, packed little-endian fields) from a 1-D structured array or a
    mapping name -> 1-D array; int64 values must fit INT32, bool becomes UINT8."""
    data, count, dtype, is_dense = packed_points(array)
    return packed_cloud(data, count, dtype, header, is_dense)


def packed_points(array: Union[np.ndarray, Mapping[str, np.ndarray]]
                  ) -> tuple[bytes, int, np.dtype, bool]:
    """(data, number of points, dtype, is_dense) of the cloud array_to_cloud makes of `array`:
    the points packed as packed_cloud reads them; is_dense False when a float is NaN."""
    if not isinstance(array, np.ndarray):
        columns = {name: np.asarray(values) for name, values in array.items()}
        lengths = {len(v) for v in columns.values()}
        if len(lengths) > 1:
            raise PointCloudFormatError(f'columns have different lengths {sorted(lengths)}')
        structured = np.zeros(lengths.pop() if lengths else 0,
                              dtype=[(n, _field_dtype(n, v)) for n, v in columns.items()])
        for name, values in columns.items():
            structured[name] = values
        array = structured
    packed_dtype, _, float_runs = packed_layout(array.dtype)
    if array.dtype == packed_dtype:
        packed = array
    else:
        for name in array.dtype.names:
            _field_dtype(name, array[name])    # int64 values must fit INT32
        packed = np.empty(len(array), dtype=packed_dtype)
        for name in array.dtype.names:
            packed[name] = array[name]
    data = packed.tobytes()
    return data, len(array), packed_dtype, \
        not _has_nan(data, len(array), packed_dtype.itemsize, float_runs)


def packed_cloud(data: bytes, count: int, dtype: np.dtype, header=None,
                 is_dense: bool = True) -> PointCloud2:
    """PointCloud2 (height 1) of `count` points already packed in `data` as array_to_cloud
    packs a structured array of `dtype` (fields in order, little-endian, no padding)."""
    packed_dtype, fields, _ = packed_layout(dtype)
    return PointCloud2(
        header=Header() if header is None else header, height=1, width=count,
        is_bigendian=False, point_step=packed_dtype.itemsize,
        row_step=packed_dtype.itemsize * count, data=data, is_dense=is_dense,
        fields=[PointField(name=name, offset=offset, count=1, datatype=datatype)
                for name, offset, datatype in fields])


def _has_nan(data: bytes, count: int, point_step: int,
             float_runs: tuple[tuple[int, np.dtype, int], ...]) -> bool:
    """True when a float field of the `count` packed points in `data` holds NaN; float_runs:
    (offset, dtype, number of fields) of each run of adjacent float fields of one dtype."""
    return count > 0 and any(np.isnan(np.ndarray((count, width), dtype, data, offset,
                                                 (point_step, dtype.itemsize))).any()
                             for offset, dtype, width in float_runs)


@lru_cache(maxsize=128)
def packed_layout(dtype: np.dtype) -> tuple[np.dtype, tuple[tuple[str, int, int], ...],
                                             tuple[tuple[int, np.dtype, int], ...]]:
    """(packed little-endian dtype, its fields as (name, offset, PointField datatype), its
    runs of adjacent float fields of one dtype as (offset, dtype, number of fields)) of a
    structured dtype."""
    formats, fields, runs, offset = [], [], [], 0
    for name in dtype.names:
        field = np.dtype(dtype.fields[name][0])
        packed = _field_dtype(name, np.zeros(0, dtype=field))
        formats.append((name, packed))
        fields.append((name, offset, _DATATYPE_OF[(packed.kind, packed.itemsize)]))
        if packed.kind == 'f':
            if runs and runs[-1][1] == packed and \
                    runs[-1][0] + runs[-1][2] * packed.itemsize == offset:
                runs[-1] = (runs[-1][0], packed, runs[-1][2] + 1)
            else:
                runs.append((offset, packed, 1))
        offset += packed.itemsize
    return np.dtype(formats), tuple(fields), tuple(runs)


def _field_dtype(name: str, values: np.ndarray) -> np.dtype:
    dtype = np.asarray(values).dtype
    if dtype.kind == 'b':
        return np.dtype('<u1')
    if dtype.kind in 'iu' and dtype.itemsize == 8:
        values = np.asarray(values)
        info = np.iinfo(np.int32)
        if values.size and (values.min() < info.min or values.max() > info.max):
            raise PointCloudFormatError(f'field {name!r}: int64 values do not fit INT32')
        return np.dtype('<i4')
    if dtype.kind == 'f' and dtype.itemsize not in (4, 8):
        return np.dtype('<f8')
    if (dtype.kind, dtype.itemsize) not in _DATATYPE_OF:
        raise PointCloudFormatError(f'field {name!r}: dtype {dtype} has no PointField datatype')
    return dtype.newbyteorder('<')


def fields_of(msg: PointCloud2) -> tuple[str, ...]:
    """The field names of a cloud."""
    return tuple(field.name for field in msg.fields)
