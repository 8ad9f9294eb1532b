"""The LiDAR object tracker's parameters: defaults, ranges, meanings (shared by the core, the node
and the evaluation tool; no ROS)."""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

from ..associators import REGISTRY
from ..errors import InvalidInputError
from ..parameters import ParameterSpec
from .alignment import TRANSFORMS
from .fine import FINE_METHODS, JNIS_COORDINATES

SIZE_CLASSES = {'car': (4.5, 1.8), 'f1tenth': (0.55, 0.30), 'pedestrian': (0.6, 0.6)}
"""size_class -> (prior length, prior width) [m]: a full-size car, a 1/10-scale F1Tenth car, a
person (shoulders and stride)."""
PRESETS = {
    'car': {},
    'f1tenth': {'size_class': 'f1tenth', 'fine': 'nearest', 'nearest_cutoff': 0.1,
                'boundary_spacing': 0.05, 'max_size_ratio': 2.0,
                'calm_yaw_accel_sigma': 0.5, 'calm_lateral_accel_sigma': 1.0, 'slip_sigma': 0.3},
    'pedestrian': {'size_class': 'pedestrian'},
}
"""Parameter sets per setting (F1Tenth's also in config/lidar_f1tenth.yaml).  F1Tenth racing:
pairs points with the nearest boundary point within 0.1 m (JCBB takes most of a 25 ms scan
period on this 2-core machine; nearest is about 2-3x faster here) on a boundary sampled every
5 cm (a 0.55 m car), and takes anything longer than 1.1 m for the track's walls; an IMM mixes
a calm motion model (white angular acceleration 0.5 rad/s^2/sqrt(Hz), white acceleration
across the heading 1 m/s^2/sqrt(Hz)) with the agile default (4 and 4): a small car far away
shows a few returns of one face, whose heading scatters by 10-20 deg from scan to scan, and
the agile model follows that scatter (docs/lidar.md, "Two motion models"; at 10 Hz the calm
velocity averages them over more scans: "Twenty-seventh round"); heading and velocity are
tied (slip_sigma 0.3 m/s: at 10 Hz the returns of one face turn a small car's box by 5-15 deg
a scan, its velocity at speed tells it better; "Twenty-sixth round").  Pedestrians: the size
class only (docs/lidar.md, "Pedestrians": nothing tuned for them yet)."""
COARSE_METHODS = tuple(name for name, a in REGISTRY.items() if 'point_map' in a.models)


@dataclass(frozen=True)
class Choice:
    """A string parameter with its valid values."""

    name: str
    default: str
    description: str
    choices: tuple[str, ...]

    def check(self, value: Any) -> str:
        """The value, or InvalidInputError listing the valid ones."""
        if value not in self.choices:
            raise InvalidInputError(f'{self.name}: {value!r} is not one of '
                                    f'{", ".join(self.choices)}')
        return value

    def range_text(self) -> str:
        """The valid values for docs."""
        return ', '.join(self.choices)


def _float(name, default, description, low=0.0, high=None, low_open=True):
    return ParameterSpec(name, default, description, low=low, high=high, low_open=low_open)


def _int(name, default, description, low, high):
    return ParameterSpec(name, default, description, kind=int, low=low, high=high)


