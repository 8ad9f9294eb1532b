"""Free space along the beams (added to seed 003, see object_tracker): a beam that returns from
beyond an object's rectangle, or returns nothing, shows that the rectangle is not there, so an
extent completed by the size prior on the hidden side is cut back to where the beam passes (a
3.8 m car seen whole no longer keeps a 4.5 m prior).

Beams are rays o + t d, t in [0, free], free = range - margin (for a beam without a return:
the farthest return of the scan - margin).  In the
rectangle's frame (axes u along the heading, v across) the box is [low_u, high_u] x [low_v,
high_v]; a ray passes through it when its free part meets the box (slab test).
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from .clustering import FACE_SLOPE, FACE_STEPS

RANGE_SHARE = 0.95
"""beams: a beam without a return is free up to this share of the sensor's range_max."""
LINEAR_TOLERANCE = 0.1
"""Beam angles of a scan are taken as evenly spaced when every return's angle lies within this
share of one beam step of the line through the first and last return (a LaserScan: exactly)."""


def beam_directions(points: np.ndarray) -> np.ndarray:
    """Unit beam directions (K, 2) of a scan's points (K, 2) in the sensor frame, in beam order
    (non-finite: no return).  A beam without a return gets the direction of its index on the
    line through the first and last return's angles when every return lies on it
    (LINEAR_TOLERANCE: evenly spaced beams), else NaN (nothing is known about it).  The
    returns' angles are unwrapped along that line: each one to the turn nearest to where the
    median step between neighbouring beams puts it, so that returns more than half a turn of
    missing beams apart (a 360 deg scan with returns only near its two ends) stay on it."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    directions = np.full(points.shape, np.nan)
    valid = np.all(np.isfinite(points), axis=1) & (np.hypot(points[:, 0], points[:, 1]) > 0)
    index = np.flatnonzero(valid)
    angles = np.arctan2(points[valid, 1], points[valid, 0])
    directions[valid] = np.column_stack([np.cos(angles), np.sin(angles)])
    if len(index) < 3 or len(index) == len(points):  # two returns prove no spacing
        return directions
    neighbours = np.flatnonzero(np.diff(index) == 1)
    if neighbours.size:  # each angle to the turn nearest to the median step's prediction
        step = float(np.median(np.angle(np.exp(1j * np.diff(angles)[neighbours]))))
        predicted = angles[0] + step * (index - index[0])
        angles = predicted + np.angle(np.exp(1j * (angles - predicted)))
    else:
        angles = np.unwrap(angles)
    slope = (angles[-1] - angles[0]) / (index[-1] - index[0])  # the line through the end beams
    intercept = angles[0] - slope * index[0]
    if np.max(np.abs(angles - (slope * index + intercept))) > LINEAR_TOLERANCE * abs(slope):
        return directions
    missing = np.flatnonzero(~valid)
    fitted = slope * missing + intercept
    directions[missing] = np.column_stack([np.cos(fitted), np.sin(fitted)])
    return directions


def _slab(origin: np.ndarray, direction: np.ndarray, low: float, high: float
          ) -> tuple[np.ndarray, np.ndarray]:
    """(t_enter, t_exit) (R,) of rays (R,) (one coordinate) within [low, high]; empty
    (enter > exit) when a ray parallel to the slab lies outside it."""
    with np.errstate(divide='ignore', invalid='ignore'):
        a, b = (low - origin) / direction, (high - origin) / direction
    parallel = np.abs(direction) < 1e-12
    inside = (origin >= low) & (origin <= high)
    enter = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(a, b))
    leave = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(a, b))
    return enter, leave


def beams(points: np.ndarray, sensor: np.ndarray, directions: Optional[np.ndarray],
          margin: float, max_range: Optional[float] = None
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(unit directions (K, 2), free lengths (K,), returned (K,) bool) of a scan's beams from
    `sensor` (2,) (or each beam from its own origin, (K, 2)): towards the point (or
    directions[k] where given, NaN unknown; by default beam_directions of the points seen
    from the sensor), free up to `margin` [m] before the
    return; a beam without one is free up to `margin` before the farthest return of the scan
    or RANGE_SHARE x the sensor's `max_range` [m] (its range_max), whichever is farther (no
    return can mean out of range: the sensor reaches at least that far; returns near the end
    of the range are weak, so no return there is no evidence)."""
    delta = np.asarray(points, float) - sensor
    distance = np.hypot(delta[:, 0], delta[:, 1])
    returned = np.isfinite(distance) & (distance > 0)
    with np.errstate(invalid='ignore', divide='ignore'):
        own = delta / distance[:, None]
    if directions is None:
        directions = beam_directions(delta)
    directions = np.where(returned[:, None], own, np.asarray(directions, float))
    reach = distance[returned].max() if returned.any() else 0.0
    if max_range is not None and np.isfinite(max_range):
        reach = max(reach, RANGE_SHARE * float(max_range))
    return directions, np.where(returned, distance, reach) - margin, returned


