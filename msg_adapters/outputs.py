"""Core results -> output messages: correspondences, new_landmarks, markers, diagnostics."""
from __future__ import annotations

from functools import lru_cache
from typing import Mapping, Optional, Sequence

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseWithCovarianceStamped
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from data_association_ros.core import NEW, UNASSOCIATED, Association
from data_association_ros.core.candidates import Candidate, ConfirmedLandmark

from . import packing_kernels
from .pointcloud import array_to_cloud, packed_cloud, packed_points
from .serialized_cloud import packed_cloud_cdr

CORRESPONDENCE_DTYPE = np.dtype([('observation', '<i4'), ('landmark', '<i4'), ('nis', '<f4'),
                                 ('probability', '<f4'), ('x', '<f4'), ('y', '<f4')])
"""Fields of `correspondences` (DESIGN.md 4)."""
NEW_LANDMARK_DTYPE = np.dtype([('observation', '<i4'), ('x', '<f4'), ('y', '<f4'),
                               ('cov_xx', '<f4'), ('cov_xy', '<f4'), ('cov_yy', '<f4'),
                               ('candidate', '<i4'), ('stamp_sec', '<i4'),
                               ('stamp_nanosec', '<u4')])
"""Fields of `new_landmarks` (DESIGN.md 4, plus the candidate id and the stamp of each
confirming observation)."""
CANDIDATE_DTYPE = np.dtype([('candidate', '<i4'), ('x', '<f4'), ('y', '<f4'), ('cov_xx', '<f4'),
                            ('cov_xy', '<f4'), ('cov_yy', '<f4'), ('hits', '<i4'),
                            ('misses', '<i4')])
"""Fields of `landmark_candidates` (DESIGN.md 4)."""


def correspondences_cloud(header, association: Association, map_positions: np.ndarray,
                          probabilities: Optional[np.ndarray] = None, serialized: bool = False):
    """PointCloud2, one point per observation: index, landmark id (-1 new, -2 unassociated),
    NIS (NaN when none), probability (1 unless given), map-frame x, y; serialized: its CDR
    bytes instead (serialized_cloud.packed_cloud_cdr, publishable as they are)."""
    k = len(association.assignment)
    if k and packing_kernels.available():
        data, has_nan = packing_kernels.run_correspondence_words(
            association.assignment, association.nis, probabilities, map_positions)
        is_dense = not has_nan
    else:
        points = _correspondences(k).copy()
        points['landmark'] = association.assignment
        points['nis'] = association.nis
        if probabilities is not None:
            points['probability'] = probabilities
        if k:
            points['x'] = map_positions[:, 0]
            points['y'] = map_positions[:, 1]
        data, _, _, is_dense = packed_points(points)
    return (packed_cloud_cdr if serialized else packed_cloud)(
        data, k, CORRESPONDENCE_DTYPE, header, is_dense)


@lru_cache(maxsize=16)
def _correspondences(k: int) -> np.ndarray:
    """k correspondences points with their index and probability 1, the rest 0 (read-only)."""
    points = np.zeros(k, dtype=CORRESPONDENCE_DTYPE)
    points['observation'] = np.arange(k)
    points['probability'] = 1.0
    points.flags.writeable = False
    return points


def new_landmarks_cloud(header, confirmed: Sequence[ConfirmedLandmark]):
    """PointCloud2 of the landmarks confirmed at this scan (map frame), one point per
    confirming observation: its index and stamp, the candidate id (one landmark per distinct
    candidate) and the landmark's fused x, y and covariance; None when none was confirmed.
    With confirm_hits 1 that is one point per NEW observation of this message."""
    rows = [(landmark, stamp, index) for landmark in confirmed
            for stamp, index in landmark.observations]
    if not rows:
        return None
    points = np.zeros(len(rows), dtype=NEW_LANDMARK_DTYPE)
    landmarks, stamps, indices = zip(*rows)
    points['observation'] = indices
    points['candidate'] = [landmark.candidate for landmark in landmarks]
    points['stamp_sec'], points['stamp_nanosec'] = np.divmod(np.array(stamps, dtype=np.int64),
                                                             1_000_000_000)
    means = np.array([landmark.mean[:2] for landmark in landmarks], dtype=float)
    points['x'], points['y'] = means[:, 0], means[:, 1]
    _covariance_columns(points, [landmark.covariance for landmark in landmarks])
    return array_to_cloud(points, header)


def _covariance_columns(points: np.ndarray, covariances: Sequence[Optional[np.ndarray]]) -> None:
    """cov_xx, cov_xy, cov_yy of each point from its covariance (the x, y block; NaN when
    None)."""
    blocks = np.full((len(points), 2, 2), np.nan)
    for row, covariance in enumerate(covariances):
        if covariance is not None:
            blocks[row] = covariance[:2, :2]
    points['cov_xx'], points['cov_xy'], points['cov_yy'] = \
        blocks[:, 0, 0], blocks[:, 0, 1], blocks[:, 1, 1]


