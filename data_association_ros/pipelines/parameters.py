"""The association node's parameters: defaults, ranges, descriptions, validation (no ROS types).

Algorithm parameters reuse the core's ParameterSpec of each associator, so the node and the
library accept exactly the same values.
"""
from __future__ import annotations

import array
from dataclasses import dataclass
from typing import Any, Optional

from ..core import InvalidInputError, available_algorithms
from ..core.associators import REGISTRY
from ..core.candidates import check_confirmation
from ..core.parameters import ParameterSpec
from ..core.map_refinding import REFINDING_PARAMETERS
from ..core.pose_recovery import RECOVERY_PARAMETERS

MULTI_HYPOTHESIS = 'multi_hypothesis'
MEASUREMENT_MODELS = ('auto', 'point_map', 'point_robot', 'range_bearing', 'box')


@dataclass(frozen=True)
class NodeParameter:
    """A node parameter: a numeric/bool ParameterSpec, or a string with `choices`, or a list of
    positive floats; `read_only` when a change cannot apply at run time."""

    name: str
    default: Any
    description: str
    spec: Optional[ParameterSpec] = None
    choices: tuple[str, ...] = ()
    read_only: bool = False

    def check(self, value: Any) -> Any:
        """The checked value; InvalidInputError with the reason otherwise."""
        if self.choices:
            if value not in self.choices:
                raise InvalidInputError(
                    f'{self.name}: {value!r} is not one of {", ".join(self.choices)}')
            return value
        if self.spec is not None:
            return self.spec.check(value)
        values = list(value) if isinstance(value, (list, tuple, array.array)) else None
        if not values or len(values) > 4 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < float('inf')
                for v in values):
            raise InvalidInputError(f'{self.name}: expected 1 to 4 positive variances, '
                                    f'got {value!r}')
        return [float(v) for v in values]

    def range_text(self) -> str:
        """Valid values for the README and the descriptor."""
        if self.choices:
            return ', '.join(self.choices)
        if self.spec is not None:
            return self.spec.range_text()
        return '1 or m positive values'


def _core_specs() -> dict[str, ParameterSpec]:
    specs: dict[str, ParameterSpec] = {}
    for associator in REGISTRY.values():
        for spec in associator.parameters:
            specs.setdefault(spec.name, spec)
    return specs


def _from_spec(spec: ParameterSpec, default=None, read_only: bool = False) -> NodeParameter:
    return NodeParameter(spec.name, spec.default if default is None else default,
                         spec.description, spec=spec, read_only=read_only)


