"""Seed 003's LiDAR object tracker: clusters -> coarse association -> fine point matching ->
rigid transform -> fictitious measurement -> Kalman update.

Track state x = [x, y, yaw, vx, vy, yaw_rate] (constant velocity and turn rate over dt), with
boundary points kept in the object's frame, centred on their bounding box (so x, y converge to
the object's centre as more of its outline is seen).  Each scan: cluster consecutive points;
predict every track; associate cluster centroids with predicted track positions (`coarse`, a
registry associator on point_map: S = P_xy + centroid noise); for each pair, match (at most
`max_match_points` of) the cluster's points to the track's predicted boundary points (`fine`:
`jcbb_points`, or `nearest`, the seed's rejected nearest pairing with a distance cut-off),
estimate the rigid SE(2) transform T mapping the predicted boundary onto the scan (Kabsch), and
form the fictitious measurement z = [T(centre), yaw + theta_T, (T(centre) - previous centre) / dt,
(yaw + theta_T - previous yaw) / dt] with diagonal R (velocity terms larger); update; the scan
points join the boundary.  Unassociated clusters start tracks (centroid, yaw 0, velocity 0);
tracks unassociated for more than `max_age` scans are dropped.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..api import associate
from ..errors import InvalidInputError
from ..models.base import wrap_angle
from ..tracking.kalman import KalmanFilter
from ..transforms import estimate_rigid_transform
from ..types import Landmarks, Observations
from .clustering import cluster_consecutive

FINE_METHODS = ('jcbb_points', 'nearest')


def rotation(yaw: float) -> np.ndarray:
    """R(yaw) (2, 2)."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])


def transition(dt: float) -> np.ndarray:
    """F of the constant-velocity, constant-turn-rate state (6, 6)."""
    f = np.eye(6)
    f[0, 3] = f[1, 4] = f[2, 5] = dt
    return f


def fictitious_measurement(centre: np.ndarray, yaw: float, previous_centre: np.ndarray,
                           previous_yaw: float, transform, dt: float) -> np.ndarray:
    """[x, y, yaw, vx, vy, yaw_rate] from the transform T that moved the predicted boundary
    (around `centre`, `yaw`) onto the scan, over the step from the previous posterior pose."""
    moved = transform.apply(np.asarray(centre, dtype=float)[None])[0]
    new_yaw = wrap_angle(yaw + transform.yaw)
    velocity = (moved - previous_centre) / dt
    return np.array([moved[0], moved[1], new_yaw, velocity[0], velocity[1],
                     wrap_angle(new_yaw - previous_yaw) / dt])


def evenly(points: np.ndarray, most: int) -> np.ndarray:
    """At most `most` of the points, evenly spaced in their order."""
    if len(points) <= most:
        return np.arange(len(points))
    return np.unique(np.linspace(0, len(points) - 1, most).round().astype(int))


@dataclass
class ObjectTrack:
    """A tracked rigid object: id, filter, boundary points in its own frame, misses."""

    id: int
    filter: KalmanFilter
    boundary: np.ndarray
    misses: int = 0
    hits: int = 1

    def boundary_in_world(self, state: Optional[np.ndarray] = None) -> np.ndarray:
        """The boundary points at the track's (or the given) pose (n, 2)."""
        x = self.filter.x if state is None else state
        return self.boundary @ rotation(x[2]).T + x[:2]


