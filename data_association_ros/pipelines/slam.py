"""The ekf_slam_node's work without rclpy: an EKF-SLAM that feeds an association node and lives
with its answers (or with the bag's ground truth).

Per scan (`sensor_observations`, PointCloud2 in the robot frame: range, bearing [+ var_range,
var_bearing] or x, y [+ cov_xx, cov_xy, cov_yy]):
1. wait until odometry at least as new as the scan has arrived (or `max_pending_scans` scans
   wait), compose the odometry increments up to the scan and predict;
2. publish the local map - `landmarks` some observation of the scan can be paired with (or
   within local_map_radius of the robot), `robot_pose` and `state_covariance` (the block of
   [pose, those landmarks]) - stamped with the scan's stamp,
   then forward the scan on `observations` (so the association node has the map before the
   scan);
3. on the scan's answer - `correspondences` (association_source `node`) or
   `ground_truth/correspondences` (`ground_truth`) - fuse the paired observations in one EKF
   update; then initialise landmarks: from `new_landmarks` (`node`: one landmark per candidate,
   from its confirming observation of this scan, at the updated pose) or from the truth ids not
   yet in the map (`ground_truth`, which keeps the true ids); publish `slam_pose` and `slam_map`.
Answers and new_landmarks may arrive in either order, and before their scan is processed
(kept, at most MAX_EARLY); ones for scans already done are counted and dropped (a landmark whose
scan has passed is initialised from its fused map-frame estimate, uncorrelated with the state,
and counted as `late_new_landmarks`).  Scans wait in stamp order; a scan not newer than the last
one processed, and odometry older than what the filter has used, are counted and dropped; a
scan more than 1 s older than the last restarts the filter (a bag played again).
Values beyond MAX_MAGNITUDE are rejected (fusing them would overflow the state).
"""
from __future__ import annotations

import bisect
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np
from std_msgs.msg import Header

from msg_adapters import (PointCloudFormatError, cloud_to_array, detect_model,
                          observations_from_points, odometry_message, point_map_cloud,
                          pose_from_odometry, state_covariance_cloud)

from ..core import InvalidInputError, Observations
from ..core.models import MODELS
from ..core.parameters import ParameterSpec
from ..core.problem import state_rows
from ..core.slam import EkfSlam, OdometryIncrements
from ..core.slam.landmark_management import LandmarkManagementConfig, LandmarkManager
from ..core.slam.local_map import (EUCLIDEAN_GATE, POSITION_STD, YAW_STD, local_map_columns,
                                   scan_reach)
from ..core.validation import check_covariance_matrix, check_positive_semidefinite
from .association import NS_PER_S, stamp_ns
from .parameters import BY_NAME, NodeParameter
from .statistics import WarningThrottle

INPUT_ERRORS = (InvalidInputError, PointCloudFormatError, ValueError)
MAP_FRAME = 'map'
NEW_LANDMARK_FIELDS = ('observation', 'candidate', 'stamp_sec', 'stamp_nanosec', 'x', 'y',
                       'cov_xx', 'cov_xy', 'cov_yy')