PARAMETERS = (
    _float('cluster_gap', 0.3, 'consecutive scan points closer than this [m] form one cluster '
           '(farther ones too when a third continues their straight line at an even spacing: '
           'a face seen at a grazing angle)'),
    _int('min_cluster_points', 3, 'clusters with fewer points are ignored', 1, 100000),
    _float('edge_jump', 0.3, 'a cluster end is an object edge when the next return is missing '
           'or farther by more than this [m]'),
    Choice('coarse', 'gnn', 'coarse association of clusters with tracks (an associator of this '
           'package on point_map)', COARSE_METHODS),
    _float('coarse_sigma', 0.5, 'std of a cluster centroid about its predicted position [m]'),
    Choice('fine', 'jcbb_points', "fine association of scan points with boundary points "
           "(nearest: the seed's rejected nearest pairing with nearest_cutoff)", FINE_METHODS),
    Choice('jnis', 'cartesian', 'coordinates of the fine jNIS: cartesian (x, y) or polar '
           '(range, bearing)', JNIS_COORDINATES),
    Choice('transform', 'point_to_line', 'correction from the pairs: point_to_line (face lines '
           "+ edge corners), kabsch or ransac (the seed's)", TRANSFORMS),
    _float('point_sigma', 0.05, 'std of a scan point and of a boundary point [m]'),
    _float('bearing_sigma', 0.01, 'polar jnis: bearing std [rad]'),
    _float('nearest_cutoff', 0.3, 'fine nearest: largest pair distance [m]'),
    ParameterSpec('gate_probability', 0.99, 'chi-square gate of the coarse and fine '
                  "associations and of a track's measurement (with two motion models: taken if "
                  "either model's gate takes it, so a little more often than this)",
                  low=0.0, high=1.0, low_open=True, high_open=True),
    _float('time_budget_ms', 0.0, 'JCBB search time budget per track and scan [ms] (0: none; '
           'results then depend on the machine)', low_open=False),
    _int('max_nodes', 500, 'JCBB search budget per track and scan in search nodes (0: none)',
         0, 10 ** 9),
    _int('max_match_points', 20, 'scan points of a track matched per scan (evenly spaced)', 3,
         100000),
    _int('min_pairs', 5, 'a track is corrected only from at least this many point pairs', 3,
         100000),
    _float('boundary_spacing', 0.1, 'spacing of the boundary points along the rectangle [m]'),
    _int('max_boundary_points', 50, 'at most about this many boundary points (the spacing '
         'widens for large objects)', 4, 100000),
    Choice('size_class', 'car', 'assumed size of an object until it is seen (length x width): '
           'car 4.5 x 1.8 m, f1tenth 0.55 x 0.30 m, pedestrian 0.6 x 0.6 m, custom: prior_length '
           'x prior_width', tuple(SIZE_CLASSES) + ('custom',)),
    _float('prior_length', 4.5, 'size_class custom: assumed length of an object whose length is '
           'not seen [m]'),
    _float('prior_width', 1.8, 'size_class custom: assumed width of an object whose width is not '
           'seen [m]'),
    _float('max_size_ratio', 4.0, 'a cluster or track longer than this times the prior length '
           'is background (walls), not tracked; no two returns farther apart are joined as one '
           'face'),
    _float('ransac_threshold', 0.1, 'transform ransac: inlier distance [m]'),
    _float('accel_sigma', 4.0, 'process noise: white acceleration [m/s^2/sqrt(Hz)]'),
    _float('yaw_accel_sigma', 4.0, 'process noise: white angular acceleration '
           '[rad/s^2/sqrt(Hz)]'),
    _float('calm_yaw_accel_sigma', 0.0, 'a second motion model, calm (driving straight), with '
           'this white angular acceleration [rad/s^2/sqrt(Hz)], mixed with the yaw_accel_sigma '
           'one by an IMM (core/tracking/interacting_models.py; tracks started from then on); '
           '0: one model (the f1tenth preset: 0.5)', low_open=False),
    _float('calm_lateral_accel_sigma', 0.0, 'the calm motion model (calm_yaw_accel_sigma; '
           'without it this has no effect): its white acceleration across the box\'s heading '
           '[m/s^2/sqrt(Hz)] (along it: accel_sigma; a car driving straight speeds up and '
           'brakes, it does not slide sideways; only once the velocity has settled the '
           'heading, before that accel_sigma); 0: accel_sigma (the f1tenth preset: 1.0)',
           low_open=False),
    _float('model_switch_time', 2.0, 'IMM: mean time an object keeps to one motion model [s]'),
    _float('slip_sigma', 0.0, 'a settled track is corrected with the pseudo-measurement that '
           'its velocity has no component across its heading (a car does not drive sideways), '
           'with this std [m/s]: heading, velocity and yaw rate move towards each other by '
           'their variances; 0: off (the f1tenth preset: 0.3; docs/lidar.md "Twenty-sixth '
           'round")', low_open=False),
    ParameterSpec('velocity_measurement', False, "the fictitious measurement includes the "
                  "velocity and yaw rate (the seed's); false: only x, y, yaw (the filter "
                  'differentiates)', kind=bool),
    _float('position_sigma', 0.02, 'measurement noise floor on x, y [m]'),
    _float('yaw_sigma', 0.01, 'measurement noise floor on yaw [rad]'),
    _float('velocity_sigma', 0.5, 'measurement noise floor on vx, vy [m/s]'),
    _float('yaw_rate_sigma', 0.5, 'measurement noise floor on the yaw rate [rad/s]'),
    _float('max_age', 1.0, 'a track not updated for longer than this is dropped [s]',
           low_open=False),
    _float('max_hidden_age', 3.0, 'a confirmed track hidden behind something nearer (at least '
           '90 % of the beams towards its predicted rectangle return before it, or none points '
           'at it) or predicted too vaguely to be looked for (position std above its length) is '
           'kept up to this long without update instead of max_age [s] (at least max_age '
           'counts)', low_open=False),
    _int('min_hits', 3, 'a track is reported once updated on this many scans', 1, 100000),
)
BY_NAME = {p.name: p for p in PARAMETERS}


