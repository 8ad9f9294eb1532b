"""Clustering of a scan by consecutive points (seed 003's first step): neighbouring returns in scan
order belong to one cluster while they are closer than `gap` [m]; invalid returns (non-finite)
break clusters; clusters with fewer than `min_points` are dropped.  cluster_ends tells which
cluster ends are the object's real edges and which are cut by something in front.  With a
`face_tolerance`, returns of one straight face seen at a grazing angle stay one cluster although
they are farther apart than `gap` (on_face), but not past the face's far end (ends_receding)."""
from __future__ import annotations

from typing import Optional

import numpy as np

FACE_SLOPE, FACE_STEPS = np.tan(np.deg2rad(20.0)), (0.5, 2.0)
"""on_face: the next return lies within 20 deg of the face's direction, FACE_STEPS times the
last spacing along it (the angle keeps a small object's corner, whose returns are a few cm
apart, from passing for its face going on)."""


def cluster_consecutive(points: np.ndarray, gap: float, min_points: int = 1,
                        face_tolerance: float = 0.0, longest_step: float = np.inf,
                        sensor: np.ndarray = np.zeros(2)) -> np.ndarray:
    """Cluster label per point (K,) in scan order, 0, 1, ...; -1 for invalid or dropped points.

    face_tolerance > 0 [m]: two consecutive returns a, b farther apart than `gap` stay in one
    cluster when they lie on one straight face with a third: b + 1 continues the line from a
    through b, or b continues the line from a - 1 through a (on_face with this tolerance; a
    face seen at a grazing angle has its returns farther apart than the gap: 0.6 m on a car's
    side at 8 deg and 20 m, which would leave the side out and end the cluster at the corner).
    A return past a corner with no second one on its line, or one off the line or at another
    spacing (a doorway in a wall), is not joined, nor are two returns more than `longest_step`
    [m] apart (longer than any object of the size class: returns of other things that happen
    to line up with a face, 3.2 m apart behind an F1Tenth car in race seed 404), nor a face
    to returns past its far end that turn off it (ends_receding; the face seen from `sensor`
    (2,), default the origin)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    valid = np.all(np.isfinite(points), axis=1)
    labels = np.full(len(points), -1)
    if not valid.any():
        return labels
    index = np.flatnonzero(valid)
    valid_points = points[index]
    steps = np.hypot(*np.diff(valid_points, axis=0).T)
    jumps = steps > gap
    # a skipped invalid return between two valid ones also separates them
    jumps |= np.diff(index) > 1
    if face_tolerance > 0:
        _join_faces(valid_points, index, jumps, max(min_points, 2), face_tolerance,
                    steps <= longest_step, np.asarray(sensor, dtype=float).reshape(2))
    raw = np.concatenate([[0], np.cumsum(jumps)])
    counts = np.bincount(raw)
    keep = counts[raw] >= min_points
    _, renumbered = np.unique(raw[keep], return_inverse=True)
    labels[index[keep]] = renumbered
    return labels


def _join_faces(points: np.ndarray, index: np.ndarray, jumps: np.ndarray, anchor: int,
                tolerance: float, short: np.ndarray, sensor: np.ndarray) -> None:
    """Clear jumps[t] (between valid returns t and t + 1, where short[t]: not too far apart to
    be one object's) where the returns lie on one face (_continues, either way round) and the
    face goes on from a group of at least `anchor` returns on the near side: a cluster is
    continued outwards, return by return, first forwards then backwards; returns that only
    line up with each other (a wall seen at a grazing angle) do not become a cluster."""
    segment = np.concatenate([[0], np.cumsum(jumps)])
    anchored = np.bincount(segment) >= anchor
    ahead = _continues(points, index, tolerance)   # t + 2 continues t -> t + 1
    behind = np.concatenate([[False], ahead[:-1]])  # t + 1 continues t - 1 -> t
    joins = jumps & (ahead | behind) & short
    candidates = np.flatnonzero(joins)
    joins[candidates] = ~ends_receding(points, jumps, candidates, tolerance, sensor)
    at = np.flatnonzero(jumps)
    group = bool(anchored[0])
    for t in at:                  # forwards: the group on the left grows
        if joins[t] and group:
            jumps[t] = False
        else:
            group = bool(anchored[segment[t + 1]])
    group = bool(anchored[-1])
    for t in at[::-1]:            # backwards: the group on the right grows
        if jumps[t] and not (joins[t] and group):
            group = bool(anchored[segment[t]])
        else:
            jumps[t] = False
            group = group or bool(anchored[segment[t]])


def ends_receding(points: np.ndarray, jumps: np.ndarray, at: np.ndarray, tolerance: float,
                  sensor: np.ndarray = np.zeros(2)) -> np.ndarray:
    """For each step t in `at` (between returns t and t + 1 of `points` (V, 2) in scan order;
    jumps (V - 1,) bool: the steps that split clusters, before any face is joined), whether
    the returns past the step's farther return from `sensor` (2,) turn off the step's line:
    that return starts a run of returns without a jump, and the first of them at least
    max(step, 2 tolerance / FACE_SLOPE) from it (else the run's last) lies farther than
    tolerance + FACE_SLOPE x its distance along the step's line from that line (tolerance
    [m]: on_face's).  A face ends where it is farthest from the sensor at the object's far
    corner, and the face past that corner turns away from the sensor (a convex object shows
    at most the two faces that meet at its nearest corner): what the next beam hits there is
    something else, even when it happens to lie on the face's line (car_moving seed 1098: a wall behind a car seen end-on, its
    first return 0.01 m off the line of the car's side; the side joined it, and the wall with
    it).  At the nearest corner the step's farther return is one of the sparse face's, a run
    of one: that join stays.  The reach keeps the returns' noise from reading as a turn (a
    straight wall split by a step just over the gap, car_static seed 627).  Returns
    (len(at),) bool."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    result = np.zeros(len(at), dtype=bool)
    ranges = np.hypot(*(points - sensor).T)
    for k, t in enumerate(at):
        outwards = ranges[t + 1] > ranges[t]
        far, near, way = (t + 1, t, 1) if outwards else (t, t + 1, -1)
        face = points[far] - points[near]
        length = float(np.hypot(*face))
        if length == 0:
            continue
        reach = max(length, 2 * tolerance / FACE_SLOPE)
        other = far
        while 0 <= other + way < len(points) and not jumps[min(other, other + way)]:
            other += way
            if np.hypot(*(points[other] - points[far])) >= reach:
                break
        if other == far:
            continue
        along, across = along_across(points[other] - points[far], face / length)
        result[k] = across > tolerance + FACE_SLOPE * along
    return result