SLAM_PARAMETERS = (
    NodeParameter('association_source', 'node', 'node: fuse the association node\'s answers '
                  '(closed loop); ground_truth: fuse the bag\'s true association (oracle)',
                  choices=('node', 'ground_truth')),
    NodeParameter('measurement_model', 'auto', 'model of sensor_observations (auto: range/'
                  'bearing fields -> range_bearing, x/y -> point_robot)',
                  choices=('auto', 'range_bearing', 'point_robot'), read_only=True),
    BY_NAME['observation_noise'],
    NodeParameter('initial_x', 0.0, 'initial robot x in the map frame [m]',
                  spec=ParameterSpec('initial_x', 0.0, ''), read_only=True),
    NodeParameter('initial_y', 0.0, 'initial robot y in the map frame [m]',
                  spec=ParameterSpec('initial_y', 0.0, ''), read_only=True),
    NodeParameter('initial_yaw', 0.0, 'initial robot yaw in the map frame [rad]',
                  spec=ParameterSpec('initial_yaw', 0.0, ''), read_only=True),
    NodeParameter('initial_position_std', 0.0, 'standard deviation of the initial x and y [m]',
                  spec=ParameterSpec('initial_position_std', 0.0, '', low=0.0), read_only=True),
    NodeParameter('initial_yaw_std', 0.0, 'standard deviation of the initial yaw [rad]',
                  spec=ParameterSpec('initial_yaw_std', 0.0, '', low=0.0), read_only=True),
    NodeParameter('odometry_tolerance', 0.005, 'odometry up to this much newer than a scan '
                  'counts as taken at the scan [s]',
                  spec=ParameterSpec('odometry_tolerance', 0.005, '', low=0.0, high=10.0)),
    NodeParameter('max_pending_scans', 10, 'scans waiting for odometry beyond this many are '
                  'processed with the odometry there is',
                  spec=ParameterSpec('max_pending_scans', 10, '', kind=int, low=0, high=1000)),
    NodeParameter('odometry_noise_scale', 1.0, 'multiplies every odometry increment covariance '
                  '(inflate it when the odometry is biased or its covariance optimistic)',
                  spec=ParameterSpec('odometry_noise_scale', 1.0, '', low=0.0, high=1e6,
                                     low_open=True)),
    NodeParameter('odometry_yaw_noise_scale', 1.0, 'multiplies the heading variance of every '
                  'odometry increment on top of odometry_noise_scale (its row and column by the '
                  'square root): for odometry whose heading drifts more than its covariance '
                  'says while its distance is fine (Victoria Park: docs/slam.md)',
                  spec=ParameterSpec('odometry_yaw_noise_scale', 1.0, '', low=0.0, high=1e6,
                                     low_open=True)),
    NodeParameter('min_motion_variance', 1e-9, 'added to the diagonal of every odometry '
                  'increment covariance [m^2, rad^2]',
                  spec=ParameterSpec('min_motion_variance', 1e-9, '', low=0.0, high=1.0)),
    NodeParameter('local_map_radius', 0.0, 'landmarks and state_covariance carry the local map: '
                  'the landmarks within this distance of the robot [m] and the covariance block '
                  'of [pose, those landmarks] (ids stay global); 0: automatic, the landmarks '
                  'some observation of the scan can be paired with (a chi-square gate up to '
                  '1 - 1e-9 under the pose widened by local_map_position_std and '
                  'local_map_yaw_std, or a Euclidean gate up to local_map_euclidean_gate: '
                  'docs/large_maps.md)',
                  spec=ParameterSpec('local_map_radius', 0.0, '', low=0.0)),
    NodeParameter('local_map_position_std', POSITION_STD, 'automatic local map: robot position '
                  'noise [m] a second association pass may add (at least association_node\'s '
                  'recovery_position_std)',
                  spec=ParameterSpec('local_map_position_std', POSITION_STD, '', low=0.0,
                                     high=1e3)),
    NodeParameter('local_map_yaw_std', YAW_STD, 'automatic local map: heading noise [rad] a '
                  'second association pass may add (at least association_node\'s '
                  'recovery_yaw_std)',
                  spec=ParameterSpec('local_map_yaw_std', YAW_STD, '', low=0.0, high=10.0)),
    NodeParameter('local_map_euclidean_gate', EUCLIDEAN_GATE, 'automatic local map: the '
                  'largest Euclidean gate covered (at least association_node\'s euclidean_gate; '
                  'measurement units)',
                  spec=ParameterSpec('local_map_euclidean_gate', EUCLIDEAN_GATE, '', low=0.0)),
    NodeParameter('merge_probability', 0.0, 'closed loop: merge two landmarks when their '
                  'difference passes the chi-square test at this probability (joint covariance '
                  'included) and no scan saw both (core/slam/landmark_management.py); 0: never',
                  spec=ParameterSpec('merge_probability', 0.0, '', low=0.0, high=1.0,
                                     high_open=True)),
    NodeParameter('merge_distance', 2.0, 'only landmarks closer than this are tested for a '
                  'merge [m]', spec=ParameterSpec('merge_distance', 2.0, '', low=0.0,
                                                  low_open=True)),
    NodeParameter('merge_floor', 0.0, 'merge test and fusion: the difference of two landmarks '
                  'gets this much independent noise [m std] on top of their joint covariance '
                  '(for a filter whose covariances are tighter than its errors); 0: none, an '
                  'exact fusion',
                  spec=ParameterSpec('merge_floor', 0.0, '', low=0.0, high=100.0)),
    NodeParameter('drop_misses', 0, 'closed loop: drop a landmark seen at most '
                  'drop_max_sightings times once it was predicted in view on this many scans '
                  'in a row without being seen; 0: never',
                  spec=ParameterSpec('drop_misses', 0, '', kind=int, low=0, high=100000)),
    NodeParameter('drop_max_sightings', 1, 'landmarks seen more often than this are never '
                  'dropped (0: no limit)',
                  spec=ParameterSpec('drop_max_sightings', 1, '', kind=int, low=0,
                                     high=100000)),
    NodeParameter('view_range', 0.0, 'sensor range for drop_misses: a landmark farther than '
                  'this is not in view [m]; 0: the largest observation distance seen so far',
                  spec=ParameterSpec('view_range', 0.0, '', low=0.0)),
    NodeParameter('view_half_angle', 3.141592653589793, 'sensor field of view for drop_misses: '
                  'a landmark at a bearing beyond +- this is not in view [rad]',
                  spec=ParameterSpec('view_half_angle', 3.141592653589793, '', low=0.0,
                                     high=3.141592653589793, low_open=True)),
    NodeParameter('input_qos', 'reliable', 'QoS of the odometry and sensor_observations '
                  'subscriptions: reliable or sensor_data (best effort, as many drivers '
                  'publish)', choices=('reliable', 'sensor_data'), read_only=True),
)
SLAM_BY_NAME = {p.name: p for p in SLAM_PARAMETERS}
MAX_EARLY = 100
"""Answers / new_landmarks kept for scans not processed yet (beyond: the furthest dropped)."""
MAX_ODOMETRY_QUEUE = 10_000
"""Odometry messages kept waiting for a scan; beyond, the oldest are composed into the motion
(a dead sensor does not grow memory)."""
RESTART_AFTER_NS = NS_PER_S
"""A scan this much older than the last one restarts the filter (a bag played again)."""
MAX_MAGNITUDE = 1e6
"""Largest |value| accepted in positions [m], ranges [m] and (co)variances: beyond it a value
is a fault, and fusing it would overflow the filter's state."""