@dataclass(frozen=True)
class TrackerConfig:
    """Checked values of PARAMETERS (field names = parameter names)."""

    cluster_gap: float = 0.3
    min_cluster_points: int = 3
    edge_jump: float = 0.3
    coarse: str = 'gnn'
    coarse_sigma: float = 0.5
    fine: str = 'jcbb_points'
    jnis: str = 'cartesian'
    transform: str = 'point_to_line'
    point_sigma: float = 0.05
    bearing_sigma: float = 0.01
    nearest_cutoff: float = 0.3
    gate_probability: float = 0.99
    time_budget_ms: float = 0.0
    max_nodes: int = 500
    max_match_points: int = 20
    min_pairs: int = 5
    boundary_spacing: float = 0.1
    max_boundary_points: int = 50
    size_class: str = 'car'
    prior_length: float = 4.5
    prior_width: float = 1.8
    max_size_ratio: float = 4.0
    ransac_threshold: float = 0.1
    accel_sigma: float = 4.0
    yaw_accel_sigma: float = 4.0
    calm_yaw_accel_sigma: float = 0.0
    calm_lateral_accel_sigma: float = 0.0
    model_switch_time: float = 2.0
    slip_sigma: float = 0.0
    velocity_measurement: bool = False
    position_sigma: float = 0.02
    yaw_sigma: float = 0.01
    velocity_sigma: float = 0.5
    yaw_rate_sigma: float = 0.5
    max_age: float = 1.0
    max_hidden_age: float = 3.0
    min_hits: int = 3

    def __post_init__(self) -> None:
        for field in fields(self):
            object.__setattr__(self, field.name,
                               BY_NAME[field.name].check(getattr(self, field.name)))

    def with_values(self, **values: Any) -> 'TrackerConfig':
        """A checked copy with `values` replaced (InvalidInputError names a bad one)."""
        unknown = sorted(set(values) - set(BY_NAME))
        if unknown:
            raise InvalidInputError(f'{unknown[0]}: not a LiDAR tracker parameter')
        return replace(self, **values)

    def priors(self) -> tuple[float, float]:
        """(length, width) [m] assumed until seen: the size class's, or prior_length /
        prior_width for custom."""
        if self.size_class == 'custom':
            return self.prior_length, self.prior_width
        return SIZE_CLASSES[self.size_class]

    def measurement_sigmas(self) -> tuple[float, ...]:
        """Floor of R's standard deviations for [x, y, yaw, vx, vy, yaw_rate]."""
        return (self.position_sigma, self.position_sigma, self.yaw_sigma, self.velocity_sigma,
                self.velocity_sigma, self.yaw_rate_sigma)

