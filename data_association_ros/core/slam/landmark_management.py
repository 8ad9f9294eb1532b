"""Landmark management for EKF-SLAM: merge duplicates by a joint test, drop landmarks that are
predicted in view again and again but never seen.

Merge.  Two landmarks i, j of the state are one when the difference d = l_i - l_j passes the
chi-square test d^T D^-1 d <= chi2(2, merge_probability), D = P_ii + P_jj - P_ij - P_ji + f^2 I
(the covariance of d, with the cross-correlation the filter holds, and merge_floor f [m] for a
filter whose covariances are tighter than its errors; f = 0: none).  They are fused by the
pseudo-measurement 0 = l_i - l_j + v, v ~ N(0, f^2 I) (K = P H^T D^-1, x -= K d, P -= K D K^T,
H = [.. I .. -I ..]; f = 0: exactly, l_j then equals l_i); l_j is then removed from the state
(its rows and columns deleted), the older landmark i stays.  Tested pairs: each landmark fused
or started since the last call against every other landmark within merge_distance [m]
(Euclidean pre-filter) that was never fused or started on the same scan as it (one scan sees
an object once: two landmarks seen together are two objects; recorded for the pairs closer
than TOGETHER_RANGE merge distances), the smallest statistic first,
each landmark merged at most once per call.

Drop.  Each landmark counts its sightings (scans on which it was fused, its start included) and
its misses: scans in a row since its last sighting on which its mean was predicted in view -
range <= view_range [m] and |bearing| <= view_half_angle [rad] from the robot's posterior pose -
but it was not fused.  A landmark with at most drop_max_sightings sightings (0: any number) is
removed once it has drop_misses misses: a clutter return or a duplicate started from a bad pose
that is never seen again, or (drop_max_sightings 0) an object that has moved away.

The state is the EkfSlam's (mean, covariance, ids); removal keeps the order of the others.
"""
from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from ..gating import chi2_threshold
from ..models.base import wrap_angle
from .ekf_slam import LANDMARK, POSE, EkfSlam

TOGETHER_RANGE = 2.0
"""Pairs seen together are recorded when closer than this many merge distances (a merge tests
pairs within one)."""
MERGE_REGULARISATION = 1e-12
"""Added to the diagonal of D before it is inverted [m^2] (two landmarks with identical rows)."""


@dataclass
class LandmarkManagementConfig:
    """merge_probability in (0, 1) (0: no merging); merge_distance [m]; merge_floor [m];
    drop_misses (0: no dropping); drop_max_sightings (0: no limit); view_range [m] (0: no
    limit); view_half_angle [rad]."""

    merge_probability: float = 0.0
    merge_distance: float = 2.0
    merge_floor: float = 0.0
    drop_misses: int = 0
    drop_max_sightings: int = 1
    view_range: float = 0.0
    view_half_angle: float = np.pi


@dataclass
class ManagementResult:
    """What one call changed: merged (removed id, kept id) pairs and dropped ids."""

    merged: list[tuple[int, int]] = field(default_factory=list)
    dropped: list[int] = field(default_factory=list)


def remove_landmarks(slam: EkfSlam, ids: np.ndarray) -> None:
    """Delete the landmarks `ids` (all in the map) from the state: their mean entries and
    covariance rows and columns (marginalisation)."""
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    if ids.size == 0:
        return
    index = slam.index_of(ids)
    if np.any(index < 0):
        raise ValueError(f'ids not in the map: {ids[index < 0]}')
    keep = np.ones(len(slam.mean), dtype=bool)
    for a in range(LANDMARK):
        keep[POSE + LANDMARK * index + a] = False
    slam.mean = slam.mean[keep]
    slam.covariance = slam.covariance[np.ix_(keep, keep)]
    slam.ids = np.delete(slam.ids, index)


def merge_statistic(slam: EkfSlam, i: int, j: int,
                    floor: float = 0.0) -> tuple[float, np.ndarray, np.ndarray]:
    """(d^T D^-1 d, d (2,), D (2, 2)) of landmarks at map indices i, j, floor f [m] (see the
    module doc)."""
    a, b = POSE + LANDMARK * i, POSE + LANDMARK * j
    p = slam.covariance
    d = slam.mean[a:a + LANDMARK] - slam.mean[b:b + LANDMARK]
    block = (p[a:a + LANDMARK, a:a + LANDMARK] + p[b:b + LANDMARK, b:b + LANDMARK]
             - p[a:a + LANDMARK, b:b + LANDMARK] - p[b:b + LANDMARK, a:a + LANDMARK])
    block = 0.5 * (block + block.T) + (MERGE_REGULARISATION + floor ** 2) * np.eye(LANDMARK)
    return float(d @ np.linalg.solve(block, d)), d, block