def near(origin: np.ndarray, directions: np.ndarray, centre: np.ndarray,
         radius: float) -> np.ndarray:
    """Indices of the rays from `origin` (2,) or origins (R, 2) along unit `directions` (R, 2)
    that pass within `radius` [m] of `centre` (2,) ahead of their origin (a box's enclosing
    circle: the only rays that can meet the box)."""
    delta = np.asarray(centre, float) - origin
    with np.errstate(invalid='ignore'):
        across = np.abs(directions[:, 0] * delta[..., 1] - directions[:, 1] * delta[..., 0])
        along = np.sum(directions * delta, axis=-1)
        return np.flatnonzero((across <= radius) & (along >= -radius))


def through_box(origins: np.ndarray, directions: np.ndarray, low: np.ndarray,
                high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t_enter, t_exit) (R,) of rays (origins (R, 2) or (2,), unit directions (R, 2)) through
    the box [low, high] (2,) (slab test; a ray misses it when exit <= max(enter, 0))."""
    origins = np.broadcast_to(np.asarray(origins, float), np.shape(directions))
    return _box(_spans(origins, directions, low, high))


def _spans(origins: np.ndarray, directions: np.ndarray, low: np.ndarray, high: np.ndarray
           ) -> list:
    """[(t_enter, t_exit) of the u slab, of the v slab] (_slab) of rays (R,) per axis."""
    return [_slab(origins[:, k], directions[:, k], low[k], high[k]) for k in range(2)]


def _box(spans: list) -> tuple[np.ndarray, np.ndarray]:
    """(t_enter, t_exit) of the box from its two slabs' spans."""
    return np.maximum(spans[0][0], spans[1][0]), np.minimum(spans[0][1], spans[1][1])


def blocked_share(origins: np.ndarray, directions: np.ndarray, free: np.ndarray,
                  returned: np.ndarray, range_known: bool, low: np.ndarray, high: np.ndarray,
                  margin: float) -> Optional[float]:
    """Share of the beams (origins (R, 2) or (2,), unit directions (R, 2), free lengths ending
    `margin` [m] before their returns, `returned` (R,) bool) towards the box [low, high] (2,)
    that end more than 2 margin before entering it: a return from something nearer (it hides
    the box), or, without a return and with the sensor's range known, the end of the range
    (beams: the box lies out of range, where nothing is seen; a beam without a return from a
    sensor of unknown range hides nothing).  Beams that return from within the box (the object
    itself, or part of it) count neither way; when only they point at it the share is 0 (it is
    in sight).  None when no beam points at it."""
    with np.errstate(invalid='ignore'):
        enter, leave = through_box(origins, directions, low, high)
        towards = np.all(np.isfinite(directions), axis=1) & (leave > np.maximum(enter, 0.0))
    if not towards.any():
        return None
    free, enter, leave, returned = free[towards], enter[towards], leave[towards], \
        np.asarray(returned, bool)[towards]
    blocked = (returned | range_known) & (free + 2 * margin < enter)
    own = returned & ~blocked & (free <= leave)
    counted = np.count_nonzero(~own)
    return float(np.count_nonzero(blocked) / counted) if counted else 0.0


