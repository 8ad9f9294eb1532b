"""Trajectories of simulated LiDAR scenes (objects and the sensor): pose (x, y, yaw) at any time,
vectorised over times, and the true state with the velocities by central differences.

* `Pieces`: constant speed and turn rate (CTRV) piece after piece from a start pose,
  x' = v cos(yaw), y' = v sin(yaw), yaw' = w; before the first piece and after the last the object
  keeps its end pose's motion (the last piece continues).
* `TrackLane`: a point driving along a stadium-shaped closed track (two straights joined by two
  half circles, counter-clockwise) at a lateral offset that may change with time (lane changes);
  the heading follows the velocity (a car does not slide).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

DIFFERENCE_STEP_S = 1e-4
"""Step [s] of the central differences of the true velocities and yaw rates."""


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return -((-np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi)


class Motion:
    """A trajectory: poses(t) (T, 3) for times (T,) [s]; state(t) (T, 6) = x, y, yaw, vx, vy,
    yaw rate."""

    def poses(self, t: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def state(self, t: np.ndarray) -> np.ndarray:
        """(T, 6): pose and its central-difference derivatives (velocity of the centre)."""
        t = np.atleast_1d(np.asarray(t, float))
        h = DIFFERENCE_STEP_S
        before, now, after = self.poses(t - h), self.poses(t), self.poses(t + h)
        rates = (after - before) / (2 * h)
        rates[:, 2] = wrap(after[:, 2] - before[:, 2]) / (2 * h)
        return np.column_stack([now, rates])


@dataclass(frozen=True)
class Pieces(Motion):
    """CTRV pieces (module docstring): start pose (3,), pieces ((duration [s], speed [m/s],
    yaw rate [rad/s]), ...) from time 0; negative times run the first piece backwards."""

    start: tuple
    pieces: tuple

    def poses(self, t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        starts = [np.asarray(self.start, float)]
        begin = [0.0]
        for duration, speed, rate in self.pieces[:-1]:
            starts.append(_ctrv(starts[-1][None], np.array([duration]), speed, rate)[0])
            begin.append(begin[-1] + duration)
        index = np.clip(np.searchsorted(begin, t, side='right') - 1, 0, len(begin) - 1)
        result = np.empty((len(t), 3))
        for k in np.unique(index):
            chosen = index == k
            _, speed, rate = self.pieces[k]
            result[chosen] = _ctrv(np.repeat(starts[k][None], chosen.sum(), 0),
                                   t[chosen] - begin[k], speed, rate)
        return result


def ramp(before: tuple, speed: float, target: float, accel: float, curvature: float = 0.0,
         step: float = 0.05) -> tuple:
    """Pieces (Pieces.pieces): `before`, then the speed going from `speed` to `target` [m/s]
    at |accel| [m/s^2] in steps of `step` [s], then on at target: a car braking to a stop or
    pulling away; the yaw rate is curvature [1/m] x speed throughout the ramp and after.
    Raises ValueError for accel 0 with speed != target (no ramp reaches the target)."""
    if speed != target and accel == 0:
        raise ValueError('ramp: accel must be non-zero to change the speed')
    count = int(np.ceil(abs(target - speed) / (abs(accel) * step))) if speed != target else 0
    speeds = np.clip(speed + np.sign(target - speed) * abs(accel) * step
                     * np.arange(1, count + 1), min(speed, target), max(speed, target))
    return tuple(before) + tuple((step, float(v), float(curvature * v)) for v in speeds) \
        + ((1e6, float(target), float(curvature * target)),)


def _ctrv(start: np.ndarray, dt: np.ndarray, speed: float, rate: float) -> np.ndarray:
    """Poses (T, 3) after dt (T,) [s] from start poses (T, 3) at constant speed and turn rate."""
    yaw = start[:, 2] + rate * dt
    if abs(rate) < 1e-9:
        dx, dy = speed * dt * np.cos(start[:, 2]), speed * dt * np.sin(start[:, 2])
    else:
        dx = speed / rate * (np.sin(yaw) - np.sin(start[:, 2]))
        dy = speed / rate * (np.cos(start[:, 2]) - np.cos(yaw))
    return np.column_stack([start[:, 0] + dx, start[:, 1] + dy, wrap(yaw)])


@dataclass(frozen=True)
class Stadium:
    """A closed track's centre line: straights of `straight` [m] along x at y = -radius (driven
    +x) and y = +radius (driven -x), joined by half circles of `radius` [m] around
    (+-straight / 2, 0); counter-clockwise; arc length s from (-straight / 2, -radius)."""

    straight: float
    radius: float

    @property
    def perimeter(self) -> float:
        return 2 * self.straight + 2 * np.pi * self.radius

    def point(self, s: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """Points (T, 2) at arc length s (T,) and lateral offset (T,) [m, left of the driving
        direction: towards the infield]."""
        s = np.asarray(s, float) % self.perimeter
        offset = np.broadcast_to(np.asarray(offset, float), s.shape)
        a, r = self.straight, self.radius
        result = np.empty((len(s), 2))
        # piece 1: bottom straight, 2: right arc, 3: top straight, 4: left arc
        bounds = np.cumsum([a, np.pi * r, a, np.pi * r])
        piece = np.searchsorted(bounds, s, side='right')
        u = s - np.concatenate([[0.0], bounds])[np.minimum(piece, 4)]
        for k, (centre, base_angle, sign) in enumerate((
                (None, None, None), ((a / 2, 0.0), -np.pi / 2, 1.0), (None, None, None),
                ((-a / 2, 0.0), np.pi / 2, 1.0))):
            chosen = piece == k
            if k == 0:
                result[chosen] = np.column_stack([-a / 2 + u[chosen], -r + offset[chosen]])
            elif k == 2:
                result[chosen] = np.column_stack([a / 2 - u[chosen], r - offset[chosen]])
            else:
                angle = base_angle + u[chosen] / r
                radius = r - offset[chosen]
                result[chosen] = np.column_stack([centre[0] + radius * np.cos(angle),
                                                  centre[1] + radius * np.sin(angle)])
        return result

    def walls(self, half_width: float, step_deg: float = 10.0) -> np.ndarray:
        """Segments (S, 2, 2) of the inner and outer walls at +-half_width from the centre
        line (arcs as chords every step_deg)."""
        count = int(round(180 / step_deg))
        segments = []
        for offset in (half_width, -half_width):
            samples = np.concatenate([
                np.linspace(0, self.straight, 2),
                self.straight + np.linspace(0, np.pi * self.radius, count + 1)[1:],
                self.straight + np.pi * self.radius + np.linspace(0, self.straight, 2)[1:],
                2 * self.straight + np.pi * self.radius
                + np.linspace(0, np.pi * self.radius, count + 1)[1:]])
            points = self.point(samples, np.full(len(samples), offset))
            points[-1] = points[0]
            segments.append(np.stack([points[:-1], points[1:]], axis=1))
        return np.concatenate(segments)


@dataclass(frozen=True)
class TrackLane(Motion):
    """Driving along a Stadium: arc length s0 + speed t [m], lateral offset lane(t) [m]."""

    track: Stadium
    s0: float
    speed: float
    lane: Callable[[np.ndarray], np.ndarray]

    def poses(self, t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        h = DIFFERENCE_STEP_S
        s = self.s0 + self.speed * t
        here = self.track.point(s, self.lane(t))
        ahead = self.track.point(s + self.speed * h, self.lane(t + h))
        yaw = np.arctan2(ahead[:, 1] - here[:, 1], ahead[:, 0] - here[:, 0])
        return np.column_stack([here, yaw])


def lane_change(start: float, end: float, begin_s: float, duration_s: float):
    """lane(t): `start` until begin_s, then a smoothstep to `end` over duration_s [s]."""
    def lane(t: np.ndarray) -> np.ndarray:
        u = np.clip((np.asarray(t, float) - begin_s) / duration_s, 0.0, 1.0)
        return start + (end - start) * (3 * u ** 2 - 2 * u ** 3)
    return lane
