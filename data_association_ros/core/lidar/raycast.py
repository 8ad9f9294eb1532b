"""Ray casting a 2-D scan against line segments, vectorised over rays x segments.

Ray i from origin o in direction d_i = (cos a_i, sin a_i); segment j from p_j to q_j, e_j = q_j - p_j.
Solving o + t d = p + u e:  t = cross(p - o, e) / cross(d, e),  u = cross(p - o, d) / cross(d, e);
a hit needs t > 0 and 0 <= u <= 1; the range is the smallest t (inf when none, or beyond max_range).
"""
from __future__ import annotations

import numpy as np


def rectangle_segments(centre: np.ndarray, yaw: float, length: float,
                       width: float) -> np.ndarray:
    """The 4 sides (4, 2, 2) [segment, end, xy] of a rectangle with its long side along yaw."""
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
    c, s = np.cos(yaw), np.sin(yaw)
    corners = half @ np.array([[c, s], [-s, c]]) + centre
    return np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)


def raycast(origin: np.ndarray, angles: np.ndarray, segments: np.ndarray,
            max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """(ranges (R,), index of the segment hit (R,), -1 for none) of rays at `angles` [rad, world
    frame] from `origin` (2,) against `segments` (S, 2, 2); inf beyond max_range or no hit.
    Per ray (a moving sensor, a scene that moves while the beam turns): origin (R, 2) and/or
    segments (R, S, 2, 2)."""
    d = np.column_stack([np.cos(angles), np.sin(angles)])[:, None, :]  # (R, 1, 2)
    segments = np.asarray(segments, dtype=float)
    if segments.ndim == 3:
        segments = segments[None]
    p, e = segments[..., 0, :], segments[..., 1, :] - segments[..., 0, :]  # (1|R, S, 2)
    origin = np.asarray(origin, dtype=float)
    w = p - (origin[:, None, :] if origin.ndim == 2 else origin)

    def cross(a, b):
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    denominator = cross(d, e)
    with np.errstate(divide='ignore', invalid='ignore'):
        t = cross(w, e) / denominator
        u = cross(w, d) / denominator
    hit = (np.abs(denominator) > 1e-12) & (t > 1e-9) & (u >= 0) & (u <= 1)
    t = np.where(hit, t, np.inf)
    nearest = np.argmin(t, axis=1)
    ranges = t[np.arange(len(angles)), nearest]
    ranges = np.where(ranges <= max_range, ranges, np.inf)
    return ranges, np.where(np.isfinite(ranges), nearest, -1)