def _continues(points: np.ndarray, index: np.ndarray, tolerance: float) -> np.ndarray:
    """For each gap t between valid returns t and t + 1 ((V - 1,) bool): the returns t, t + 1,
    t + 2 (positions in `points` (V, 2), the scan's valid returns, scan indices `index`) are
    consecutive beams and t + 2 continues the face from t through t + 1 (on_face)."""
    out = np.zeros(max(len(points) - 1, 0), dtype=bool)
    a = np.flatnonzero(index[2:] - index[:-2] == 2)
    step = points[a + 1] - points[a]
    spacing = np.hypot(step[:, 0], step[:, 1])
    with np.errstate(invalid='ignore', divide='ignore'):
        out[a] = (spacing > 0) & on_face(points[a + 1], step / spacing[:, None], spacing,
                                         points[a + 2], tolerance)
    return out


def cluster_ends(points: np.ndarray, labels: np.ndarray, jump: float,
                 sensor: np.ndarray = np.zeros(2), max_range: Optional[float] = None,
                 full_turn: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(first and last point index (C, 2), which end is an object edge (C, 2) bool, which end is
    occluded (C, 2) bool) of clusters 0..C-1 of `labels` (from cluster_consecutive on
    scan-ordered points seen from `sensor` (2,), default the origin).

    An end is an edge (the object's outline really ends there) when the neighbouring return
    outside the cluster is missing (nothing behind) or farther by more than `jump` [m]; it is
    occluded when that return is nearer by more than `jump` (something in front hides the
    rest), or when it is the first or last beam of the scan (the field of view cuts it);
    neither when within `jump`, nor when the return is missing and the face, going on as
    between the end's last two returns, would pass the sensor's `max_range` at the next beam:
    r_end + 2 |r_end - r_inner| + jump > max_range (the object may go on beyond the range or
    end there: an object leaving the range would otherwise seem to end where the range does
    and be pulled back).  `full_turn`: the scan's last beam is followed by its first (a 360 deg
    scan), so no end is cut by the field of view: the neighbour of the first beam is the last."""
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
    if full_turn:
        neighbours %= max(len(labels), 1)
    in_scan = (neighbours >= 0) & (neighbours < len(labels))
    clipped = np.clip(neighbours, 0, max(len(labels) - 1, 0))
    with np.errstate(invalid='ignore'):
        ranges = np.hypot(points[:, 0] - sensor[0], points[:, 1] - sensor[1])
        neighbour_range = ranges[clipped]
        step = neighbour_range - ranges[ends]
    missing = ~np.isfinite(neighbour_range)
    beyond = np.zeros_like(missing)
    if max_range is not None and np.isfinite(max_range) and count:
        inner = np.clip(ends - [-1, 1], ends[:, :1], ends[:, 1:])   # the end's neighbour inside
        with np.errstate(invalid='ignore'):
            beyond = missing & (ranges[ends] + 2 * np.abs(ranges[ends] - ranges[inner]) + jump
                                > max_range)
    return ends, in_scan & ~beyond & (missing | (step > jump)), \
        ~in_scan | (~missing & (step < -jump))


def on_face(end: np.ndarray, outward: np.ndarray, spacing: float | np.ndarray, point: np.ndarray,
            tolerance: float) -> bool | np.ndarray:
    """True when `point` (2,) continues a face that reaches `end` (2,) going `outward` (unit,
    2): within `tolerance` [m] of its line and FACE_SLOPE of its direction, FACE_STEPS x
    `spacing` (the face's last return spacing [m]) beyond the end along it (the next return on
    the same straight face; a corner or a gap leaves it off the line or too far).  Arrays of
    them (..., 2) and spacings (...) broadcast: a bool array; NaN anywhere: False."""
    with np.errstate(invalid='ignore'):
        along, across = along_across(np.asarray(point, dtype=float) - end, outward)
        return (across <= np.minimum(tolerance, FACE_SLOPE * along)) & \
            (FACE_STEPS[0] * spacing <= along) & (along <= FACE_STEPS[1] * spacing)


def along_across(offset: np.ndarray, direction: np.ndarray) -> tuple:
    """(offset . direction, |offset x direction|) [m]: how far `offset` (..., 2) [m] goes along
    the unit vector `direction` (..., 2) and how far it lies off its line; arrays broadcast."""
    along = np.sum(offset * direction, axis=-1)
    across = np.abs(offset[..., 0] * direction[..., 1] - offset[..., 1] * direction[..., 0])
    return along, across


def turn_start(points: np.ndarray, longest_step: float = np.inf) -> int:
    """The beam at which to start a full-turn (360 deg) scan of `points` (K, 2, beam order,
    non-finite: no return) so that no cluster of cluster_consecutive runs over its last and
    first beams: 0 when beams K - 1 and 0 are already apart (either without a return, or
    farther apart than `longest_step` [m], which no cluster joins); else the first beam
    after a beam without a return (a missing return always ends a cluster); else, with
    returns all round (e.g. in a room), the beam after the longest step between neighbours,
    which ends a cluster only when it is longer than the gap and not joined as one face."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return 0
    valid = np.all(np.isfinite(points), axis=1)
    steps = np.hypot(*(points - np.roll(points, 1, axis=0)).T)  # step into beam k from k - 1
    if not (valid[-1] and valid[0]) or steps[0] > longest_step:
        return 0
    after_missing = np.flatnonzero(valid & ~np.roll(valid, 1))
    if after_missing.size:
        return int(after_missing[0])
    return int(np.argmax(steps))
