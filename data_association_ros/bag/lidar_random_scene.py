"""LiDAR scenes from a seed (da_make_bags; tests and benchmarks generate them in memory).

A scene: rigid rectangular objects on trajectories (bag.lidar_motion), a sensor (static at the
origin, or moving with odometry), walls, and a 2-D LiDAR that turns while it scans: beam k of the
scan stamped t0 is taken at t0 + k time_increment, from the sensor pose and against the objects
at that time (ray casting, core.lidar.raycast), Gaussian range noise.

* `random_scene(seed, size, moving)`: 1-5 objects of the size class (`car`: 3.8-5.2 m x
  1.6-2.0 m, 30 m LiDAR; `f1tenth`: 0.50-0.60 m x 0.27-0.33 m, 10 m LiDAR with distances / 5
  and speeds / 2 of the car class) at random bearings and distances from the sensor, headings
  uniform over all directions, speeds 1.5-10 m/s (car class), a straight piece then a turn
  (|yaw rate| up to 0.4 rad/s, up to 1.2 rad/s for f1tenth), objects that start outside the
  field of view or range and enter, others that leave; a corridor of two walls on half of the
  seeds.  Objects never overlap each other, the sensor or a wall (rejection sampling on 0.05 s
  steps with their circumscribed circles), so occlusions come from objects passing in front of
  others.  The moving sensor drives straight at 3-8 m/s (0.6-1.6 m/s for f1tenth) along the
  corridor.  `pedestrian`: walkers 0.25-0.35 m (front to back) x 0.45-0.60 m (shoulders), the
  car class's 30 m LiDAR, distances / 2 (2.5-14 m), speeds x 0.18 (0.27-1.8 m/s), turning up
  to 1 rad/s, a corridor 8-14 m wide, the moving sensor at 0.54-1.44 m/s (a robot among
  people).
* `race_scene(seed)`: F1Tenth racing (seed 003's setting): a stadium track (14 m straights, 4 m
  radius, walls 1 m either side of the centre line), the ego car at 4-5.5 m/s in the inner lane
  (+0.4 m), opponent 1 ahead of it in the same lane, a bit faster, opponent 2 from behind the ego
  (the LiDAR's blind sector) in the outer lane (-0.4 m), 1.5-2.5 m/s faster: it overtakes the
  ego and then opponent 1.  Cars 0.50-0.60 m x 0.27-0.33 m; Hokuyo-like 40 Hz, 270 deg,
  0.25 deg, 10 m, range noise 0.01 m.  Seed 0 is the committed bag `lidar_f1tenth_race`.

Messages: /scan (LaserScan, frame `laser`, stamped at its first beam, time_increment set, logged
when its last beam is taken), /odometry (nav_msgs/Odometry of the sensor in `odom`, child frame
`laser`, 80 Hz; moving sensor only; exact: odom is the scene's world frame) and
/ground_truth/objects (PointCloud2 stamped as its scan: id, x, y, yaw, vx, vy, yaw_rate, length,
width, visible = beams that hit the object in that scan; frame `odom` with a moving sensor, else
`laser` = the world frame).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterator, NamedTuple, Optional

import numpy as np
from sensor_msgs.msg import LaserScan

from msg_adapters import array_to_cloud, odometry_message

from ..core.lidar import raycast
from .lidar_motion import Motion, Pieces, Stadium, TrackLane, lane_change
from .topics import header

SCAN, ODOMETRY, OBJECTS = '/scan', '/odometry', '/ground_truth/objects'
OBJECT_DTYPE = np.dtype([('id', '<i4'), ('x', '<f4'), ('y', '<f4'), ('yaw', '<f4'),
                         ('vx', '<f4'), ('vy', '<f4'), ('yaw_rate', '<f4'), ('length', '<f4'),
                         ('width', '<f4'), ('visible', '<i4')])
START_NS = 1_000_000_000
ODOMETRY_PER_SCAN = 2
SIZES = ('car', 'f1tenth', 'pedestrian')


@dataclass(frozen=True)
class Lidar:
    """A 2-D LiDAR: scans per second, first beam angle and step [rad], beams, range [m], range
    noise std [m], beams per full turn (time_increment = 1 / (rate * beams_per_turn))."""

    rate_hz: float = 40.0
    angle_min: float = float(np.deg2rad(-135.0))
    angle_increment: float = float(np.deg2rad(0.25))
    beams: int = 1081
    max_range: float = 30.0
    range_sigma: float = 0.02
    beams_per_turn: int = 1440

    @property
    def time_increment(self) -> float:
        return 1.0 / (self.rate_hz * self.beams_per_turn)


CAR_LIDAR = Lidar()
F1TENTH_LIDAR = Lidar(max_range=10.0, range_sigma=0.01)
OTHER_LIDARS = {
    '360_10hz': Lidar(10.0, float(-np.pi), float(np.deg2rad(0.2)), 1800, 60.0, 0.03, 1800),
    '270_25hz': Lidar(25.0, float(np.deg2rad(-135.0)), float(np.deg2rad(0.5)), 541, 20.0, 0.03,
                      720),
    '360_10hz_coarse': Lidar(10.0, float(-np.pi), float(np.deg2rad(0.5)), 720, 12.0, 0.02, 720),
    '270_40hz_coarse': Lidar(40.0, float(np.deg2rad(-135.0)), float(np.deg2rad(0.5)), 541, 10.0,
                             0.01, 720),
}
"""LiDARs other than the scenes' own (da_lidar_eval --scenes ... --lidar NAME): a full turn at
10 Hz, 0.2 deg, 60 m, 3 cm (a spinning LiDAR's ring, or a 360 deg scanner); 270 deg at 25 Hz,
0.5 deg, 20 m, 3 cm (a safety-scanner class); a full turn at 10 Hz, 0.5 deg, 12 m, 2 cm (a
low-cost 360 deg scanner); 270 deg at 40 Hz, 0.5 deg, 10 m, 1 cm.  The scenes' own: CAR_LIDAR
(40 Hz, 270 deg, 0.25 deg, 30 m, 2 cm) and F1TENTH_LIDAR (the same to 10 m, 1 cm)."""


@dataclass(frozen=True)
class SceneObject:
    """A rigid rectangle: id, length, width [m], trajectory of its centre."""

    id: int
    length: float
    width: float
    motion: Motion


@dataclass
class Scene:
    """Objects, sensor trajectory (None: static at the origin, no odometry), walls (W, 2, 2),
    LiDAR, duration [s], noise seed."""

    objects: list
    sensor: Optional[Motion]
    walls: np.ndarray
    lidar: Lidar
    duration: float
    seed: int
    size: str = 'car'
    notes: dict = field(default_factory=dict)

    @property
    def frame(self) -> str:
        """The frame of the truth (and of the tracks): odom with a moving sensor."""
        return 'odom' if self.sensor is not None else 'laser'

    def sensor_poses(self, t: np.ndarray) -> np.ndarray:
        """Sensor poses (T, 3) in the world (= odom) frame."""
        if self.sensor is None:
            return np.zeros((len(np.atleast_1d(t)), 3))
        return self.sensor.poses(t)

    def cast(self, t0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                       np.ndarray]:
        """The noise-free scan whose first beam is at t0, per beam (R): its time [s], origin
        (R, 2) and angle [rad] in the world frame, range [m] (inf: no return within max_range)
        and the index of the object it hit in `objects` (-1: a wall or nothing)."""
        lidar = self.lidar
        k = np.arange(lidar.beams)
        times = t0 + k * lidar.time_increment
        pose = self.sensor_poses(times)
        angles = pose[:, 2] + lidar.angle_min + k * lidar.angle_increment
        pieces = [np.broadcast_to(self.walls[None], (lidar.beams,) + self.walls.shape)]
        for item in self.objects:
            states = item.motion.poses(times)
            pieces.append(_rectangles(states, item.length, item.width))
        segments = np.concatenate(pieces, axis=1)
        ranges, hit = raycast(pose[:, :2], angles, segments, lidar.max_range)
        owner = np.concatenate([np.full(len(self.walls), -1)]
                               + [np.full(4, i) for i in range(len(self.objects))])
        return times, pose[:, :2], angles, ranges, np.where(hit >= 0, owner[np.maximum(hit, 0)],
                                                            -1)

    def scan_ranges(self, t0: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(noisy ranges (R,), hits per object (O,)) of the scan whose first beam is at t0."""
        _, _, _, ranges, hit_owner = self.cast(t0)
        hits = np.bincount(hit_owner[hit_owner >= 0], minlength=len(self.objects))
        return ranges + rng.normal(0.0, self.lidar.range_sigma, self.lidar.beams), hits

    def seen_lengths(self, index: int) -> np.ndarray:
        """Per scan (duration x rate_hz), the extent [m] along objects[index]'s own axis of the
        beams that hit it in the noise-free scan (0 with fewer than 2 such beams): a lower bound
        on its length that the returns give, equal to the length when both ends were hit."""
        item = self.objects[index]
        count = int(round(self.duration * self.lidar.rate_hz))
        out = np.zeros(count)
        for k in range(count):
            times, origins, angles, ranges, owner = self.cast(k / self.lidar.rate_hz)
            mine = owner == index
            if mine.sum() < 2:
                continue
            points = origins[mine] + ranges[mine, None] * np.c_[np.cos(angles[mine]),
                                                                np.sin(angles[mine])]
            states = item.motion.poses(times[mine])
            along = np.cos(states[:, 2]) * (points[:, 0] - states[:, 0]) \
                + np.sin(states[:, 2]) * (points[:, 1] - states[:, 1])
            out[k] = np.ptp(along)
        return out

    def truth(self, t0: float, hits: np.ndarray) -> np.ndarray:
        """OBJECT_DTYPE rows of every object at t0 (in the truth frame)."""
        rows = np.zeros(len(self.objects), dtype=OBJECT_DTYPE)
        for row, item, count in zip(rows, self.objects, hits):
            state = item.motion.state(np.array([t0]))[0]
            row['id'], row['length'], row['width'], row['visible'] = \
                item.id, item.length, item.width, count
            for name, value in zip(('x', 'y', 'yaw', 'vx', 'vy', 'yaw_rate'), state):
                row[name] = value
        return rows

    def messages(self) -> Iterator[tuple[str, object, int]]:
        """(topic, message, log time ns) of the whole scene, in log-time order."""
        rng = np.random.default_rng(self.seed)
        lidar = self.lidar
        period_ns = int(round(1e9 / lidar.rate_hz))
        sweep_ns = int(round((lidar.beams - 1) * lidar.time_increment * 1e9))
        count = int(round(self.duration * lidar.rate_hz))
        pending = []
        if self.sensor is not None:
            step = period_ns // ODOMETRY_PER_SCAN
            for j in range((count + 1) * ODOMETRY_PER_SCAN):
                time_ns = START_NS + j * step
                pose = self.sensor.poses(np.array([(time_ns - START_NS) * 1e-9]))[0]
                msg = odometry_message(header(time_ns, 'odom'), pose, 1e-6 * np.eye(3),
                                       child_frame='laser')
                pending.append((time_ns, 0, ODOMETRY, msg))
        for k in range(count):
            stamp = START_NS + k * period_ns
            t0 = (stamp - START_NS) * 1e-9
            ranges, hits = self.scan_ranges(t0, rng)
            scan = LaserScan(header=header(stamp, 'laser'), angle_min=float(lidar.angle_min),
                             angle_max=float(lidar.angle_min
                                             + (lidar.beams - 1) * lidar.angle_increment),
                             angle_increment=float(lidar.angle_increment),
                             time_increment=float(lidar.time_increment),
                             scan_time=1.0 / lidar.rate_hz, range_min=0.05,
                             range_max=float(lidar.max_range),
                             ranges=np.where(np.isfinite(ranges), ranges, np.inf).astype(
                                 np.float32).tolist())
            logged = stamp + sweep_ns
            pending.append((logged, 1, SCAN, scan))
            pending.append((logged, 2, OBJECTS,
                            array_to_cloud(self.truth(t0, hits), header(stamp, self.frame))))
        pending.sort(key=lambda item: item[:2])
        for time_ns, _, topic, msg in pending:
            yield topic, msg, time_ns


def _rectangles(states: np.ndarray, length: float, width: float) -> np.ndarray:
    """Sides (T, 4, 2, 2) of a rectangle at poses (T, 3) (core.lidar.rectangle_segments at
    every pose at once)."""
    half = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
    c, s = np.cos(states[:, 2])[:, None], np.sin(states[:, 2])[:, None]
    corners = np.stack([c * half[:, 0] - s * half[:, 1], s * half[:, 0] + c * half[:, 1]],
                       axis=-1) + states[:, None, :2]
    return np.stack([corners, np.roll(corners, -1, axis=1)], axis=2)


def _clear(motion: Motion, radius: float, others: list, walls_y: Optional[float],
           sensor: Optional[Motion], times: np.ndarray) -> bool:
    """No overlap of the circle of `radius` along `motion` with the others' circles
    [(motion, radius)], the walls y = +-walls_y, or the sensor (1 m clearance)."""
    here = motion.poses(times)[:, :2]
    for other, other_radius in others:
        gap = np.hypot(*(here - other.poses(times)[:, :2]).T)
        if np.any(gap < radius + other_radius + 0.2 * radius):
            return False
    if walls_y is not None and np.any(np.abs(here[:, 1]) > walls_y - radius * 1.2):
        return False
    origin = np.zeros((len(times), 2)) if sensor is None else sensor.poses(times)[:, :2]
    return bool(np.all(np.hypot(*(here - origin).T) > radius + 0.25 * radius + 0.5))


class SizeSettings(NamedTuple):
    """random_scene's (module docstring) numbers for one size class."""

    scale: float
    """of the car class's distances and corridor width"""
    lidar: Lidar
    speed_scale: float
    """of the car class's object and sensor speeds"""
    max_turn: float
    """largest |yaw rate| [rad/s]"""
    sensor_divisor: float
    """divides the moving sensor's scaled speed"""
    wall_reach: float
    """of the car class's walls along x (-60 to 120 m)"""
    lengths: tuple
    """length range [m]"""
    widths: tuple
    """width range [m]"""


SIZE_SETTINGS = {
    'car': SizeSettings(1.0, CAR_LIDAR, 1.0, 0.4, 1.0, 1.0, (3.8, 5.2), (1.6, 2.0)),
    'f1tenth': SizeSettings(0.2, F1TENTH_LIDAR, 0.5, 1.2, 2.5, 0.4, (0.50, 0.60), (0.27, 0.33)),
    'pedestrian': SizeSettings(0.5, CAR_LIDAR, 0.18, 1.0, 1.0, 1.0, (0.25, 0.35), (0.45, 0.60)),
}
"""Per size class, random_scene's numbers."""


def straight_then_turn(rng: np.random.Generator, start: tuple, speed: float, straight: float,
                       turn: float, duration: float) -> Motion:
    """random_scene's motion: straight at `speed` [m/s] for `straight` [s], then turning at
    `turn` [rad/s] (draws nothing from rng)."""
    return Pieces(start, ((straight, speed, 0.0), (duration + 1.0, speed, turn)))


def random_scene(seed: int, size: str = 'car', moving: bool = False,
                 duration: float = 4.0, motion: Callable = straight_then_turn) -> Scene:
    """A random scene (module docstring) from `seed`; the same seed gives the same scene.
    `motion(rng, start pose, speed, straight, turn, duration)` makes each object's trajectory
    from its draws (straight_then_turn; benchmarks/lidar_stop_and_go.py passes others)."""
    if size not in SIZES:
        raise ValueError(f'size: {size!r} is not one of {", ".join(SIZES)}')
    rng = np.random.default_rng([seed, SIZES.index(size), int(moving)])
    settings = SIZE_SETTINGS[size]
    scale, speed_scale, lengths, widths = (settings.scale, settings.speed_scale,
                                           settings.lengths, settings.widths)
    sensor = None
    if moving:
        sensor = Pieces((0.0, 0.0, 0.0), ((duration + 1.0, rng.uniform(3.0, 8.0) * speed_scale
                                           / settings.sensor_divisor, 0.0),))
    walls_y = rng.uniform(8.0, 14.0) * scale if rng.random() < 0.5 else None
    walls = np.zeros((0, 2, 2))
    if walls_y is not None:
        reach = settings.wall_reach
        walls = np.array([[[-60.0 * reach, -walls_y], [120.0 * reach, -walls_y]],
                          [[-60.0 * reach, walls_y], [120.0 * reach, walls_y]]])
    times = np.arange(0.0, duration + 1e-9, 0.05)
    count = int(rng.integers(1, 6))
    objects, placed = [], []
    for number in range(1, count + 1):
        for _ in range(200):
            length, width = rng.uniform(*lengths), rng.uniform(*widths)
            distance = rng.uniform(5.0, 28.0) * scale
            bearing = rng.uniform(-np.pi, np.pi)
            heading = rng.uniform(-np.pi, np.pi)
            speed = rng.uniform(1.5, 10.0) * speed_scale
            straight = rng.uniform(0.0, duration)
            turn = rng.uniform(-settings.max_turn, settings.max_turn) * (rng.random() < 0.6)
            start = (distance * np.cos(bearing), distance * np.sin(bearing), heading)
            path = motion(rng, start, speed, straight, turn, duration)
            radius = np.hypot(length, width) / 2
            if _clear(path, radius, placed, walls_y, sensor, times):
                objects.append(SceneObject(number, float(length), float(width), path))
                placed.append((path, radius))
                break
    return Scene(objects, sensor, walls, settings.lidar, duration, seed, size,
                 {'walls_y': walls_y, 'moving': moving})


RACE_TRACK = Stadium(straight=14.0, radius=4.0)
RACE_HALF_WIDTH = 1.0
RACE_LANES = (0.4, -0.4)


def race_scene(seed: int = 0, duration: float = 5.0) -> Scene:
    """The F1Tenth race of the module docstring from `seed`."""
    rng = np.random.default_rng([seed, 3])
    inner, outer = RACE_LANES
    ego_speed = rng.uniform(4.0, 5.5)
    ego = TrackLane(RACE_TRACK, 2.0, ego_speed, lane_change(inner, inner, 0.0, 1.0))
    size = lambda: (float(rng.uniform(0.50, 0.60)), float(rng.uniform(0.27, 0.33)))  # noqa: E731
    ahead = TrackLane(RACE_TRACK, 2.0 + rng.uniform(1.8, 2.8), ego_speed + rng.uniform(0.2, 0.8),
                      lane_change(inner, inner, 0.0, 1.0))
    overtaker = TrackLane(RACE_TRACK, 2.0 - rng.uniform(0.8, 1.5),
                          ego_speed + rng.uniform(1.5, 2.5),
                          lane_change(outer, outer, 0.0, 1.0))
    objects = [SceneObject(1, *size(), ahead), SceneObject(2, *size(), overtaker)]
    return Scene(objects, ego, RACE_TRACK.walls(RACE_HALF_WIDTH), F1TENTH_LIDAR, duration,
                 seed, 'f1tenth', {'track': 'stadium'})


def scene_messages(name: str):
    """Generator factory of a named committed scene bag (make_bags)."""
    scenes = {'lidar_f1tenth_race': lambda: race_scene(0),
              'lidar_urban_random': lambda: random_scene(URBAN_SEED, 'car', moving=True)}
    return lambda: scenes[name]().messages()


URBAN_SEED = 500
"""Seed of the committed random urban scene `lidar_urban_random` (neither a tuning seed, 0-29,
nor a benchmark seed, 100-129)."""


def crossing_scene(seed: int = 0, duration: float = 3.0) -> Scene:
    """Issue 21's report: three full-size cars (4.5 m x 1.8 m) seen by a static LiDAR, one
    turning on a 20 m radius at 8 m/s, one crossing the view at 90 deg to the sensor's x axis
    (from y = -12 m at x = 15 m, 8 m/s), one oncoming (from (28, 3) at 8 m/s)."""
    objects = [
        SceneObject(1, 4.5, 1.8, Pieces((6.0, -8.0, 0.0), ((duration + 1.0, 8.0, 0.4),))),
        SceneObject(2, 4.5, 1.8, Pieces((15.0, -12.0, np.pi / 2), ((duration + 1.0, 8.0, 0.0),))),
        SceneObject(3, 4.5, 1.8, Pieces((28.0, 3.0, np.pi), ((duration + 1.0, 8.0, 0.0),))),
    ]
    return Scene(objects, None, np.zeros((0, 2, 2)), CAR_LIDAR, duration, seed, 'car')


KINDS = {
    'car_static': lambda seed: random_scene(seed, 'car', False),
    'car_moving': lambda seed: random_scene(seed, 'car', True),
    'f1tenth_static': lambda seed: random_scene(seed, 'f1tenth', False),
    'f1tenth_moving': lambda seed: random_scene(seed, 'f1tenth', True),
    'pedestrian_static': lambda seed: random_scene(seed, 'pedestrian', False),
    'pedestrian_moving': lambda seed: random_scene(seed, 'pedestrian', True),
    'race': race_scene,
    'crossing': crossing_scene,
}
"""Scene kind -> scene of a seed (da_lidar_eval --scenes)."""
