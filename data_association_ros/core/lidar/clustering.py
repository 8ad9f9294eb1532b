"""Clustering of a scan by consecutive points (seed 003's first step): neighbouring returns in scan
order belong to one cluster while they are closer than `gap` [m]; invalid returns (non-finite)
break clusters; clusters with fewer than `min_points` are dropped."""
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