def fuse_equal(slam: EkfSlam, i: int, j: int, floor: float = 0.0) -> None:
    """Condition the state on l_i = l_j + v, v ~ N(0, floor^2 I) (map indices; see the module
    doc); floor 0: l_j stays in the state with the same mean and rows as l_i."""
    _, d, block = merge_statistic(slam, i, j, floor)
    a, b = POSE + LANDMARK * i, POSE + LANDMARK * j
    p = slam.covariance
    p_ht = p[:, a:a + LANDMARK] - p[:, b:b + LANDMARK]          # P H^T (n, 2)
    gain = np.linalg.solve(block, p_ht.T).T                      # (n, 2)
    slam.mean -= gain @ d
    slam.mean[2] = wrap_angle(slam.mean[2])
    p -= gain @ p_ht.T
    slam.covariance = 0.5 * (p + p.T)


class LandmarkManager:
    """Sightings and misses per landmark id, and the merge and drop rules of the module doc."""

    def __init__(self, config: LandmarkManagementConfig) -> None:
        self.config = config
        self.sightings: dict[int, int] = {}
        self.misses: dict[int, int] = {}
        self.fresh: set[int] = set()     # fused or started since the last call
        self.seen_on: dict[Optional[Hashable], set[int]] = {}   # scan -> its fused or started
        self.together: dict[int, set[int]] = {}   # landmarks fused or started on one scan

    @property
    def active(self) -> bool:
        return self.config.merge_probability > 0 or self.config.drop_misses > 0

    def started(self, ids, scan: Optional[Hashable] = None) -> None:
        """Landmarks just added to the map (one sighting each) from observations of `scan`
        (a key, e.g. its stamp; None: the scan of the next after_scan)."""
        for landmark in np.asarray(ids, dtype=np.int64).reshape(-1).tolist():
            self.sightings[landmark] = 1
            self.misses[landmark] = 0
            self._seen(landmark, scan)

    def fused(self, ids, scan: Optional[Hashable] = None) -> None:
        """Landmarks fused in the update of `scan` (as for `started`)."""
        for landmark in np.asarray(ids, dtype=np.int64).reshape(-1).tolist():
            self.sightings[landmark] = self.sightings.get(landmark, 0) + 1
            self.misses[landmark] = 0
            self._seen(landmark, scan)

    def _seen(self, landmark: int, scan: Optional[Hashable]) -> None:
        self.fresh.add(landmark)
        self.seen_on.setdefault(scan, set()).add(landmark)

    def after_scan(self, slam: EkfSlam, fused_ids,
                   scan: Optional[Hashable] = None) -> ManagementResult:
        """Count misses of the landmarks in view not in `fused_ids`, then merge and drop (the
        module doc); returns what was removed.  Call once per scan, after its update and its new
        landmarks; `scan`: its key (None: every landmark since the last call was seen on it).
        The landmarks of one scan are recorded as seen together, also those started from it
        after this call (new landmarks that arrive after its answer: at the next call)."""
        result = ManagementResult()
        if not self.active or len(slam.ids) == 0:
            self.next_scan(scan)
            return result
        if self.config.drop_misses > 0:
            self._count_misses(slam, set(np.asarray(fused_ids, dtype=np.int64).tolist()))
        if self.config.merge_probability > 0:
            self._record_together(slam)
            result.merged = self._merge(slam)
        if self.config.drop_misses > 0:
            result.dropped = self._drop(slam)
        self.next_scan(scan)
        return result

    def next_scan(self, scan: Optional[Hashable] = None) -> None:
        """Forget what was fresh; keep the landmarks of `scan` (not None) for its late ones
        (after_scan does this; call it for a scan that is not managed)."""
        self.fresh.clear()
        kept = self.seen_on.get(scan) if scan is not None else None
        self.seen_on = {} if kept is None else {scan: kept}

    def _in_view(self, slam: EkfSlam) -> np.ndarray:
        """(N,) landmarks whose mean is in the sensor's view from the posterior pose."""
        means = slam.mean[POSE:].reshape(-1, LANDMARK)
        delta = means - slam.mean[:2]
        distance = np.hypot(delta[:, 0], delta[:, 1])
        bearing = wrap_angle(np.arctan2(delta[:, 1], delta[:, 0]) - slam.mean[2])
        view = np.abs(bearing) <= self.config.view_half_angle
        if self.config.view_range > 0:
            view &= distance <= self.config.view_range
        return view

    def _count_misses(self, slam: EkfSlam, fused: set[int]) -> None:
        for landmark in slam.ids[self._in_view(slam)].tolist():
            if landmark not in fused and landmark not in self.fresh:
                self.misses[landmark] = self.misses.get(landmark, 0) + 1

    def _record_together(self, slam: EkfSlam) -> None:
        """The landmarks fused or started from one scan were seen together: each pair of them
        closer than TOGETHER_RANGE merge distances (the only pairs a merge could test; the
        record stays as small as the neighbourhoods, not the square of the map)."""
        for landmarks in self.seen_on.values():
            self._record_pairs(slam, landmarks)

    def _record_pairs(self, slam: EkfSlam, landmarks: set[int]) -> None:
        ids = np.array(sorted(landmarks), dtype=np.int64)
        index = slam.index_of(ids)
        ids, index = ids[index >= 0], index[index >= 0]
        if len(ids) < 2:
            return
        means = slam.mean[POSE:].reshape(-1, LANDMARK)[index]
        close = np.hypot(*(means[:, None, :] - means[None, :, :]).transpose(2, 0, 1)) \
            <= TOGETHER_RANGE * self.config.merge_distance
        for a, b in zip(*np.nonzero(np.triu(close, 1))):
            first, second = int(ids[a]), int(ids[b])
            self.together.setdefault(first, set()).add(second)
            self.together.setdefault(second, set()).add(first)

    def _merge(self, slam: EkfSlam) -> list[tuple[int, int]]:
        threshold = chi2_threshold(self.config.merge_probability, LANDMARK)
        means = slam.mean[POSE:].reshape(-1, LANDMARK)
        fresh = [i for i in slam.index_of(np.array(sorted(self.fresh), dtype=np.int64))
                 if i >= 0]
        tests = []
        for i in fresh:
            near = np.flatnonzero(np.hypot(*(means - means[i]).T) <= self.config.merge_distance)
            seen_with = self.together.get(int(slam.ids[i]), set())
            for j in near[near != i].tolist():
                if int(slam.ids[j]) in seen_with:
                    continue
                statistic, _, _ = merge_statistic(slam, i, j, self.config.merge_floor)
                if statistic <= threshold:
                    tests.append((statistic, int(slam.ids[min(i, j)]),
                                  int(slam.ids[max(i, j)])))
        merged, used = [], set()
        for _, keep, remove in sorted(tests):
            if keep in used or remove in used:
                continue
            i, j = slam.index_of(np.array([keep, remove]))
            fuse_equal(slam, int(i), int(j), self.config.merge_floor)
            remove_landmarks(slam, np.array([remove]))
            self.sightings[keep] = self.sightings.get(keep, 0) + self.sightings.pop(remove, 0)
            self.misses[keep] = min(self.misses.get(keep, 0), self.misses.pop(remove, 0))
            for other in self._forget(remove):
                self.together[other].add(keep)
                self.together.setdefault(keep, set()).add(other)
            for landmarks in self.seen_on.values():   # keep was on remove's scans
                if remove in landmarks:
                    landmarks.discard(remove)
                    landmarks.add(keep)
            used.update((keep, remove))
            merged.append((remove, keep))
        return merged

    def _drop(self, slam: EkfSlam) -> list[int]:
        config = self.config
        dropped = [landmark for landmark in slam.ids.tolist()
                   if self.misses.get(landmark, 0) >= config.drop_misses
                   and (config.drop_max_sightings == 0
                        or self.sightings.get(landmark, 0) <= config.drop_max_sightings)]
        if dropped:
            remove_landmarks(slam, np.array(dropped, dtype=np.int64))
            for landmark in dropped:
                self.sightings.pop(landmark, None)
                self.misses.pop(landmark, None)
                self._forget(landmark)
        return dropped

    def _forget(self, landmark: int) -> set[int]:
        """Remove `landmark` from the seen-together record; the landmarks it was seen with."""
        others = self.together.pop(landmark, set())
        for other in others:
            self.together[other].discard(landmark)
        return others
