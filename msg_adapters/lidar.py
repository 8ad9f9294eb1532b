"""LiDAR tracker messages <-> numpy: LaserScan / 2-D PointCloud2 -> points, tracks and their
boundaries -> PointCloud2, tracks -> MarkerArray (the only place knowing these layouts).

Frames: the tracker works in the scan's frame; every output carries the input's header.
"""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
from geometry_msgs.msg import Point
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from data_association_ros.core import InvalidInputError
from data_association_ros.core.models import wrap_angle

from .pointcloud import array_to_cloud, cloud_to_array

TRACK_DTYPE = np.dtype([
    ('id', '<i4'), ('x', '<f4'), ('y', '<f4'), ('yaw', '<f4'), ('vx', '<f4'), ('vy', '<f4'),
    ('yaw_rate', '<f4'), ('length', '<f4'), ('width', '<f4'), ('cov_xx', '<f4'),
    ('cov_xy', '<f4'), ('cov_yy', '<f4'), ('cov_yaw', '<f4'), ('cov_vxvx', '<f4'),
    ('cov_vxvy', '<f4'), ('cov_vyvy', '<f4'), ('cov_yaw_rate', '<f4'), ('hits', '<i4'),
    ('updated', 'u1')])
"""Fields of `tracks`: id, state [m, rad, m/s, rad/s], rectangle size [m], covariance terms of
x, y (xx, xy, yy), yaw, vx, vy (vxvx, vxvy, vyvy) and yaw rate, update count, 1 when updated on
this scan."""
BOUNDARY_DTYPE = np.dtype([('id', '<i4'), ('x', '<f4'), ('y', '<f4')])
"""Fields of `track_boundaries`: the track id and one boundary point."""


def points_from_scan(msg: LaserScan) -> np.ndarray:
    """(K, 2) points of the ranges at angle_min + k angle_increment; ranges that are not finite
    or outside [range_min, range_max] become NaN points (no return).  InvalidInputError when the
    angles are not finite or angle_increment is 0 with more than one range."""
    ranges = np.asarray(msg.ranges, dtype=float)
    if not (np.isfinite(msg.angle_min) and np.isfinite(msg.angle_increment)):
        raise InvalidInputError(f'scan: angle_min {msg.angle_min} / angle_increment '
                                f'{msg.angle_increment} not finite')
    if len(ranges) > 1 and msg.angle_increment == 0:
        raise InvalidInputError('scan: angle_increment is 0')
    low = msg.range_min if np.isfinite(msg.range_min) else 0.0
    high = range_max_of(msg) or np.inf
    with np.errstate(invalid='ignore'):
        valid = np.isfinite(ranges) & (ranges >= low) & (ranges <= high)
    ranges = np.where(valid, ranges, np.nan)
    angles = msg.angle_min + msg.angle_increment * np.arange(len(ranges))
    return np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])


def range_max_of(msg: LaserScan) -> Optional[float]:
    """The scan's range_max [m] when it is finite and positive (points_from_scan's upper
    limit), else None."""
    value = float(msg.range_max)
    return value if np.isfinite(value) and value > 0 else None


def full_turn_of(msg: LaserScan) -> bool:
    """Whether the scan's beams go all the way round, its last beam next to its first (a 360
    deg scan): 2 pi - |angle_increment| / 2 <= len(ranges) |angle_increment| <= 2 pi + 3/2
    |angle_increment| (the first beam may be repeated at the end; a scan going farther round
    overlaps itself and is not one)."""
    step = abs(float(msg.angle_increment))
    span = len(msg.ranges) * step
    return bool(np.isfinite(step) and step > 0 and len(msg.ranges) > 1
                and 2 * np.pi - step / 2 <= span <= 2 * np.pi + 1.5 * step)


def points_from_cloud(msg: PointCloud2) -> np.ndarray:
    """(K, 2) points from the `x`, `y` fields of a cloud in scan order (z and others ignored;
    non-finite values stay, meaning no return).  InvalidInputError without x or y; layout
    errors raise pointcloud.PointCloudFormatError."""
    array = cloud_to_array(msg)
    names = array.dtype.names or ()
    missing = [name for name in ('x', 'y') if name not in names]
    if missing:
        raise InvalidInputError(f'points: field {missing[0]!r} missing (has {names})')
    return np.column_stack([array['x'].astype(float), array['y'].astype(float)]).reshape(-1, 2)