def check_magnitude(values: np.ndarray, field: str) -> None:
    """InvalidInputError when any |value| exceeds MAX_MAGNITUDE (or is not finite)."""
    values = np.asarray(values, dtype=float)
    if values.size and not np.all(np.abs(values) <= MAX_MAGNITUDE):
        raise InvalidInputError(f'{field}: values beyond {MAX_MAGNITUDE:g} or not finite')


@dataclass
class CurrentScan:
    """The scan being answered: its stamp, observations and whether its update ran."""

    stamp: int
    header: Any
    observations: Observations
    updated: bool = False


@dataclass
class SlamStatistics:
    """Counters of the SLAM node (reported on /diagnostics)."""

    scans: int = 0
    updates: int = 0
    fused_observations: int = 0
    landmarks_added: int = 0
    local_map_landmarks: int = 0
    """Landmarks in the last scan's local map (`landmarks`, `state_covariance`)."""
    local_map_landmarks_max: int = 0
    invalid: Counter = field(default_factory=Counter)
    dropped: Counter = field(default_factory=Counter)

    def key_values(self) -> dict[str, object]:
        return {'scans': self.scans, 'updates': self.updates,
                'fused_observations': self.fused_observations,
                'landmarks_added': self.landmarks_added,
                'local_map_landmarks': self.local_map_landmarks,
                'local_map_landmarks_max': self.local_map_landmarks_max,
                **{f'invalid_{k}': v for k, v in sorted(self.invalid.items())},
                **{f'dropped_{k}': v for k, v in sorted(self.dropped.items())}}


Outputs = list[tuple[str, Any]]
"""(relative topic, message) to publish, in order."""


