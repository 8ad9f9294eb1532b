"""Re-finding the map over several scans (a loop closed after a long drift).

When a SLAM filter comes back to a mapped area after a long loop, its pose can be metres and
tens of degrees off while its covariance says centimetres: every observation of the old map
falls outside its gate and is mapped again (DLR's last loop closure: 4-5 m, 10-20 deg; see
docs/slam.md).  The widened single-scan pass of pose_recovery cannot take that much without
pairing wrong landmarks; several scans together can: the map-frame positions of the
observations of the last `window_scans` scans (as the filter placed them, drift included) are
registered rigidly against the *old* landmarks near the robot (first seen at least `old_scans`
scans ago): rotation r about the robot in [-max_rotation, max_rotation] (steps of
ROTATION_STEP), translation t voted over pairs (point, landmark) in cells of `tolerance` with
|t| <= max_shift, refined as the median of the best cells' votes; the score of (r, t) is the
number of distinct old landmarks with a window point within `tolerance` after it (ties: the
smaller sum of those points' squared distances).  When the best score reaches `min_landmarks`
and GAIN times the score of the window as placed, the scan is associated again from the pose
moved by (r, t); the second answer is kept when it pairs more observations with old landmarks
than the first.

The window and the landmarks' first-seen scans are this object's state (one per association
node).  Deterministic: the same scans give the same answers.
"""
from __future__ import annotations

import dataclasses
from collections import deque
from typing import Optional

import numpy as np

from .parameters import ParameterSpec
from .types import NEW, Association, Landmarks, RobotPose

ROTATION_STEP = np.radians(1.0)
"""Step of the rotations tried [rad]."""
CELLS_PER_ROTATION = 3
"""Translation cells (the most voted) refined and scored per rotation."""
GAIN = 2
"""A registration is used only when it matches at least GAIN times the old landmarks the window
matches as the filter placed it (a scan whose pose is right but whose NEW observations are new
landmarks near old ones must not be moved onto an alias of the layout)."""

WINDOW_SCANS = ParameterSpec(
    'refind_window_scans', 0, 're-find the map over the observations of this many recent scans '
    'when a scan comes back with NEW observations near old landmarks (a long loop closed with a '
    'drifted pose); 0: off', kind=int, low=0, high=10000)
OLD_SCANS = ParameterSpec(
    'refind_old_scans', 300, 'old landmarks, the ones registered against: first seen at least '
    'this many scans ago', kind=int, low=1, high=10 ** 7)
RADIUS = ParameterSpec(
    'refind_radius', 12.0, 'old landmarks within this distance of the robot take part [m]',
    low=0.0, high=1e6, low_open=True)
TOLERANCE = ParameterSpec(
    'refind_tolerance', 0.2, 'a window observation within this distance of an old landmark '
    'after the registration matches it [m]', low=0.0, high=1e3, low_open=True)
MIN_LANDMARKS = ParameterSpec(
    'refind_min_landmarks', 8, 'a registration is used when it matches at least this many '
    'distinct old landmarks', kind=int, low=1, high=100000)
MAX_ROTATION = ParameterSpec(
    'refind_max_rotation', 0.61, 'largest heading error searched [rad]', low=0.0, high=np.pi)
MAX_SHIFT = ParameterSpec(
    'refind_max_shift', 8.0, 'largest position error searched [m]', low=0.0, high=1e6,
    low_open=True)
REFINDING_PARAMETERS = (WINDOW_SCANS, OLD_SCANS, RADIUS, TOLERANCE, MIN_LANDMARKS, MAX_ROTATION,
                        MAX_SHIFT)
"""The settings of MapRefinder as parameters (the association node declares these)."""


@dataclasses.dataclass(frozen=True)
class RefindingConfig:
    """The module doc's settings (window_scans 0: off)."""

    window_scans: int = 0
    old_scans: int = 300
    radius: float = 12.0
    tolerance: float = 0.2
    min_landmarks: int = 8
    max_rotation: float = 0.61
    max_shift: float = 8.0

    def __post_init__(self) -> None:
        for spec in REFINDING_PARAMETERS:
            spec.check(getattr(self, spec.name.removeprefix('refind_')))


@dataclasses.dataclass(frozen=True)
class Registration:
    """A rigid correction: rotation [rad] about `centre` (2,), then `shift` (2,) [m]; `matched`:
    the distinct old landmarks it matches."""

    rotation: float
    shift: np.ndarray
    centre: np.ndarray
    matched: int

    def apply(self, points: np.ndarray) -> np.ndarray:
        """The corrected points (n, 2)."""
        return (points - self.centre) @ _rotation(self.rotation).T + self.centre + self.shift

    def pose(self, pose: RobotPose) -> RobotPose:
        """The corrected pose (same covariance)."""
        mean = pose.mean.copy()
        mean[:2] = self.apply(pose.mean[None, :2])[0]
        mean[2] += self.rotation
        return RobotPose(mean, pose.covariance)


