"""A SORT-style box tracker (Bewley et al. 2016) whose association is any registered associator.

State x = [u, v, s, r, du, dv, ds] (box centre, area s = w h, aspect ratio r = w / h; constant
velocity of u, v, s), measurement z = [u, v, s, r] with SORT's noise: R = diag(1, 1, 10, 10),
P0 = 10 diag(1, 1, 1, 1, 1000, 1000, 1000), Q = diag(1, 1, 1, 1, 0.01, 0.01, 0.0001).  Each
frame: predict every track (area velocity zeroed if the area would go non-positive), associate
the detections (boxes: centre x, centre y, width, height) with the predicted boxes, update the
paired tracks, start a track per unpaired detection, report the tracks updated this frame whose
hit streak reached `min_hits` (or while the first `min_hits` frames last), delete tracks not
updated for more than `max_age` frames.  Associators that need covariances get the predicted
box covariance J H P H^T J^T (J: d(w, h)/d(s, r)) and the detection noise mapped the same way;
`noise_scale` multiplies R and Q (SORT's values are tuned for IoU, not a calibrated noise model).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..api import associate
from ..associators import REGISTRY
from ..errors import InvalidInputError
from ..types import Landmarks, Observations
from .kalman import KalmanFilter

F = np.eye(7)
F[0, 4] = F[1, 5] = F[2, 6] = 1.0
H = np.eye(4, 7)
R = np.diag([1.0, 1.0, 10.0, 10.0])
P0 = 10.0 * np.diag([1.0, 1.0, 1.0, 1.0, 1000.0, 1000.0, 1000.0])
Q = np.diag([1.0, 1.0, 1.0, 1.0, 0.01, 0.01, 0.0001])


def box_to_z(box: np.ndarray) -> np.ndarray:
    """(centre x, centre y, w, h) -> (u, v, s = w h, r = w / h)."""
    u, v, w, h = box
    return np.array([u, v, w * h, w / h])


def z_to_box(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v, s, r) -> (box (4,), Jacobian d box / d z (4, 4)); w = sqrt(s r), h = sqrt(s / r)."""
    u, v, s, r = z
    s, r = max(s, 1e-9), max(r, 1e-9)
    w, h = np.sqrt(s * r), np.sqrt(s / r)
    jacobian = np.eye(4)
    jacobian[2:, 2:] = [[0.5 * w / s, 0.5 * w / r], [0.5 * h / s, -0.5 * h / r]]
    return np.array([u, v, w, h]), jacobian


@dataclass
class Track:
    """One tracked box: stable id, its Kalman filter and SORT's counters."""

    id: int
    filter: KalmanFilter
    hits: int = 1
    hit_streak: int = 1
    age: int = 0
    time_since_update: int = 0

    def box(self) -> np.ndarray:
        """Current box (centre x, centre y, w, h)."""
        return z_to_box(self.filter.x[:4])[0]

    def box_covariance(self) -> np.ndarray:
        """Covariance of the predicted box measurement, J (H P H^T) J^T (4, 4)."""
        _, jacobian = z_to_box(self.filter.x[:4])
        return jacobian @ (H @ self.filter.p @ H.T) @ jacobian.T


@dataclass
class BoxTracker:
    """Tracks boxes frame by frame; `step` once per detection message."""

    algorithm: str = 'iou'
    min_hits: int = 3
    max_age: int = 1
    parameters: dict = field(default_factory=lambda: {'iou_threshold': 0.3})
    noise_scale: float = 1.0  # multiplies SORT's R and Q (matters to covariance gates only)
    tracks: list[Track] = field(default_factory=list)
    frame: int = 0
    _next_id: int = 1

    def __post_init__(self) -> None:
        self.configure(self.algorithm, self.min_hits, self.max_age, self.parameters)

    def configure(self, algorithm: str, min_hits: int, max_age: int,
                  parameters: Optional[dict] = None, noise_scale: Optional[float] = None) -> None:
        """Set the associator and track rules (applies from the next frame; noise_scale to new
        tracks)."""
        if noise_scale is not None:
            if not noise_scale > 0:
                raise InvalidInputError('noise_scale must be > 0')
            self.noise_scale = float(noise_scale)
        if algorithm not in REGISTRY or 'box' not in REGISTRY[algorithm].models:
            raise InvalidInputError(f'algorithm: {algorithm!r} does not associate boxes')
        if min_hits < 0 or max_age < 0:
            raise InvalidInputError('min_hits and max_age must be >= 0')
        self.algorithm, self.min_hits, self.max_age = algorithm, int(min_hits), int(max_age)
        if parameters is not None:
            self.parameters = dict(parameters)

    def step(self, boxes: np.ndarray) -> list[tuple[int, np.ndarray]]:
        """One frame of detections (K, 4) as (centre x, centre y, w, h); returns the reported
        tracks [(id, box (4,))] (see the module docstring).  Detections with a non-finite value
        or a width or height <= 0 are ignored."""
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        self.frame += 1
        for track in self.tracks:
            x = track.filter.x
            if x[6] + x[2] <= 0:
                x[6] = 0.0
            track.filter.predict()
            track.age += 1
            if track.time_since_update > 0:
                track.hit_streak = 0
            track.time_since_update += 1
        self.tracks = [t for t in self.tracks if np.all(np.isfinite(t.filter.x))]
        usable = np.flatnonzero(np.all(np.isfinite(boxes), axis=1) & (boxes[:, 2] > 0)
                                & (boxes[:, 3] > 0))
        assignment = np.full(len(boxes), -1, dtype=np.int64)
        assignment[usable] = self._associate(boxes[usable])
        by_id = {t.id: t for t in self.tracks}
        for row in usable:
            track_id = assignment[row]
            if track_id >= 0:
                track = by_id[int(track_id)]
                track.filter.update(box_to_z(boxes[row]))
                track.time_since_update = 0
                track.hits += 1
                track.hit_streak += 1
            else:
                x0 = np.zeros(7)
                x0[:4] = box_to_z(boxes[row])
                self.tracks.append(Track(self._next_id, KalmanFilter(
                    x0, P0, F, Q * self.noise_scale, H, R * self.noise_scale)))
                self._next_id += 1
        reported = [(t.id, t.box()) for t in self.tracks if t.time_since_update < 1 and (
            t.hit_streak >= self.min_hits or self.frame <= self.min_hits)]
        self.tracks = [t for t in self.tracks if t.time_since_update <= self.max_age]
        return reported

    def _associate(self, boxes: np.ndarray) -> np.ndarray:
        """Track id per detection (K,), negative where none."""
        if not len(self.tracks) or not len(boxes):
            return np.full(len(boxes), -1)
        predicted = np.array([t.box() for t in self.tracks])
        covariances = np.array([t.box_covariance() for t in self.tracks])
        noise = None
        if REGISTRY[self.algorithm].needs_covariances:
            jacobians = np.array([z_to_box(box_to_z(b))[1] for b in boxes])
            noise = jacobians @ (R * self.noise_scale) @ np.swapaxes(jacobians, 1, 2)
        landmarks = Landmarks(np.array([t.id for t in self.tracks]), predicted,
                              covariances if noise is not None else None)
        observations = Observations(boxes, noise, 'box')
        return associate(landmarks, observations, self.algorithm, **self.parameters).assignment
