"""A cluster that holds the returns of two or more tracked objects, split between them.

Two objects close together (cars side by side in a convoy, an F1Tenth car passing another)
give returns closer than the cluster gap, so cluster_consecutive makes one cluster of both.
The coarse association gives a cluster to one track: that track then grows over both objects
and the other one coasts and loses its object (f1tenth_moving seed 1013 objects 2 and 4: two
cars 0.8 m apart, the near one's track grew to 1.24 m and was dropped as a wall, the far one's
id was handed to the near car).  `split_shared` divides such a cluster by the predicted
rectangles of the tracks that were corrected on the previous scan: a return belongs to the
rectangle it lies nearest to; the pieces are contiguous in scan order (one object's returns
are consecutive beams).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .shape import rotation


@dataclass(frozen=True)
class Boxes:
    """Predicted rectangles: centres (B, 2) [m], yaws (B,) [rad], half length and width
    (B, 2) [m], velocities (B, 2) [m/s] (a return taken `offset` s after the scan's stamp is
    moved back by velocity x offset before it is compared), margins (B,) [m]: how far outside
    its rectangle a return may lie and still be the box's."""

    centres: np.ndarray
    yaws: np.ndarray
    halves: np.ndarray
    velocities: np.ndarray
    margins: np.ndarray

    def subset(self, index: np.ndarray) -> 'Boxes':
        """The boxes at `index`."""
        return Boxes(self.centres[index], self.yaws[index], self.halves[index],
                     self.velocities[index], self.margins[index])

    def reaching(self, points: np.ndarray, labels: np.ndarray, offsets: np.ndarray,
                 count: int) -> np.ndarray:
        """(count, B) bool: whether box b may hold a return of cluster c (`labels` (K,) of
        `points` (K, 2), -1: none) within its margin: the box's centre is within the cluster's
        circle about its mean, grown by the box's half diagonal, margin and largest move
        (velocity x the cluster's largest |offset| (K,) [s])."""
        inside = labels >= 0
        owner, members = labels[inside], points[inside]
        sizes = np.maximum(np.bincount(owner, minlength=count), 1)
        means = np.column_stack([np.bincount(owner, members[:, k], count) / sizes
                                 for k in range(2)])
        radius, late = np.zeros(count), np.zeros(count)
        np.maximum.at(radius, owner, np.hypot(*(members - means[owner]).T))
        np.maximum.at(late, owner, np.abs(offsets[inside]))
        reach = radius[:, None] + (np.hypot(*self.halves.T) + self.margins)[None] \
            + late[:, None] * np.hypot(*self.velocities.T)[None]
        gap = self.centres[None] - means[:, None]
        return np.hypot(gap[..., 0], gap[..., 1]) <= reach

    def distances(self, points: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """(K, B): the distance [m] of each point (K, 2), taken offsets (K,) [s] after the
        stamp, to each rectangle (0 inside)."""
        moved = points[:, None, :] - offsets[:, None, None] * self.velocities[None]  # (K, B, 2)
        result = np.empty((len(points), len(self.yaws)))
        for b, yaw in enumerate(self.yaws):
            body = np.abs((moved[:, b] - self.centres[b]) @ rotation(yaw)) - self.halves[b]
            result[:, b] = np.hypot(*np.maximum(body, 0.0).T)
        return result


def split_shared(points: np.ndarray, labels: np.ndarray, boxes: Boxes, offsets: np.ndarray,
                 min_points: int) -> np.ndarray:
    """Labels (K,) with each cluster of `labels` (cluster_consecutive's, on scan-ordered
    `points` (K, 2)) that two or more boxes claim split into one cluster per box: a box claims a
    cluster when at least `min_points` of its returns lie within the box's margin and within no
    other box's.  Each return goes to the claiming box it lies nearest to, then the cut points
    are placed in scan order where the fewest returns go against that (a cut between box a and
    the boxes after it minimises a's returns after it plus the others' before it).  A cluster is
    left whole when a piece would have fewer than `min_points` returns.  After a split the
    labels are renumbered 0..C-1 in scan order of each cluster's first return (-1 kept; as
    cluster_consecutive numbers them); with none, `labels` itself is returned."""
    labels = np.asarray(labels)
    if len(boxes.yaws) < 2 or not np.any(labels >= 0):
        return labels   # a cluster is only split between two boxes or more
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    offsets = np.asarray(offsets, dtype=float).reshape(len(points))
    count = int(labels.max()) + 1
    next_label = count
    reaching_boxes = boxes.reaching(points, labels, offsets, count)
    large = np.bincount(labels[labels >= 0], minlength=count) >= 2 * min_points
    for cluster in np.flatnonzero(large & (reaching_boxes.sum(axis=1) >= 2)):
        member = np.flatnonzero(labels == cluster)
        reaching = np.flatnonzero(reaching_boxes[cluster])
        distance = boxes.subset(reaching).distances(points[member], offsets[member])
        near = distance <= boxes.margins[reaching][None, :]
        own = near & (near.sum(axis=1) == 1)[:, None]
        claimants = np.flatnonzero(own.sum(axis=0) >= min_points)
        if len(claimants) < 2:
            continue
        owner = _owners(distance, claimants, min_points)
        if owner is None:
            continue
        order = sorted(set(owner), key=lambda b: np.median(np.flatnonzero(owner == b)))
        cuts = _cuts(owner, order)
        sizes = np.diff(np.concatenate([[0], cuts, [len(member)]]))
        if np.any(sizes < min_points):
            continue
        if next_label == count:
            labels = labels.copy()  # the caller's labels are left as they are
        for cut in cuts:
            labels[member[cut:]] = next_label
            next_label += 1
    return labels if next_label == count else _renumbered(labels)


def _owners(distance: np.ndarray, claimants: np.ndarray, min_points: int
            ) -> Optional[np.ndarray]:
    """The box (column of distance (n, B)) each return goes to: the nearest claimant, after
    dropping, one round at a time, the claimants nearest to fewer than min_points returns (a box
    with a wide margin may claim returns that lie nearer another); None when fewer than two
    are left."""
    while len(claimants) >= 2:
        owner = claimants[np.argmin(distance[:, claimants], axis=1)]
        kept = np.array([np.count_nonzero(owner == b) >= min_points for b in claimants])
        if kept.all():
            return owner
        claimants = claimants[kept]
    return None


def _cuts(owner: np.ndarray, order: list) -> list[int]:
    """Cut positions (m - 1 for m boxes in `order`) in the scan-ordered returns' owners: each
    cut, after the previous one, where the fewest returns of the box before it lie after it
    and of the later boxes before it."""
    cuts, start = [], 0
    for box in order[:-1]:
        mine = owner[start:] == box
        # cost(s) = not mine before s + mine from s on, for s = start..len
        before = np.concatenate([[0], np.cumsum(~mine)])
        after = np.concatenate([np.cumsum(mine[::-1])[::-1], [0]])
        start += int(np.argmin(before + after))
        cuts.append(start)
    return cuts


def _renumbered(labels: np.ndarray) -> np.ndarray:
    """Labels 0..C-1 in scan order of each cluster's first return (-1 kept)."""
    inside = labels >= 0
    if not inside.any():
        return labels
    _, first = np.unique(labels[inside], return_index=True)
    order = np.argsort(np.argsort(first))
    mapping = np.full(int(labels.max()) + 1, -1)
    mapping[np.unique(labels[inside])] = order
    result = labels.copy()
    result[inside] = mapping[labels[inside]]
    return result
