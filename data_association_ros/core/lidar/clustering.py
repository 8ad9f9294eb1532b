"""Clustering of a scan by consecutive points (seed 003's first step): neighbouring returns in scan
order belong to one cluster while they are closer than `gap` [m]; invalid returns (non-finite)
break clusters; clusters with fewer than `min_points` are dropped.  cluster_ends tells which
cluster ends are the object's real edges and which are cut by something in front."""
from __future__ import annotations

import numpy as np


def cluster_consecutive(points: np.ndarray, gap: float, min_points: int = 1) -> np.ndarray:
    """Cluster label per point (K,) in scan order, 0, 1, ...; -1 for invalid or dropped points."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    valid = np.all(np.isfinite(points), axis=1)
    labels = np.full(len(points), -1)
    if not valid.any():
        return labels
    index = np.flatnonzero(valid)
    jumps = np.hypot(*np.diff(points[index], axis=0).T) > gap
    # a skipped invalid return between two valid ones also separates them
    jumps |= np.diff(index) > 1
    raw = np.concatenate([[0], np.cumsum(jumps)])
    counts = np.bincount(raw)
    keep = counts[raw] >= min_points
    _, renumbered = np.unique(raw[keep], return_inverse=True)
    labels[index[keep]] = renumbered
    return labels


def cluster_ends(points: np.ndarray, labels: np.ndarray, jump: float,
                 sensor: np.ndarray = np.zeros(2)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(first and last point index (C, 2), which end is an object edge (C, 2) bool, which end is
    occluded (C, 2) bool) of clusters 0..C-1 of `labels` (from cluster_consecutive on
    scan-ordered points seen from `sensor` (2,), default the origin).

    An end is an edge (the object's outline really ends there) when the neighbouring return
    outside the cluster is missing (nothing behind) or farther by more than `jump` [m]; it is
    occluded when that return is nearer by more than `jump` (something in front hides the
    rest), or when it is the first or last beam of the scan (the field of view cuts it);
    neither when within `jump`."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    count = int(labels.max()) + 1 if labels.size else 0
    index = np.arange(len(labels))
    inside = labels >= 0
    first = np.full(count, len(labels))
    last = np.full(count, -1)
    np.minimum.at(first, labels[inside], index[inside])
    np.maximum.at(last, labels[inside], index[inside])
    ends = np.column_stack([first, last]).reshape(count, 2)
    neighbours = ends + [-1, 1]
    in_scan = (neighbours >= 0) & (neighbours < len(labels))
    clipped = np.clip(neighbours, 0, max(len(labels) - 1, 0))
    with np.errstate(invalid='ignore'):
        ranges = np.hypot(points[:, 0] - sensor[0], points[:, 1] - sensor[1])
        neighbour_range = ranges[clipped]
        step = neighbour_range - ranges[ends]
    missing = ~np.isfinite(neighbour_range)
    return ends, in_scan & (missing | (step > jump)), \
        ~in_scan | (~missing & (step < -jump))