def tracks_cloud(header, tracks: Sequence, time: float) -> PointCloud2:
    """PointCloud2 of TRACK_DTYPE, one point per track (core.lidar.ObjectTrack), possibly
    empty; `time` [s] the scan's, to tell which tracks it updated."""
    points = np.zeros(len(tracks), dtype=TRACK_DTYPE)
    if tracks:
        states = np.array([t.filter.x for t in tracks])
        p = np.array([t.filter.p for t in tracks])
        points['id'] = [t.id for t in tracks]
        for k, name in enumerate(('x', 'y', 'yaw', 'vx', 'vy', 'yaw_rate')):
            points[name] = states[:, k]
        points['yaw'] = wrap_angle(states[:, 2])   # a coasting track's is not wrapped
        points['length'] = [t.length for t in tracks]
        points['width'] = [t.width for t in tracks]
        for name, (i, j) in (('cov_xx', (0, 0)), ('cov_xy', (0, 1)), ('cov_yy', (1, 1)),
                             ('cov_yaw', (2, 2)), ('cov_vxvx', (3, 3)), ('cov_vxvy', (3, 4)),
                             ('cov_vyvy', (4, 4)), ('cov_yaw_rate', (5, 5))):
            points[name] = p[:, i, j]
        points['hits'] = [t.hits for t in tracks]
        points['updated'] = [t.updated == time for t in tracks]
    return array_to_cloud(points, header)


def boundaries_cloud(header, ids: Sequence[int], boundaries: Sequence[np.ndarray]) -> PointCloud2:
    """PointCloud2 of BOUNDARY_DTYPE: each track's boundary points (n_i, 2) with its id."""
    counts = [len(b) for b in boundaries]
    points = np.zeros(sum(counts), dtype=BOUNDARY_DTYPE)
    if points.size:
        stacked = np.vstack([np.asarray(b, float).reshape(-1, 2) for b in boundaries])
        points['id'] = np.repeat(np.asarray(ids, dtype=np.int64), counts)
        points['x'], points['y'] = stacked[:, 0], stacked[:, 1]
    return array_to_cloud(points, header)


def track_markers(header, tracks: Sequence, time: float) -> MarkerArray:
    """MarkerArray: DELETEALL, then the rectangles (LINE_LIST, ns 'boxes'; green when updated
    on this scan, grey when coasting), velocity vectors over 1 s (LINE_LIST, ns 'velocity') and
    the ids (TEXT_VIEW_FACING, ns 'ids')."""
    boxes = Marker(header=header, ns='boxes', id=0, type=Marker.LINE_LIST, action=Marker.ADD)
    velocity = Marker(header=header, ns='velocity', id=1, type=Marker.LINE_LIST,
                      action=Marker.ADD, color=ColorRGBA(r=1.0, g=0.6, b=0.1, a=1.0))
    for marker in (boxes, velocity):
        marker.scale.x = 0.05
        marker.pose.orientation.w = 1.0
    markers = [Marker(header=header, action=Marker.DELETEALL), boxes, velocity]
    fresh, stale = ColorRGBA(r=0.1, g=0.9, b=0.2, a=1.0), ColorRGBA(r=0.6, g=0.6, b=0.6, a=1.0)
    for track in tracks:
        corners = track.corners()
        color = fresh if track.updated == time else stale
        for a, b in zip(corners, np.roll(corners, -1, axis=0)):
            boxes.points += [Point(x=float(a[0]), y=float(a[1])),
                             Point(x=float(b[0]), y=float(b[1]))]
            boxes.colors += [color, color]
        x = track.filter.x
        velocity.points += [Point(x=float(x[0]), y=float(x[1])),
                            Point(x=float(x[0] + x[3]), y=float(x[1] + x[4]))]
        text = Marker(header=header, ns='ids', id=int(track.id), type=Marker.TEXT_VIEW_FACING,
                      action=Marker.ADD, text=str(track.id), color=color)
        text.pose.position.x, text.pose.position.y = float(x[0]), float(x[1])
        text.pose.position.z = 1.0
        text.pose.orientation.w = 1.0
        text.scale.z = 0.8
        markers.append(text)
    return MarkerArray(markers=markers)