_CORE = _core_specs()
NODE_PARAMETERS: tuple[NodeParameter, ...] = (
    NodeParameter('algorithm', 'mahalanobis_nn', 'associator, switchable at run time '
                  '(multi_hypothesis: the pose-hypothesis tree over scans, needs odometry)',
                  choices=available_algorithms() + (MULTI_HYPOTHESIS,)),
    NodeParameter('measurement_model', 'auto',
                  'auto: range/bearing fields -> range_bearing; width/height -> box; x/y in the '
                  "landmarks' frame -> point_map; x/y in another frame -> point_robot",
                  choices=MEASUREMENT_MODELS),
    *(_from_spec(_CORE[name]) for name in ('gate_probability', 'joint_gate_probability',
                                            'euclidean_gate', 'new_landmark_likelihood',
                                            'iou_threshold', 'one_to_one',
                                            'min_innovation_variance')),
    _from_spec(_CORE['time_budget_ms'], default=100.0),
    _from_spec(_CORE['max_nodes']),
    *(_from_spec(_CORE[name]) for name in ('minimal_iterations', 'transform_ransac',
                                            'ransac_inlier_threshold')),
    NodeParameter('confirm_hits', 1,
                  'a NEW observation becomes a landmark (new_landmarks) once its candidate was '
                  'seen on this many of the last confirm_window scans; 1: at once (no candidates)',
                  spec=ParameterSpec('confirm_hits', 1, '', kind=int, low=1, high=1000)),
    NodeParameter('confirm_window', 3, 'scans over which confirm_hits are counted',
                  spec=ParameterSpec('confirm_window', 3, '', kind=int, low=1, high=1000)),
    NodeParameter('candidate_max_misses', 2,
                  'a candidate not seen on this many scans in a row is dropped',
                  spec=ParameterSpec('candidate_max_misses', 2, '', kind=int, low=1, high=1000)),
    NodeParameter('candidate_pose_uncertainty', True,
                  'candidates are matched and fused with the map-frame covariance including the '
                  'robot pose\'s uncertainty (true) or with the observation noise alone (false: '
                  'when the pose error is common to consecutive scans, as in a SLAM filter)',
                  spec=ParameterSpec('candidate_pose_uncertainty', True, '', kind=bool)),
    *(_from_spec(spec) for spec in RECOVERY_PARAMETERS),
    *(_from_spec(spec) for spec in REFINDING_PARAMETERS),
    NodeParameter('reevaluation_window', 5, 'multi_hypothesis: past steps re-evaluated and '
                  'published on past_associations', spec=ParameterSpec(
                      'reevaluation_window', 5, '', kind=int, low=1, high=1000)),
    NodeParameter('mh_fov_range', 1000.0, 'multi_hypothesis: landmarks within this range [m] of '
                  'a hypothesis can explain an observation (all when none is)',
                  spec=ParameterSpec('mh_fov_range', 1000.0, '', low=0.0, low_open=True)),
    NodeParameter('mh_prune_threshold', 0.005, 'multi_hypothesis: hypotheses lighter than this '
                  'are pruned', spec=ParameterSpec('mh_prune_threshold', 0.005, '', low=0.0,
                                                   high=1.0, high_open=True)),
    NodeParameter('mh_max_leaves', 200, 'multi_hypothesis: at most this many hypotheses',
                  spec=ParameterSpec('mh_max_leaves', 200, '', kind=int, low=1, high=100000)),
    NodeParameter('mh_merge_threshold', 0.0, 'multi_hypothesis: merge hypotheses closer than '
                  'this squared Mahalanobis distance (0: never)',
                  spec=ParameterSpec('mh_merge_threshold', 0.0, '', low=0.0)),
    NodeParameter('max_pairs', 5_000_000,
                  'an observation message with more observations x landmarks than this is '
                  'skipped (counted as too_large): bounds memory and time per message; maps of '
                  'at least 64 landmarks are spatially indexed (only the landmarks that can '
                  'pass a gate take part) and are not limited by it',
                  spec=ParameterSpec('max_pairs', 5_000_000, '', kind=int, low=1)),
    NodeParameter('default_landmark_covariance', 0.01,
                  'variance [m^2] on each axis of landmarks that carry no covariance (PoseArray, '
                  'clouds without cov_* fields); applies from the next landmarks message',
                  spec=ParameterSpec('default_landmark_covariance', 0.01, '', low=0.0,
                                     low_open=True)),
    NodeParameter('observation_noise', [0.01],
                  'variances of observations that carry no covariance fields, in the model\'s '
                  'units and order (x, y [m^2]; range [m^2], bearing [rad^2]; x, y, width, '
                  'height): 1 value for all or m values'),
    NodeParameter('max_landmark_age', 1.0,
                  'newest landmarks not newer than the observation are used if at most this '
                  'old [s]', spec=ParameterSpec('max_landmark_age', 1.0, '', low=0.0)),
    NodeParameter('pose_tolerance', 0.05,
                  'the robot pose nearest the observation stamp is used within this [s]',
                  spec=ParameterSpec('pose_tolerance', 0.05, '', low=0.0)),
    NodeParameter('pose_wait', 4.0,
                  'an observation message whose inputs may still be on its way waits up to this '
                  'long [s, wall clock] for them: no map received yet (a large prior map can '
                  'arrive after the first scans), state covariances arrive but not yet its '
                  'map\'s, or its robot pose (poses arrive, but none within pose_tolerance of '
                  'its stamp and none newer yet); DDS does not order topics, and a message lost on '
                  'the wire is resent after the writer\'s next heartbeat (Fast DDS: 3 s)',
                  spec=ParameterSpec('pose_wait', 4.0, '', low=0.0, high=60.0)),
    NodeParameter('publish_markers', False, 'publish association_markers (costs time)',
                  spec=ParameterSpec('publish_markers', False, '', kind=bool)),
    NodeParameter('landmarks_type', 'pointcloud2',
                  'message type of the landmarks topic', choices=('pointcloud2', 'pose_array'),
                  read_only=True),
    NodeParameter('prior_map', False,
                  'the landmarks topic is a fixed map published once (transient_local, as map '
                  'servers publish): the node keeps it, indexes it once and associates every '
                  'later scan against it, whatever its age (max_landmark_age does not apply)',
                  spec=ParameterSpec('prior_map', False, '', kind=bool), read_only=True),
    NodeParameter('input_qos', 'reliable',
                  'QoS of the input subscriptions: reliable (keep last, reliable) or '
                  'sensor_data (best effort)', choices=('reliable', 'sensor_data'),
                  read_only=True),
    NodeParameter('qos_depth', 10, 'history depth of the input subscriptions',
                  spec=ParameterSpec('qos_depth', 10, '', kind=int, low=1, high=10000),
                  read_only=True),
    NodeParameter('diagnostics_period', 1.0, 'seconds between /diagnostics messages',
                  spec=ParameterSpec('diagnostics_period', 1.0, '', low=0.01, high=3600.0),
                  read_only=True),
)
BY_NAME = {parameter.name: parameter for parameter in NODE_PARAMETERS}


def check_combination(config: dict[str, Any]) -> None:
    """InvalidInputError when parameters valid one by one conflict (confirm_hits >
    confirm_window)."""
    check_confirmation(config['confirm_hits'], config['confirm_window'],
                       config['candidate_max_misses'])


def algorithm_arguments(config: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments of `associate` for config['algorithm'] taken from the node config."""
    if config['algorithm'] not in REGISTRY:
        return {}
    associator = REGISTRY[config['algorithm']]
    return {spec.name: config[spec.name] for spec in associator.parameters
            if spec.name in config}