def carve(low: np.ndarray, high: np.ndarray, seen_low: np.ndarray, seen_high: np.ndarray,
          origins: np.ndarray, directions: np.ndarray, free: np.ndarray,
          min_depth: float = 0.0, share: float = 0.0, min_sine: float = 0.0,
          returned: Optional[np.ndarray] = None,
          margin: float = 0.0
          ) -> tuple[np.ndarray, np.ndarray]:
    """The box [low, high] (2,) (object frame, u and v) cut back, one side at a time, until no
    ray (origins (R, 2), unit directions (R, 2), free lengths (R,), object frame) passes through
    it.  A side is only cut down to the span of the seen points [seen_low, seen_high] (2,);
    each passing ray cuts the side that loses the least; a ray no such cut clears (it passes
    through the seen span: noise) is ignored.  A ray cuts an extent along one axis only when it
    crosses that axis at an angle whose sine is at least min_sine and its path in the box runs
    at least max(min_depth, share x the box's extent) [m] along the other axis (a ray nearly
    parallel to a face crosses the box where the heading is a little off: not evidence).  A
    beam that `returned` (R,) bool, its free length ending `margin` [m] before the return, from
    within the box grown by margin hit the object (a corner seen at a grazing angle): ignored."""
    low, high = np.array(low, float), np.array(high, float)
    origins, directions = np.asarray(origins, float), np.asarray(directions, float)
    free = np.asarray(free, float)
    keep = np.all(np.isfinite(origins), axis=1) & np.all(np.isfinite(directions), axis=1) \
        & ~np.isnan(free) & (free > 0)
    if returned is not None:  # a beam that returned from the box (grown by margin) hit it
        with np.errstate(invalid='ignore'):
            ends = origins + directions * (free + margin)[:, None]
            keep &= ~(np.asarray(returned, bool)
                      & np.all((ends >= low - margin) & (ends <= high + margin), axis=1))
    origins, directions, free = origins[keep], directions[keep], free[keep]
    for _ in range(8):  # every cut can only shrink the box; a few passes settle it
        spans = _spans(origins, directions, low, high)
        enter, leave = _box(spans)
        enter, leave = np.maximum(enter, 0.0), np.minimum(leave, free)
        passing = np.flatnonzero(leave - enter > 0)
        if not passing.size:
            break
        changed = False
        for ray in passing:
            best = None
            inside = leave[ray] - enter[ray]
            for k in range(2):
                other = 1 - k
                if abs(directions[ray, other]) < min_sine or abs(
                        directions[ray, other]) * inside < max(
                        min_depth, share * (high[other] - low[other])):
                    continue  # grazing along axis k (a small heading error): no evidence
                s0, s1 = spans[other][0][ray], spans[other][1][ray]
                t0, t1 = max(s0, 0.0), min(s1, free[ray])
                if t0 >= t1:
                    continue
                ends = origins[ray, k] + directions[ray, k] * np.array([t0, t1])
                for side, limit in ((1, ends.min()), (0, ends.max())):
                    if side == 1 and seen_high[k] <= limit < high[k]:
                        cut = (high[k] - limit, k, side, limit)
                    elif side == 0 and low[k] < limit <= seen_low[k]:
                        cut = (limit - low[k], k, side, limit)
                    else:
                        continue
                    if best is None or cut[0] < best[0]:
                        best = cut
            if best is not None:
                _, k, side, limit = best
                (high if side else low)[k] = limit
                changed = True
                spans = _spans(origins, directions, low, high)
        if not changed:
            break
    return low, high


FACE_POINTS, FACE_ALIGNMENT = 5, np.cos(np.deg2rad(10.0))
FACE_NOISE_FLOOR, FACE_SLACK_STDS = 0.2, 1.0
"""face_end_limit: the face's line is fitted to at most FACE_POINTS returns next to the
cluster end, every step between them within 20 deg of it and 0.5-2 times the one before
(clustering.FACE_SLOPE and FACE_STEPS, as for a face going on: the spacing along one face
changes slowly; a corner among them is no line), and it must run within 10 deg of one of the
box's axes (a run over a corner, the rear face's last returns and the side's first, is no face
of the box); the std of the returns about it is taken as at least FACE_NOISE_FLOOR x the
tolerance."""