class SlamPipeline:
    """Holds the filter and the scan in flight; each handler returns the messages to publish."""

    def __init__(self, config: dict[str, Any],
                 warn: Callable[[str], None] = lambda text: None) -> None:
        self.config = config
        self.warn = warn
        self.statistics = SlamStatistics()
        self.slam: Optional[EkfSlam] = None
        self.odometry = OdometryIncrements()
        self.odometry_queue: list = []       # (stamp, RobotPose) not yet consumed, by stamp
        self.consumed_until: Optional[int] = None   # odometry up to here is in the filter
        self.pending_scans: list = []        # (stamp, msg) waiting for odometry, by stamp
        self.current: Optional[CurrentScan] = None
        self.early_answers: dict[int, Any] = {}   # answers of a scan not processed yet
        self.early_new: dict[int, Any] = {}       # new_landmarks waiting for their scan's update
        self.origins: dict[int, tuple[int, int]] = {}   # landmark id -> (stamp, observation)
        self.next_id = 0
        self.added_for: set[int] = set()   # scan stamps whose new landmarks were added
        self.sensor_reach = 0.0    # largest observation distance seen [m] (view_range 0)
        self.last_update: Optional[tuple[int, float, int]] = None   # (stamp, joint NIS, dof)
        self.manager = LandmarkManager(self._management_config())
        self._throttle = WarningThrottle()

    # -- inputs -------------------------------------------------------------------------
    def on_odometry(self, msg) -> Outputs:
        """nav_msgs/Odometry: pose in the odometry frame, covariance of the increment since the
        previous message."""
        try:
            pose = pose_from_odometry(msg)   # finite, covariance symmetric PSD (RobotPose)
            check_magnitude(pose.mean[:2], 'odometry.pose.position')
            check_magnitude(pose.covariance, 'odometry.pose.covariance')
        except INPUT_ERRORS as error:
            return self._invalid('odometry', error)
        stamp = stamp_ns(msg.header)
        if self.consumed_until is not None and stamp <= self.consumed_until:
            return self._drop('odometry_too_old', 'odometry older than a scan already done')
        bisect.insort(self.odometry_queue, (stamp, pose), key=lambda item: item[0])
        if len(self.odometry_queue) > MAX_ODOMETRY_QUEUE:   # no scans: keep the motion only
            old_stamp, old_pose = self.odometry_queue.pop(0)
            self.odometry.add(old_pose.mean, old_pose.covariance)
            self.consumed_until = old_stamp
            self.statistics.dropped['odometry_folded_without_scan'] += 1
        return self._release_scans()

    def on_scan(self, msg) -> Outputs:
        """A sensor_observations PointCloud2; processed once its odometry is there (scans
        wait in stamp order)."""
        stamp = stamp_ns(msg.header)
        if self.current is not None and stamp < self.current.stamp - RESTART_AFTER_NS:
            self._restart(f'scan {(self.current.stamp - stamp) / NS_PER_S:.2f} s older than '
                          'the last one (a bag played again?)')
        if (self.current is not None and stamp <= self.current.stamp) or \
                any(stamp == pending for pending, _ in self.pending_scans):
            return self._drop('scan_out_of_order', 'scan not newer than the last one')
        bisect.insort(self.pending_scans, (stamp, msg), key=lambda item: item[0])
        return self._release_scans()

    def _restart(self, why: str) -> None:
        """Start over: a new filter at the initial pose, nothing pending (counted)."""
        statistics, warn = self.statistics, self.warn
        self.__init__(self.config, warn)
        self.statistics = statistics
        statistics.dropped['restarts'] += 1
        warn(f'ekf_slam_node restarted: {why}')

    def on_correspondences(self, msg) -> Outputs:
        """The association node's answer (used when association_source is `node`)."""
        return self._on_answer(msg, 'node')

    def on_ground_truth(self, msg) -> Outputs:
        """The bag's true association (used when association_source is `ground_truth`)."""
        return self._on_answer(msg, 'ground_truth')

    def on_new_landmarks(self, msg) -> Outputs:
        """The association node's new landmarks (association_source `node`)."""
        if self.config['association_source'] != 'node':
            return []
        stamp = stamp_ns(msg.header)
        current = self.current
        if current is not None and stamp == current.stamp and current.updated:
            return self._add_new_landmarks(msg) + self._estimate_messages()
        if current is None or stamp >= current.stamp:
            return self._keep_early(self.early_new, stamp, msg)
        return self._add_new_landmarks(msg, late=True) + self._estimate_messages()

    # -- work ---------------------------------------------------------------------------
    def _release_scans(self) -> Outputs:
        out: Outputs = []
        tolerance = int(self.config['odometry_tolerance'] * NS_PER_S)
        while self.pending_scans:
            stamp = self.pending_scans[0][0]
            ready = bool(self.odometry_queue) and self.odometry_queue[-1][0] >= stamp - tolerance
            if not ready and len(self.pending_scans) <= self.config['max_pending_scans']:
                break
            if not ready:
                self._drop('scan_without_odometry', 'scan processed without odometry up to '
                           'its stamp')
            out += self._process_scan(self.pending_scans.pop(0)[1], stamp + tolerance)
        return out

    def _process_scan(self, msg, odometry_until: int) -> Outputs:
        try:
            points = cloud_to_array(msg)
            model = self.config['measurement_model']
            if model == 'auto':
                model = detect_model(points.dtype.names or (), msg.header.frame_id, MAP_FRAME)
            if model not in ('range_bearing', 'point_robot'):
                raise InvalidInputError(f'sensor_observations: model {model} is not a robot-'
                                        'frame point model (range_bearing, point_robot)')
            observations = observations_from_points(points, model,
                                                    self.config['observation_noise'])
            check_magnitude(observations.values, 'sensor_observations')
            check_magnitude(observations.covariances, 'sensor_observations covariance')
            if self.slam is not None and self.slam.model.name != model:
                if len(self.slam):
                    raise InvalidInputError(f'sensor_observations: model {model} after '
                                            f'{self.slam.model.name} (the map uses it)')
                self.slam.model = MODELS[model]   # an empty map takes the new model
        except INPUT_ERRORS as error:
            return self._invalid('sensor_observations', error)
        # odometry newer than the scan and not here yet belongs to the next scan (scans may be
        # closer than odometry_tolerance: MRCLAM has 1 ms gaps), so only what was consumed, or
        # the scan's stamp, is "done"
        consumed = stamp_ns(msg.header)
        while self.odometry_queue and self.odometry_queue[0][0] <= odometry_until:
            consumed, pose = self.odometry_queue.pop(0)
            self.odometry.add(pose.mean, pose.covariance)
        self.consumed_until = max(consumed, stamp_ns(msg.header), self.consumed_until or 0)
        if self.slam is None:
            self.slam = self._start(model)
        increment, noise = self.odometry.take()
        self.slam.predict(increment, self._motion_noise(noise))
        stamp = stamp_ns(msg.header)
        self.current = CurrentScan(stamp, msg.header, observations)
        self.statistics.scans += 1
        for old in [s for s in self.early_answers if s < stamp]:
            del self.early_answers[old]
            self.statistics.dropped['answer_without_scan'] += 1
        header = Header(stamp=msg.header.stamp, frame_id=MAP_FRAME)
        self.sensor_reach = max(self.sensor_reach, scan_reach(observations.values, model))
        ids, means, covariances = self.slam.marginals()
        slam = self.slam
        config = self.config
        local = local_map_columns(model, slam.mean[:3], slam.covariance, means, covariances,
                                  observations.values, observations.covariances,
                                  config['local_map_radius'], config['local_map_position_std'],
                                  config['local_map_yaw_std'],
                                  config['local_map_euclidean_gate'])
        self.statistics.local_map_landmarks = len(local)
        self.statistics.local_map_landmarks_max = max(self.statistics.local_map_landmarks_max,
                                                      len(local))
        rows = state_rows(local, 2)
        out: Outputs = [
            ('landmarks', point_map_cloud(header, ids[local], means[local], covariances[local])),
            ('robot_pose', odometry_message(header, *self._pose())),
            ('state_covariance', state_covariance_cloud(
                header, ids[local], slam.covariance[np.ix_(rows, rows)])),
            ('observations', msg)]
        answer = self.early_answers.pop(stamp, None)
        if answer is not None:
            out += self._apply_answer(answer)
        return out

    def _motion_noise(self, noise: np.ndarray) -> np.ndarray:
        """The odometry increment covariance the filter predicts with: D Q D odometry_noise_scale
        + min_motion_variance I, D = diag(1, 1, sqrt(odometry_yaw_noise_scale))."""
        c = self.config
        scale = np.array([1.0, 1.0, np.sqrt(c['odometry_yaw_noise_scale'])])
        return (noise * np.outer(scale, scale) * c['odometry_noise_scale']
                + np.eye(3) * c['min_motion_variance'])

    def _management_config(self) -> LandmarkManagementConfig:
        """The landmark-management parameters now (view_range 0: the farthest observation seen
        so far)."""
        c = self.config
        return LandmarkManagementConfig(
            merge_probability=c['merge_probability'], merge_distance=c['merge_distance'],
            merge_floor=c['merge_floor'],
            drop_misses=c['drop_misses'], drop_max_sightings=c['drop_max_sightings'],
            view_range=c['view_range'] if c['view_range'] > 0 else self.sensor_reach,
            view_half_angle=c['view_half_angle'])

    def _manage_landmarks(self, fused_ids: np.ndarray) -> None:
        """Closed loop: merge duplicates and drop never-seen landmarks after a scan's update
        (core/slam/landmark_management.py; counted in statistics)."""
        self.manager.config = self._management_config()   # parameters set at run time
        if self.config['association_source'] != 'node' or not self.manager.active:
            self.manager.next_scan(self.current.stamp)     # nothing managed: the record moves on
            return
        result = self.manager.after_scan(self.slam, fused_ids, self.current.stamp)
        self.statistics.dropped['landmarks_merged'] += len(result.merged)
        self.statistics.dropped['landmarks_dropped'] += len(result.dropped)

    def _start(self, model: str) -> EkfSlam:
        c = self.config
        covariance = np.diag([c['initial_position_std'] ** 2] * 2 + [c['initial_yaw_std'] ** 2])
        return EkfSlam([c['initial_x'], c['initial_y'], c['initial_yaw']], covariance, model)

    def _pose(self):
        pose = self.slam.pose
        return pose.mean, pose.covariance

    def _on_answer(self, msg, source: str) -> Outputs:
        if self.config['association_source'] != source:
            return []
        stamp = stamp_ns(msg.header)
        current = self.current
        if current is not None and stamp == current.stamp and not current.updated:
            return self._apply_answer(msg)
        if current is None or stamp > current.stamp:
            return self._keep_early(self.early_answers, stamp, msg)
        return self._drop('stale_answer', 'answer for a scan already done')

    def _keep_early(self, store: dict, stamp: int, msg) -> Outputs:
        """Keep a message for a scan not processed yet (at most MAX_EARLY, the newest)."""
        store[stamp] = msg
        if len(store) > MAX_EARLY:
            del store[max(store)]
            self.statistics.dropped['too_many_early'] += 1
        return []

    def _apply_answer(self, msg) -> Outputs:
        current = self.current
        try:
            assignment = cloud_to_array(msg)['landmark'].astype(np.int64)
            if len(assignment) != len(current.observations):
                raise InvalidInputError(f'{len(assignment)} answers for '
                                        f'{len(current.observations)} observations')
        except (*INPUT_ERRORS, KeyError) as error:
            return self._invalid('correspondences', error)
        slam = self.slam
        known = (assignment >= 0) & (slam.index_of(assignment) >= 0)
        unknown = int(((assignment >= 0) & ~known).sum())
        truth_mode = self.config['association_source'] == 'ground_truth'
        if unknown and not truth_mode:
            self.statistics.dropped['unknown_landmark_id'] += unknown
        _, first = np.unique(assignment, return_index=True)
        once = np.zeros(len(assignment), dtype=bool)
        once[first] = True          # a landmark paired twice in one scan: fuse the first only
        use = np.flatnonzero(known & once)
        values, covariances = current.observations.values, current.observations.covariances
        try:
            nis = slam.update(values[use], covariances[use], assignment[use])
        except (np.linalg.LinAlgError, InvalidInputError, ValueError) as error:
            return self._invalid('update', error)   # e.g. S not positive definite
        self.last_update = (current.stamp, nis, 2 * len(use))
        self.manager.fused(assignment[use], current.stamp)
        self.statistics.updates += 1
        self.statistics.fused_observations += len(use)
        current.updated = True
        if truth_mode:
            new = np.flatnonzero((assignment >= 0) & ~known & once)
            self._add(values[new], covariances[new], assignment[new], new)
        elif current.stamp in self.early_new:
            self._add_new_landmarks(self.early_new.pop(current.stamp))
        for old in [s for s in self.early_new if s < current.stamp]:
            del self.early_new[old]
            self.statistics.dropped['new_landmarks_without_scan'] += 1
        self._manage_landmarks(assignment[use])
        return self._estimate_messages()

    def _add(self, values, covariances, ids, observations) -> None:
        self.slam.add_landmarks(values, covariances, ids)
        self.manager.started(ids, self.current.stamp)
        for landmark, index in zip(ids.tolist(), observations.tolist()):
            self.origins[landmark] = (self.current.stamp, index)
        self.statistics.landmarks_added += len(ids)
        if len(ids):
            self.next_id = max(self.next_id, int(ids.max()) + 1)

    def _add_new_landmarks(self, msg, late: bool = False) -> Outputs:
        """One landmark per candidate of a new_landmarks message, from its observation in the
        current scan (at the updated pose), else (late) from its fused map-frame estimate."""
        current = self.current
        try:
            points = cloud_to_array(msg)
            columns = {name: points[name].astype(float) for name in NEW_LANDMARK_FIELDS}
            for name in ('candidate', 'observation', 'stamp_sec', 'stamp_nanosec'):
                if not np.all(np.isfinite(columns[name])):
                    raise InvalidInputError(f'new_landmarks.{name}: not finite')
            stamps = columns['stamp_sec'].astype(np.int64) * NS_PER_S + \
                columns['stamp_nanosec'].astype(np.int64)
            observation = columns['observation'].astype(np.int64)
            candidates = columns['candidate'].astype(np.int64)
        except (*INPUT_ERRORS, KeyError) as error:
            return self._invalid('new_landmarks', error)
        if not late and current.stamp in self.added_for:
            return self._drop('repeated_new_landmarks', 'new_landmarks for this scan again')
        self.added_for.add(current.stamp)
        chosen = []
        for candidate in np.unique(candidates):
            rows = np.flatnonzero(candidates == candidate)
            here = rows[(stamps[rows] == current.stamp) & (observation[rows] >= 0) &
                        (observation[rows] < len(current.observations))]
            if here.size and not late:
                chosen.append(int(observation[here[-1]]))
            else:
                row = rows[-1]
                self._add_fused(columns, row, (int(stamps[row]), int(observation[row])))
        chosen = np.unique(np.array(chosen, dtype=np.int64))
        if chosen.size:
            ids = self.next_id + np.arange(chosen.size)
            values = current.observations.values[chosen]
            covariances = current.observations.covariances[chosen]
            self._add(values, covariances, ids, chosen)
        return []

    def _add_fused(self, columns: dict, row: int, origin: tuple[int, int]) -> None:
        """A landmark from its map-frame estimate (x, y, covariance) in `row`, uncorrelated
        with the state; `origin` = its confirming observation (stamp, index)."""
        self.statistics.dropped['late_new_landmarks'] += 1
        slam = self.slam
        mean = np.array([columns['x'][row], columns['y'][row]])
        cov = np.array([[columns['cov_xx'][row], columns['cov_xy'][row]],
                        [columns['cov_xy'][row], columns['cov_yy'][row]]])
        try:
            check_magnitude(mean, 'new_landmarks.x, y')
            check_magnitude(cov, 'new_landmarks covariance')
            check_positive_semidefinite(check_covariance_matrix(cov, 'new_landmarks covariance'),
                                        'new_landmarks covariance')
        except InvalidInputError as error:
            self._invalid('new_landmarks', error)
            return
        size = len(slam.mean)
        grown = np.zeros((size + 2, size + 2))
        grown[:size, :size] = slam.covariance
        grown[size:, size:] = cov
        slam.covariance = grown
        slam.mean = np.concatenate([slam.mean, mean])
        slam.ids = np.append(slam.ids, self.next_id)
        self.manager.started([self.next_id], origin[0])
        self.origins[self.next_id] = origin
        self.next_id += 1

    def _estimate_messages(self) -> Outputs:
        header = Header(stamp=self.current.header.stamp, frame_id=MAP_FRAME)
        ids, means, covariances = self.slam.marginals()
        origins = np.array([self.origins.get(int(i), (-1, -1)) for i in ids],
                           dtype=np.int64).reshape(-1, 2)
        sec, nanosec = np.divmod(np.maximum(origins[:, 0], 0), NS_PER_S)
        extra = {'origin_stamp_sec': sec.astype('<i4'),
                 'origin_stamp_nanosec': nanosec.astype('<u4'),
                 'origin_observation': origins[:, 1].astype('<i4')}
        return [('slam_map', point_map_cloud(header, ids, means, covariances, extra)),
                ('slam_pose', odometry_message(header, *self._pose()))]

    # -- bookkeeping --------------------------------------------------------------------
    def _invalid(self, what: str, error: Exception) -> Outputs:
        self.statistics.invalid[what] += 1
        self._warn(what, f'{what} message rejected: {error}')
        return []

    def _drop(self, cause: str, text: str) -> Outputs:
        self.statistics.dropped[cause] += 1
        self._warn(cause, text)
        return []

    def _warn(self, cause: str, text: str) -> None:
        if self._throttle.should_warn(cause, time.monotonic()):
            self.warn(f'{text} (further {cause!r} warnings throttled)')