def candidates_cloud(header, candidates: Sequence[Candidate], scan: int):
    """PointCloud2 of the pending candidate landmarks (map frame): id, x, y, covariance, hits
    so far, scans in a row without a hit (possibly empty, so that viewers clear)."""
    points = np.zeros(len(candidates), dtype=CANDIDATE_DTYPE)
    if len(candidates):
        points['candidate'] = [candidate.id for candidate in candidates]
        means = np.array([candidate.mean[:2] for candidate in candidates], dtype=float)
        points['x'], points['y'] = means[:, 0], means[:, 1]
        _covariance_columns(points, [candidate.covariance for candidate in candidates])
        points['hits'] = [len(candidate.hit_scans) for candidate in candidates]
        points['misses'] = [candidate.misses(scan) for candidate in candidates]
    return array_to_cloud(points, header)


def _color(r, g, b, a=1.0):
    return ColorRGBA(r=float(r), g=float(g), b=float(b), a=float(a))


PAIR_COLOR, NEW_COLOR, UNASSOCIATED_COLOR = _color(0.2, 0.6, 1.0), _color(0.1, 0.9, 0.2), \
    _color(1.0, 0.2, 0.2)


def association_markers(header, association: Association, map_positions: np.ndarray,
                        landmark_ids: np.ndarray, landmark_means: np.ndarray) -> MarkerArray:
    """MarkerArray: blue lines observation -> landmark, green spheres for NEW observations,
    red spheres for UNASSOCIATED ones (namespace per kind; DELETEALL first)."""
    clear = Marker(header=header, action=Marker.DELETEALL)
    order = np.argsort(landmark_ids)
    lines = Marker(header=header, ns='pairs', id=0, type=Marker.LINE_LIST, action=Marker.ADD,
                   color=PAIR_COLOR)
    lines.scale.x = 0.03
    lines.pose.orientation.w = 1.0
    paired = np.flatnonzero(association.assignment >= 0)
    if paired.size:
        columns = order[np.searchsorted(landmark_ids[order], association.assignment[paired])]
        ends = np.empty((2 * paired.size, 2))
        ends[0::2] = map_positions[paired, :2]
        ends[1::2] = landmark_means[columns, :2]
        lines.points = [Point(x=float(x), y=float(y)) for x, y in ends]
    markers = [clear, lines]
    for marker_id, (value, namespace, color) in enumerate(
            ((NEW, 'new', NEW_COLOR), (UNASSOCIATED, 'unassociated', UNASSOCIATED_COLOR)), 1):
        spheres = Marker(header=header, ns=namespace, id=marker_id, type=Marker.SPHERE_LIST,
                         action=Marker.ADD, color=color)
        spheres.scale.x = spheres.scale.y = spheres.scale.z = 0.2
        spheres.pose.orientation.w = 1.0
        chosen = np.flatnonzero(association.assignment == value)
        spheres.points = [Point(x=float(x), y=float(y)) for x, y in map_positions[chosen, :2]]
        markers.append(spheres)
    return MarkerArray(markers=markers)


def diagnostics_message(stamp, node_name: str, values: Mapping[str, object], warn: bool,
                        message: str) -> DiagnosticArray:
    """DiagnosticArray with one status named '<node_name>: association' (level WARN or OK)
    and the key-values."""
    status = DiagnosticStatus(level=DiagnosticStatus.WARN if warn else DiagnosticStatus.OK,
                              name=f'{node_name}: association', message=message, hardware_id=node_name,
                              values=[KeyValue(key=str(k), value=str(v)) for k, v in
                                      values.items()])
    return DiagnosticArray(header=Header(stamp=stamp), status=[status])


def transform_message(header, transform) -> PoseWithCovarianceStamped:
    """geometry_msgs/PoseWithCovarianceStamped of a rigid SE(2) transform (x, y, yaw) with its
    3x3 covariance in the (x, y, yaw) slots of the 6x6 (DESIGN.md 4: estimated_transform)."""
    msg = PoseWithCovarianceStamped(header=header)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(transform.x), float(transform.y)
    msg.pose.pose.orientation.z = float(np.sin(transform.yaw / 2))
    msg.pose.pose.orientation.w = float(np.cos(transform.yaw / 2))
    covariance = np.zeros((6, 6))
    covariance[np.ix_([0, 1, 5], [0, 1, 5])] = transform.covariance
    msg.pose.covariance = covariance.ravel().tolist()
    return msg
