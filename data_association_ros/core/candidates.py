"""Candidate landmarks: NEW observations become landmarks only after M-of-N confirmation.

Every scan's NEW observations, in the map frame (positions (M, d), covariances (M, d, d): with
or without the robot pose's uncertainty, the node's candidate_pose_uncertainty), are matched
one-to-one to the tracked candidates with the gate of the association: `gnn` on z = m
(S = P_c + R_i, chi-square gate at `gate_probability`); `euclidean_nn` (one-to-one, within
`euclidean_gate`) when the association is Euclidean or there are no covariances; `iou` for boxes.
A matched candidate fuses the observation as a static point (information form:
P' = (P^-1 + R^-1)^-1, x' = P' (P^-1 x + R^-1 z); the mean of the hits without covariances);
an unmatched observation starts a candidate.  A candidate is confirmed when it was hit on
`confirm_hits` of the last `confirm_window` scans and expires after `max_misses` scans in a row
without a hit.  A confirmed candidate keeps absorbing the NEW observations that match it (so one
landmark is not announced twice while the map owner adds it) until it too misses `max_misses`
scans.  confirm_hits = 1 confirms every NEW observation at once and keeps no state.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple, Optional

import numpy as np

from .api import associate
from .errors import InvalidInputError
from .types import Landmarks, Observations


@dataclass
class Candidate:
    """A pending (or recently confirmed) landmark. mean (d,), covariance (d, d) or None;
    observations: (stamp ns, index in its message) of every hit."""

    id: int
    mean: np.ndarray
    covariance: Optional[np.ndarray]
    first_scan: int
    hit_scans: list[int] = field(default_factory=list)
    observations: list[tuple[int, int]] = field(default_factory=list)
    confirmed: bool = False

    def misses(self, scan: int) -> int:
        """Scans in a row without a hit, up to `scan`."""
        return scan - self.hit_scans[-1]

    def hits_in_window(self, scan: int, window: int) -> int:
        """Hits in the last `window` scans (scan - window, scan]."""
        return sum(1 for s in self.hit_scans if s > scan - window)

    def fuse(self, position: np.ndarray, covariance: Optional[np.ndarray]) -> None:
        """Static-point update with one observation (see the module docstring)."""
        if self.covariance is None or covariance is None:
            count = len(self.hit_scans)
            self.mean = self.mean + (position - self.mean) / (count + 1)
            return
        prior_information = np.linalg.inv(self.covariance)
        information = np.linalg.inv(covariance)
        fused = np.linalg.inv(prior_information + information)
        self.mean = fused @ (prior_information @ self.mean + information @ position)
        self.covariance = 0.5 * (fused + fused.T)


class ConfirmedLandmark(NamedTuple):
    """A candidate that passed confirmation: its fused estimate, the observations that made it
    ((stamp ns, index), oldest first) and the scans from its first observation to now (an
    immutable record, a named tuple: made for every NEW observation of every scan)."""

    candidate: int
    mean: np.ndarray
    covariance: Optional[np.ndarray]
    observations: tuple[tuple[int, int], ...]
    delay_scans: int


@dataclass(frozen=True)
class CandidateUpdate:
    """What one scan changed: landmarks confirmed, candidate ids expired unconfirmed."""

    confirmed: tuple[ConfirmedLandmark, ...]
    expired: tuple[int, ...]


def check_confirmation(confirm_hits: int, confirm_window: int, max_misses: int) -> None:
    """InvalidInputError unless 1 <= confirm_hits <= confirm_window and max_misses >= 1."""
    for name, value in (('confirm_hits', confirm_hits), ('confirm_window', confirm_window),
                        ('candidate_max_misses', max_misses)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise InvalidInputError(f'{name}: expected an integer >= 1, got {value!r}')
    if confirm_hits > confirm_window:
        raise InvalidInputError(f'confirm_hits ({confirm_hits}) must not exceed confirm_window '
                                f'({confirm_window})')


class CandidateManager:
    """Candidate landmarks across scans; `update` once per answered observation message."""

    def __init__(self, confirm_hits: int = 1, confirm_window: int = 3, max_misses: int = 2,
                 gate_probability: float = 0.99, euclidean_gate: float = 1.0,
                 iou_threshold: float = 0.3) -> None:
        self.configure(confirm_hits, confirm_window, max_misses, gate_probability,
                       euclidean_gate, iou_threshold)
        self.scan = 0
        self.tracked: list[Candidate] = []
        self._next_id = 0
        self.confirmed_total = 0
        self.expired_total = 0

    def configure(self, confirm_hits: int, confirm_window: int, max_misses: int,
                  gate_probability: float, euclidean_gate: float, iou_threshold: float) -> None:
        """Set the confirmation rule and gates (applies from the next update)."""
        check_confirmation(confirm_hits, confirm_window, max_misses)
        self.confirm_hits, self.confirm_window, self.max_misses = \
            int(confirm_hits), int(confirm_window), int(max_misses)
        self.gate_probability = gate_probability
        self.euclidean_gate = euclidean_gate
        self.iou_threshold = iou_threshold

    @property
    def pending(self) -> list[Candidate]:
        """Candidates not yet confirmed."""
        return [c for c in self.tracked if not c.confirmed]

    def update(self, positions: np.ndarray, covariances: Optional[np.ndarray], stamp_ns: int,
               indices: np.ndarray, model: str = 'point_map',
               euclidean: bool = False) -> CandidateUpdate:
        """One scan's NEW observations: positions (M, d) in the map frame, covariances
        (M, d, d) or None, their indices in the message (M,); model 'box' for boxes;
        euclidean: gate by distance (the association was euclidean_nn)."""
        if self.confirm_hits == 1:
            first = self._next_id
            self.count_confirmed(len(positions))
            return CandidateUpdate(
                self._confirmed_at_once(first, positions, covariances, stamp_ns, indices), ())
        self.scan += 1
        positions = np.asarray(positions, dtype=float)
        indices = np.asarray(indices, dtype=np.int64)
        match = self._match(positions, covariances, model, euclidean)
        for row, column in enumerate(match):
            covariance = None if covariances is None else covariances[row]
            if column >= 0:
                candidate = self.tracked[column]
                candidate.fuse(positions[row], covariance)
            else:
                candidate = Candidate(self._new_id(), positions[row].copy(),
                                      None if covariance is None else covariance.copy(),
                                      self.scan)
                self.tracked.append(candidate)
            candidate.hit_scans.append(self.scan)
            candidate.observations.append((stamp_ns, int(indices[row])))
        confirmed, expired, kept = [], [], []
        for candidate in self.tracked:
            if candidate.misses(self.scan) >= self.max_misses:
                if not candidate.confirmed:
                    expired.append(candidate.id)
                continue
            if not candidate.confirmed and candidate.hits_in_window(
                    self.scan, self.confirm_window) >= self.confirm_hits:
                candidate.confirmed = True
                confirmed.append(ConfirmedLandmark(
                    candidate.id, candidate.mean.copy(),
                    None if candidate.covariance is None else candidate.covariance.copy(),
                    tuple(candidate.observations), self.scan - candidate.first_scan))
            kept.append(candidate)
        self.tracked = kept
        self.confirmed_total += len(confirmed)
        self.expired_total += len(expired)
        return CandidateUpdate(tuple(confirmed), tuple(expired))

    def count_confirmed(self, count: int) -> None:
        """confirm_hits 1: the state moves as `update` moves it for `count` NEW observations (the
        scan, the candidate ids they take, the totals), without building their landmarks."""
        self.scan += 1
        self.tracked.clear()
        self._next_id += count
        self.confirmed_total += count

    @staticmethod
    def _confirmed_at_once(first: int, positions: np.ndarray, covariances: Optional[np.ndarray],
                           stamp_ns: int, indices: np.ndarray) -> tuple[ConfirmedLandmark, ...]:
        """confirm_hits 1: every observation a landmark, ids from `first` in order (each mean
        and covariance a row of this call's own copy)."""
        positions = np.array(positions, dtype=float)
        covariances = None if covariances is None else np.array(covariances, dtype=float)
        return tuple(ConfirmedLandmark(
            first + row, positions[row], None if covariances is None else covariances[row],
            ((stamp_ns, index),), 0)
            for row, index in enumerate(np.asarray(indices, dtype=np.int64).tolist()))

    def _new_id(self) -> int:
        self._next_id += 1
        return self._next_id - 1

    def _match(self, positions: np.ndarray, covariances: Optional[np.ndarray], model: str,
               euclidean: bool) -> np.ndarray:
        """Index into `tracked` per observation (M,), -1 for none."""
        if not self.tracked or not len(positions):
            return np.full(len(positions), -1, dtype=np.intp)
        means = np.array([c.mean for c in self.tracked])
        has_covariance = covariances is not None and all(
            c.covariance is not None for c in self.tracked)
        candidate_covariances = np.array([c.covariance for c in self.tracked]) \
            if has_covariance else None
        landmarks = Landmarks(np.arange(len(self.tracked)), means, candidate_covariances)
        if model == 'box':
            observations = Observations(positions, covariances, 'box')
            result = associate(landmarks, observations, 'iou', iou_threshold=self.iou_threshold)
        elif euclidean or not has_covariance:
            observations = Observations(positions, None, 'point_map')
            result = associate(landmarks, observations, 'euclidean_nn',
                               euclidean_gate=self.euclidean_gate, one_to_one=True)
        else:
            observations = Observations(positions, covariances, 'point_map')
            result = associate(landmarks, observations, 'gnn',
                               gate_probability=self.gate_probability)
        return np.where(result.assignment >= 0, result.assignment, -1).astype(np.intp)