@dataclass
class LidarObjectTracker:
    """See the module docstring.  `step(points, dt)` once per scan (points (K, 2), scan order)."""

    gap: float = 0.3
    min_points: int = 3
    coarse: str = 'gnn'
    fine: str = 'jcbb_points'
    nearest_cutoff: float = 0.3
    max_age: int = 2
    boundary_sigma: float = 0.05
    centroid_sigma: float = 1.0
    max_boundary_points: int = 100
    max_match_points: int = 30
    measurement_sigmas: tuple = (0.1, 0.1, 0.05, 1.0, 1.0, 0.5)
    process_sigmas: tuple = (0.05, 0.05, 0.01, 2.0, 2.0, 1.0)
    tracks: list[ObjectTrack] = field(default_factory=list)
    _next_id: int = 1

    def __post_init__(self) -> None:
        if self.fine not in FINE_METHODS:
            raise InvalidInputError(f'fine: {self.fine!r} is not one of {FINE_METHODS}')

    def step(self, points: np.ndarray, dt: float) -> list[ObjectTrack]:
        """One scan; returns the tracks."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        labels = cluster_consecutive(points, self.gap, self.min_points)
        clusters = [points[labels == c] for c in range(labels.max() + 1)] if labels.size else []
        f = transition(dt)
        q = np.diag(np.square(self.process_sigmas)) * dt
        previous = {}
        for track in self.tracks:
            previous[track.id] = track.filter.x.copy()
            track.filter.f, track.filter.q = f, q
            track.filter.predict()
        updated_clusters, updated_tracks = set(), set()
        for track_index, cluster_index in self._coarse(clusters):
            track = self.tracks[track_index]
            if self._fine_update(track, clusters[cluster_index], previous[track.id], dt):
                updated_clusters.add(cluster_index)
                updated_tracks.add(track.id)
        for track in self.tracks:
            track.misses = 0 if track.id in updated_tracks else track.misses + 1
            track.hits += int(track.id in updated_tracks)
        self.tracks = [t for t in self.tracks if t.misses <= self.max_age]
        for index, cluster in enumerate(clusters):
            if index not in updated_clusters:
                self._start(cluster)
        return self.tracks

    def _coarse(self, clusters: list[np.ndarray]) -> list[tuple[int, int]]:
        if not self.tracks or not clusters:
            return []
        centroids = np.array([c.mean(axis=0) for c in clusters])
        landmarks = Landmarks(np.arange(len(self.tracks)),
                              np.array([t.filter.x[:2] for t in self.tracks]),
                              np.array([t.filter.p[:2, :2] for t in self.tracks]))
        observations = Observations(centroids, np.tile(np.eye(2) * self.centroid_sigma ** 2,
                                                       (len(clusters), 1, 1)), 'point_map')
        assignment = associate(landmarks, observations, self.coarse).assignment
        return [(int(t), c) for c, t in enumerate(assignment) if t >= 0]

    def _fine_update(self, track: ObjectTrack, cluster: np.ndarray, previous: np.ndarray,
                     dt: float) -> bool:
        predicted = track.boundary_in_world()
        sample = cluster[evenly(cluster, self.max_match_points)]
        pairs = self._match(sample, predicted)
        if len(pairs) < 2:
            return False
        try:
            transform = estimate_rigid_transform(predicted[pairs[:, 1]], sample[pairs[:, 0]])
        except InvalidInputError:
            return False
        x = track.filter.x
        z = fictitious_measurement(x[:2], x[2], previous[:2], previous[2], transform, dt)
        z[2] = x[2] + wrap_angle(z[2] - x[2])
        track.filter.r = np.diag(np.square(self.measurement_sigmas))
        track.filter.update(z)
        track.filter.x[2] = wrap_angle(track.filter.x[2])
        self._grow_boundary(track, cluster)
        return True

    def _grow_boundary(self, track: ObjectTrack, cluster: np.ndarray) -> None:
        """Add the scan points (object frame), thin to 5 cm cells, re-centre on the bounding
        box (moving x, y by the same offset)."""
        x = track.filter.x
        body = (cluster - x[:2]) @ rotation(x[2])
        boundary = np.vstack([track.boundary, body])
        _, unique = np.unique(np.round(boundary / 0.05), axis=0, return_index=True)
        boundary = boundary[np.sort(unique)]
        boundary = boundary[evenly(boundary, self.max_boundary_points)]
        offset = (boundary.min(axis=0) + boundary.max(axis=0)) / 2
        track.boundary = boundary - offset
        x[:2] = x[:2] + rotation(x[2]) @ offset

    def _match(self, scan: np.ndarray, boundary: np.ndarray) -> np.ndarray:
        """(pairs (n, 2): scan index, boundary index)."""
        if self.fine == 'nearest':
            distance = np.hypot(*(scan[:, None, :] - boundary[None, :, :]).transpose(2, 0, 1))
            nearest = distance.argmin(axis=1)
            keep = distance[np.arange(len(scan)), nearest] <= self.nearest_cutoff
            return np.column_stack([np.flatnonzero(keep), nearest[keep]])
        landmarks = Landmarks(np.arange(len(boundary)), boundary,
                              np.tile(np.eye(2) * self.boundary_sigma ** 2, (len(boundary), 1, 1)))
        observations = Observations(scan, np.tile(np.eye(2) * self.boundary_sigma ** 2,
                                                  (len(scan), 1, 1)), 'point_map')
        result = associate(landmarks, observations, 'jcbb_points', time_budget_ms=10.0)
        paired = np.flatnonzero(result.assignment >= 0)
        return np.column_stack([paired, result.assignment[paired]]).astype(int)

    def _start(self, cluster: np.ndarray) -> None:
        offset = (cluster.min(axis=0) + cluster.max(axis=0)) / 2
        x0 = np.array([offset[0], offset[1], 0.0, 0.0, 0.0, 0.0])
        p0 = np.diag([0.5, 0.5, 0.3, 25.0, 25.0, 1.0])
        self.tracks.append(ObjectTrack(self._next_id, KalmanFilter(
            x0, p0, np.eye(6), np.eye(6), np.eye(6), np.diag(np.square(self.measurement_sigmas))),
            cluster - offset))
        self._next_id += 1