def face_end_limit(face: np.ndarray, origin: np.ndarray, direction: np.ndarray, free: float,
                   tolerance: float) -> Optional[tuple[int, int, float]]:
    """Where a face seen up to a cluster end must end, from the next beam: (axis k, side
    (1: the high end, 0: the low), limit [m]) or None when that beam tells nothing.

    face (m, 2), m >= 3: the cluster's returns next to its end, the end's last (object frame);
    the beam past the end: origin (2,), unit direction (2,), free length [m] (ending before its
    return).  The face's line is fitted (least squares) to the longest run of these returns,
    from the end, that lies within `tolerance` [m] of it with every step within 20 deg of it
    and 0.5-2 times the step before (at least 3 returns); the beam crosses that
    line at c and passes it free by more than `tolerance` across the line (free > t_c +
    tolerance / sin(angle to the line): a return from the face itself, noisy, can lie a little
    beyond its line): the face, running along axis k, ends before c, plus 1 std of c along
    the line (the fitted line's std across it at c, from the returns' residuals, over the sine
    of the beam's angle to it).  Also None when the run is shorter than 2 tolerances (returns
    a centimetre apart on a near face give no direction) or c lies farther beyond its end
    than the run is long.
    A beam at a grazing angle to the face still bounds it, and from the returns' own line,
    not the box's heading (a heading a degree off moves a crossing at 10 deg by 0.1 m per
    metre of width).  None: fewer than 3 collinear returns, the line more than 10 deg from
    both axes, the beam parallel to it, crossing it behind the origin, or stopped before it."""
    face = np.asarray(face, float)
    direction = np.asarray(direction, float)
    if len(face) < 3 or not np.all(np.isfinite(direction)) or np.isnan(free):
        return None
    xs, ys = face[-FACE_POINTS:, 0].tolist(), face[-FACE_POINTS:, 1].tolist()
    for count in range(len(xs), 2, -1):  # the longest run that is a line
        fit = _line_run(xs[-count:], ys[-count:], tolerance)
        if fit is not None:
            break
    else:
        return None
    centre, along, normal, residuals = (np.array(value) for value in fit)
    run = face[-count:]
    spread = (run - centre) @ along
    extent = float(np.ptp(spread))
    if extent < 2 * tolerance:
        return None  # too short a run to give a direction
    noise = max(float(np.sqrt(residuals @ residuals / (count - 2))), FACE_NOISE_FLOOR * tolerance)
    k = int(np.argmax(np.abs(along)))
    if abs(along[k]) < FACE_ALIGNMENT:
        return None
    towards = float(direction @ normal)
    if abs(towards) < 1e-9:
        return None
    crossing = float((centre - origin) @ normal) / towards
    if crossing <= 0 or free <= crossing + tolerance / abs(towards):
        return None
    point = origin + crossing * direction
    side = int(face[-1, k] > centre[k])
    offset = float((point - centre) @ along)  # the line's std across at c, over the sine
    if abs(offset) - extent / 2 > extent:
        return None  # c farther beyond the run than it is long
    slack = FACE_SLACK_STDS * noise * np.sqrt(1.0 / len(spread) + offset ** 2 / (spread @ spread)) \
        / abs(towards)
    return k, side, float(point[k] + (slack if side else -slack) * abs(along[k]))


def _line_run(xs: list, ys: list, tolerance: float) -> Optional[tuple]:
    """face_end_limit's test of one run of returns (3-5, in plain floats: numpy's overhead on
    arrays this small was most of a scan's face tests): (centre, unit direction, unit normal,
    residuals across) of its least-squares line, or None when a return lies farther than
    `tolerance` [m] from that line, a step turns more than FACE_SLOPE from it or a step is not
    FACE_STEPS times the one before.  The direction is the scatter matrix's major axis, at
    0.5 atan2(2 s_xy, s_xx - s_yy) (the first right singular vector of the centred run)."""
    n = len(xs)
    cx, cy = sum(xs) / n, sum(ys) / n
    dx, dy = [x - cx for x in xs], [y - cy for y in ys]
    angle = 0.5 * math.atan2(2.0 * sum(a * b for a, b in zip(dx, dy)),
                             sum(a * a for a in dx) - sum(b * b for b in dy))
    ax, ay = math.cos(angle), math.sin(angle)
    nx, ny = -ay, ax
    residuals = [a * nx + b * ny for a, b in zip(dx, dy)]
    if max(abs(r) for r in residuals) > tolerance:
        return None
    previous = None
    for i in range(n - 1):
        sx, sy = xs[i + 1] - xs[i], ys[i + 1] - ys[i]
        if abs(sx * nx + sy * ny) > FACE_SLOPE * abs(sx * ax + sy * ay):
            return None
        length = math.hypot(sx, sy)
        if previous is not None and not (
                FACE_STEPS[0] <= length / max(previous, 1e-12) <= FACE_STEPS[1]):
            return None
        previous = length
    return (cx, cy), (ax, ay), (nx, ny), residuals
