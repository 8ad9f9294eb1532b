"""Core results -> output messages: correspondences, new_landmarks, markers, diagnostics."""
from __future__ import annotations

from typing import Mapping, Optional

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseWithCovarianceStamped
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from data_association_ros.core import NEW, UNASSOCIATED, Association

from .pointcloud import array_to_cloud

CORRESPONDENCE_DTYPE = np.dtype([('observation', '<i4'), ('landmark', '<i4'), ('nis', '<f4'),
                                 ('probability', '<f4'), ('x', '<f4'), ('y', '<f4')])
"""Fields of `correspondences` (DESIGN.md 4)."""
NEW_LANDMARK_DTYPE = np.dtype([('observation', '<i4'), ('x', '<f4'), ('y', '<f4'),
                               ('cov_xx', '<f4'), ('cov_xy', '<f4'), ('cov_yy', '<f4')])
"""Fields of `new_landmarks` (DESIGN.md 4)."""


def correspondences_cloud(header, association: Association, map_positions: np.ndarray,
                          probabilities: Optional[np.ndarray] = None):
    """PointCloud2, one point per observation: index, landmark id (-1 new, -2 unassociated),
    NIS (NaN when none), probability (1 unless given), map-frame x, y."""
    k = len(association.assignment)
    points = np.zeros(k, dtype=CORRESPONDENCE_DTYPE)
    points['observation'] = np.arange(k)
    points['landmark'] = association.assignment
    points['nis'] = association.nis
    points['probability'] = 1.0 if probabilities is None else probabilities
    if k:
        points['x'] = map_positions[:, 0]
        points['y'] = map_positions[:, 1]
    return array_to_cloud(points, header)


def new_landmarks_cloud(header, association: Association, map_positions: np.ndarray,
                        map_covariances: np.ndarray):
    """PointCloud2 of the NEW observations (map frame): index, x, y and 2x2 covariance from the
    inverse measurement model; None when there is none."""
    new = np.flatnonzero(association.assignment == NEW)
    if new.size == 0:
        return None
    points = np.zeros(new.size, dtype=NEW_LANDMARK_DTYPE)
    points['observation'] = new
    points['x'] = map_positions[new, 0]
    points['y'] = map_positions[new, 1]
    points['cov_xx'] = map_covariances[new, 0, 0]
    points['cov_xy'] = map_covariances[new, 0, 1]
    points['cov_yy'] = map_covariances[new, 1, 1]
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