def _rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def matched_landmarks(points: np.ndarray, landmarks: np.ndarray, tolerance: float
                      ) -> tuple[int, float]:
    """(the number of distinct landmarks (m, 2) that are the nearest landmark of some point
    (n, 2) within `tolerance`, the summed squared distance of those points to them [m^2])."""
    if not len(points) or not len(landmarks):
        return 0, 0.0
    distance = np.linalg.norm(points[:, None, :] - landmarks[None, :, :], axis=2)
    nearest = distance.argmin(axis=1)
    closest = distance[np.arange(len(points)), nearest]
    close = closest <= tolerance
    return len(np.unique(nearest[close])), float(np.sum(closest[close] ** 2))


def register(points: np.ndarray, landmarks: np.ndarray, centre: np.ndarray,
             config: RefindingConfig) -> Optional[Registration]:
    """The best rigid correction of points (n, 2) onto landmarks (m, 2) (module doc), None when
    there is nothing to register."""
    if not len(points) or not len(landmarks):
        return None
    best: Optional[Registration] = None
    best_residual = 0.0
    count = int(np.floor(config.max_rotation / ROTATION_STEP + 1e-9))
    for rotation in ROTATION_STEP * np.arange(-count, count + 1):
        turned = (points - centre) @ _rotation(rotation).T + centre
        votes = (landmarks[None, :, :] - turned[:, None, :]).reshape(-1, 2)
        votes = votes[np.linalg.norm(votes, axis=1) <= config.max_shift]
        if not len(votes):
            continue
        cells = np.floor(votes / config.tolerance).astype(np.int64)
        _, inverse, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
        inverse = inverse.reshape(-1)
        for cell in np.argsort(counts, kind='stable')[-CELLS_PER_ROTATION:]:
            shift = np.median(votes[inverse == cell], axis=0)
            matched, residual = matched_landmarks(turned + shift, landmarks, config.tolerance)
            if best is None or (matched, -residual) > (best.matched, -best_residual):
                best = Registration(float(rotation), shift, centre.copy(), matched)
                best_residual = residual
    return best


class MapRefinder:
    """The window of recent map-frame observations and the first-seen scan of each landmark id
    (module doc); `refind` is called once per scan."""

    def __init__(self, config: RefindingConfig) -> None:
        self.config = config
        self.scan = 0
        self.first_seen: dict[int, int] = {}
        self.window: deque = deque()   # (scan, positions (k, 2))
        self.used: list[tuple[int, Registration]] = []   # (scan, registration) kept

    @property
    def enabled(self) -> bool:
        return self.config.window_scans > 0

    def reconfigure(self, config: RefindingConfig) -> None:
        """New settings; the state is kept."""
        self.config = config

    def old_mask(self, landmarks: Landmarks) -> np.ndarray:
        """(N,) the landmarks first seen at least old_scans scans before this one."""
        first = self.first_seen
        return np.array([first[i] <= self.scan - self.config.old_scans
                         for i in landmarks.ids.tolist()], dtype=bool)

    def refind(self, landmarks: Landmarks, positions: np.ndarray, pose: RobotPose,
               first: Association) -> Optional[Registration]:
        """Record this scan (landmark ids, the observations' map-frame positions (K, 2) from
        `pose`); when its first answer has 2 or more NEW observations, the registration of the
        window against the old landmarks near the pose that matches at least min_landmarks of
        them, else None."""
        self.scan += 1
        for landmark in landmarks.ids.tolist():
            self.first_seen.setdefault(landmark, self.scan)
        self.window.append((self.scan, np.asarray(positions, dtype=float)[:, :2]))
        while self.window[0][0] <= self.scan - self.config.window_scans:
            self.window.popleft()
        if int((first.assignment == NEW).sum()) < 2 or not len(landmarks):
            return None
        near = np.linalg.norm(landmarks.means[:, :2] - pose.mean[:2], axis=1) \
            <= self.config.radius
        old = landmarks.means[self.old_mask(landmarks) & near, :2]
        if len(old) < 4:
            return None
        points = np.concatenate([p for _, p in self.window])
        found = register(points, old, pose.mean[:2].copy(), self.config)
        if found is None or found.matched < self.config.min_landmarks:
            return None
        as_placed, _ = matched_landmarks(points, old, self.config.tolerance)
        return found if found.matched >= GAIN * as_placed else None

    def paired_old(self, landmarks: Landmarks, association: Association) -> int:
        """Observations paired with old landmarks."""
        return int(np.isin(association.assignment, landmarks.ids[self.old_mask(landmarks)]).sum())

    def kept(self, registration: Registration) -> None:
        """The registration's answer was kept: the window (placed from the drifted pose) is
        cleared."""
        self.used.append((self.scan, registration))
        self.window.clear()
