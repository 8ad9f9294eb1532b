"""The association node's work without rclpy: input messages in, output messages out.

The node (live) and the bag evaluator (offline) both run this, so they give the same answers.
It converts each input once on arrival, matches an observation message to the newest landmarks
not newer than it (within max_landmark_age) and the pose nearest in time (within
pose_tolerance), calls the core and builds the output messages.  Rejections and skips are
counted by cause in `statistics` and reported through `warn` (throttled per cause).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from functools import lru_cache
from operator import itemgetter
from typing import AbstractSet, Any, Callable, Optional

import numpy as np
from std_msgs.msg import Header

from msg_adapters import (PointCloudFormatError, array_to_cloud, association_markers,
                          candidates_cloud, cloud_points, cloud_to_array, correspondences_cloud,
                          detect_model, landmarks_from_points, landmarks_from_pose_array,
                          new_landmarks_cloud, observations_from_points, pose_from_odometry,
                          state_covariance_from_cloud, transform_message)
from msg_adapters.serialized_cloud import SerializedCloud

from ..core import NEW, Association, InvalidInputError, Landmarks, RobotPose
from ..core.candidates import CandidateManager, CandidateUpdate
from ..core.initialisation import observations_in_map
from ..core.models import MODELS
from ..core.map_refinding import REFINDING_PARAMETERS, MapRefinder, RefindingConfig
from ..core.pose_recovery import RECOVERED, PoseRecovery, associate_with_pose_recovery
from ..core.spatial_index import INDEX_MIN_LANDMARKS, landmark_index
from .multi_hypothesis_stage import MultiHypothesisStage
from .parameters import MULTI_HYPOTHESIS, algorithm_arguments
from .stamped_buffer import StampedBuffer
from .statistics import AssociationStatistics

NS_PER_S = 1_000_000_000
INPUT_ERRORS = (InvalidInputError, PointCloudFormatError)


def stamp_ns(header) -> int:
    """A std_msgs/Header stamp in nanoseconds."""
    return int(header.stamp.sec) * NS_PER_S + int(header.stamp.nanosec)


@dataclass(frozen=True)
class StampedLandmarks:
    """A landmarks message converted once on arrival."""

    landmarks: Landmarks
    frame_id: str
    stamp: int = 0


@dataclass(frozen=True)
class StampedCovariance:
    """A state_covariance message converted once on arrival: the landmark ids of its rows and
    the joint covariance of [pose, those landmarks] (checked finite, symmetric, non-negative
    diagonal)."""

    ids: np.ndarray
    matrix: np.ndarray


CANDIDATE_SETTINGS = itemgetter('confirm_hits', 'confirm_window', 'candidate_max_misses',
                                'gate_probability', 'euclidean_gate', 'iou_threshold')
"""The values of CandidateManager.configure's parameters in a config, in its order."""


@lru_cache(maxsize=16, typed=True)
def _refinding_config(values: tuple) -> RefindingConfig:
    return RefindingConfig(*values)


def refinding_config(config: dict[str, Any]) -> RefindingConfig:
    """The RefindingConfig of a node config (built once per set of values)."""
    return _refinding_config(tuple(config[spec.name] for spec in REFINDING_PARAMETERS))


@lru_cache(maxsize=16, typed=True)
def pose_recovery(position_std: float, yaw_std: float, min_new: int) -> PoseRecovery:
    """The (immutable) PoseRecovery of these settings, built once."""
    return PoseRecovery(position_std, yaw_std, min_new)


OPTIONAL_OUTPUTS = frozenset({'new_landmarks', 'landmark_candidates', 'association_markers'})
"""Outputs built only when wanted (AssociationPipeline.answer), by their topic names."""


@dataclass
class Answer:
    """The outputs for one observation message (new_landmarks, candidates and markers may be
    None: none to publish, or not wanted); correspondences: a PointCloud2, or its CDR bytes
    when the observation message was a SerializedCloud (msg_adapters.serialized_cloud)."""

    correspondences: Any
    new_landmarks: Optional[Any]
    markers: Optional[Any]
    association: Association
    transform: Optional[Any] = None
    candidates: Optional[Any] = None
    pose_hypotheses: Optional[Any] = None
    past_associations: Optional[Any] = None


class AssociationPipeline:
    """Holds the latest inputs and answers observation messages with `config` (a dict of the
    node's parameter values, read at each answer so changes apply from the next message)."""

    def __init__(self, config: dict[str, Any],
                 warn: Callable[[str], None] = lambda text: None) -> None:
        self.config = config
        self.warn = warn
        self.statistics = AssociationStatistics()
        self.landmark_history: StampedBuffer[StampedLandmarks] = StampedBuffer(50)
        self.pose_history: StampedBuffer = StampedBuffer(200)
        self.covariance_history: StampedBuffer[StampedCovariance] = StampedBuffer(50)
        self.candidates = CandidateManager()
        self._candidate_settings: tuple = ()   # the values of CANDIDATE_SETTINGS in force
        self.odometry_history: StampedBuffer = StampedBuffer(200)
        self.multi_hypothesis = MultiHypothesisStage()
        self.refinder = MapRefinder(refinding_config(config))

    def _reject(self, counter, cause: str, text: str) -> None:
        counter[cause] += 1
        if self.statistics.should_warn(cause, time.monotonic()):
            self.warn(f'{text} (further {cause!r} warnings throttled)')

    def count_invalid(self, topic: str, error: Exception) -> None:
        """Count a `topic` message rejected for `error` (and warn, throttled)."""
        self._reject(self.statistics.invalid, topic, f'{topic} message rejected: {error}')

    def on_landmarks(self, msg) -> None:
        """A sensor_msgs/PointCloud2 of landmarks (boxes when it has width and height)."""
        try:
            points = cloud_to_array(msg)
            box = {'width', 'height'} <= set(points.dtype.names or ())
            landmarks = landmarks_from_points(points, self.config['default_landmark_covariance'],
                                              box)
        except INPUT_ERRORS as error:
            self.count_invalid('landmarks', error)
            return
        self._add_landmarks(msg.header, landmarks)

    def on_pose_array(self, msg) -> None:
        """A geometry_msgs/PoseArray of landmarks (ids = index)."""
        try:
            landmarks = landmarks_from_pose_array(msg, self.config['default_landmark_covariance'])
        except INPUT_ERRORS as error:
            self.count_invalid('landmarks', error)
            return
        self._add_landmarks(msg.header, landmarks)

    def _add_landmarks(self, header, landmarks: Landmarks) -> None:
        stamp = stamp_ns(header)
        if self.config['prior_map']:    # one fixed map: it serves every scan, whatever its age
            self.landmark_history = StampedBuffer(1)
            stamp = -2 ** 62
            if len(landmarks) >= INDEX_MIN_LANDMARKS:
                landmark_index(landmarks)   # indexed now, not in the first scan's latency
        self.landmark_history.add(stamp, StampedLandmarks(landmarks, header.frame_id,
                                                          stamp_ns(header)))

    def on_robot_pose(self, msg) -> None:
        """A nav_msgs/Odometry robot pose in the map frame."""
        self._add_pose(msg, 'robot_pose', self.pose_history)

    def on_odometry(self, msg) -> None:
        """A nav_msgs/Odometry from wheel odometry (multi_hypothesis motion increments)."""
        self._add_pose(msg, 'odometry', self.odometry_history)

    def _add_pose(self, msg, topic: str, history: StampedBuffer) -> None:
        try:
            pose = pose_from_odometry(msg)
        except INPUT_ERRORS as error:
            self.count_invalid(topic, error)
            return
        history.add(stamp_ns(msg.header), pose)

    def on_state_covariance(self, msg) -> None:
        """A state_covariance PointCloud2: the joint covariance of [pose, landmarks] of the
        landmarks message with the same stamp (msg_adapters.state.STATE_COVARIANCE_FIELDS)."""
        try:
            ids, matrix = state_covariance_from_cloud(msg)
        except INPUT_ERRORS as error:
            self.count_invalid('state_covariance', error)
            return
        self.covariance_history.add(stamp_ns(msg.header), StampedCovariance(ids, matrix))

    def _joint_covariance(self, item: StampedLandmarks) -> Optional[np.ndarray]:
        """The joint covariance that belongs to the map `item`: same stamp, same ids in the
        same order, one row per landmark coordinate.  None (marginal covariances) when there
        is none; counted as covariance_mismatch when covariances arrive but none fits."""
        if not len(self.covariance_history):
            return None
        landmarks = item.landmarks
        found = self.covariance_history.at(item.stamp)
        if found is not None and np.array_equal(found.ids, landmarks.ids) and \
                found.matrix.shape[0] == 3 + len(landmarks) * (landmarks.dim if len(landmarks)
                                                               else 2):
            return found.matrix
        why = 'none with the map\'s stamp' if found is None else \
            'its landmark ids or size differ from the map\'s'
        self._reject(self.statistics.fallbacks, 'covariance_mismatch',
                     f'state_covariance not used ({why}): marginal covariances instead')
        return None

    def inputs_pending(self, msg) -> bool:
        """True when what this observation message needs may still be on its way (DDS does not
        order messages across topics: a SLAM node's map, pose and covariance can arrive after
        the scan they precede, a large prior map after the first scans): no map received yet;
        state covariances arrive but not yet the one of its map; or the robot pose it needs
        (robot-frame models): poses arrive, but none within pose_tolerance of its stamp and
        none newer yet; multi_hypothesis: the same for the odometry it needs (not for the robot
        pose, only its optional prior)."""
        if not len(self.landmark_history) or self._covariance_pending(msg):
            return True
        multi_hypothesis = self.config['algorithm'] == MULTI_HYPOTHESIS
        newest = (self.odometry_history if multi_hypothesis else self.pose_history).newest_stamp()
        if newest is None or not multi_hypothesis and self.config['measurement_model'] in (
                'point_map', 'box'):
            return False
        try:
            stamp = stamp_ns(msg.header)
            if newest >= stamp - int(self.config['pose_tolerance'] * NS_PER_S):
                return False    # it has come
            if not multi_hypothesis and self.config['measurement_model'] == 'auto':
                landmarks, _ = self.landmark_history.latest_not_after(stamp, 2 ** 62)
                names = {field.name for field in msg.fields}
                if landmarks is not None and detect_model(
                        names, msg.header.frame_id, landmarks.frame_id) in ('point_map', 'box'):
                    return False    # a map-frame model needs no pose
        except (AttributeError, TypeError, ValueError, InvalidInputError):
            return False
        return True

    def _map_for(self, stamp: int, config: dict[str, Any]
                 ) -> tuple[Optional[StampedLandmarks], str]:
        """The newest landmarks not newer than `stamp` within max_landmark_age (the prior map,
        whatever its age)."""
        max_age = 2 ** 63 if config['prior_map'] else int(config['max_landmark_age'] * NS_PER_S)
        return self.landmark_history.latest_not_after(stamp, max_age)

    def _covariance_pending(self, msg) -> bool:
        """True when state covariances arrive but the one of this scan's map has not yet (the
        map owner publishes it with the map; DDS may deliver it after the scan)."""
        newest = self.covariance_history.newest_stamp()
        if newest is None:
            return False
        try:
            item, _ = self._map_for(stamp_ns(msg.header), self.config)
        except (AttributeError, TypeError, ValueError):
            return False
        return item is not None and newest < item.stamp

    def answer(self, msg, wanted: Optional[AbstractSet[str]] = None) -> Optional[Answer]:
        """The outputs for an observation PointCloud2 (or SerializedCloud), or None when it is
        skipped or invalid.
        wanted: the optional outputs to build (OPTIONAL_OUTPUTS; the node passes those with a
        subscriber, None: all); the others are None, the state (candidates) is updated alike."""
        started = time.perf_counter()
        try:
            return self._answer(msg, started, OPTIONAL_OUTPUTS if wanted is None else wanted)
        except INPUT_ERRORS as error:
            self.count_invalid('observations', error)
        except Exception as error:  # never let one message take the node down
            self._reject(self.statistics.invalid, 'internal_error',
                         f'observation message dropped by an internal error: {error!r}')
        return None

    @np.errstate(all='ignore')   # absurd magnitudes give inf/NaN, reported as such
    def _answer(self, msg, started: float, wanted: AbstractSet[str]) -> Optional[Answer]:
        config = dict(self.config)
        stamp = stamp_ns(msg.header)
        item, why = self._map_for(stamp, config)
        if item is None:
            self._reject(self.statistics.skipped, 'no_landmarks',
                         f'observation message skipped: landmarks {why}')
            return None
        points = cloud_points(msg)
        model = config['measurement_model']
        if model == 'auto':
            model = detect_model(points.dtype.names or (), msg.header.frame_id, item.frame_id)
        if config['algorithm'] == MULTI_HYPOTHESIS:
            return self._answer_multi_hypothesis(config, msg, points, model, item, stamp,
                                                 started)
        if self.multi_hypothesis.tree is not None:
            self.multi_hypothesis.reset()
        pose = None
        if MODELS[model].needs_pose:
            pose, why = self.pose_history.nearest(stamp,
                                                  int(config['pose_tolerance'] * NS_PER_S))
            if pose is None:
                self._reject(self.statistics.skipped, 'no_pose',
                             f'observation message skipped: robot pose {why}')
                return None
        observations = observations_from_points(points, model, config['observation_noise'])
        landmarks = item.landmarks
        too_many_pairs = len(observations) * len(landmarks) > config['max_pairs']
        if too_many_pairs and len(landmarks) < INDEX_MIN_LANDMARKS:
            self._reject(self.statistics.skipped, 'too_large',
                         f'observation message skipped: {len(observations)} observations x '
                         f'{len(landmarks)} landmarks exceeds max_pairs {config["max_pairs"]}')
            return None
        state_covariance = self._joint_covariance(item)
        result = associate_with_pose_recovery(
            landmarks, observations, config['algorithm'], pose, state_covariance,
            pose_recovery(config['recovery_position_std'], config['recovery_yaw_std'],
                          config['recovery_min_new']),
            spatial_index=True if too_many_pairs else None, **algorithm_arguments(config))
        if config['refind_window_scans'] > 0 and pose is not None:
            result, pose = self._refind(config, landmarks, observations, pose, state_covariance,
                                        result, too_many_pairs)
        # candidate_pose_uncertainty false: the observation noise alone (a SLAM's pose error is
        # common to consecutive scans and would only widen every candidate gate; ttk4250 with
        # 20 clutter returns per scan: 66 false landmarks confirmed 3 scans in a row with it,
        # 5 without)
        positions, covariances = observations_in_map(observations, pose,
                                                     config['candidate_pose_uncertainty'])
        update = self._confirm(config, result, positions, covariances, stamp, model,
                               'new_landmarks' in wanted)
        map_header = Header(stamp=msg.header.stamp, frame_id=item.frame_id) \
            if wanted else None
        answer = Answer(
            correspondences=correspondences_cloud(msg.header, result, positions,
                                                  serialized=isinstance(msg, SerializedCloud)),
            new_landmarks=new_landmarks_cloud(map_header, update.confirmed)
            if 'new_landmarks' in wanted else None,
            candidates=candidates_cloud(map_header, self.candidates.pending,
                                        self.candidates.scan)
            if config['confirm_hits'] > 1 and 'landmark_candidates' in wanted else None,
            markers=association_markers(map_header, result, positions, landmarks.ids,
                                        landmarks.means)
            if config['publish_markers'] and 'association_markers' in wanted else None,
            association=result,
            transform=transform_message(msg.header, result.extras['transform'])
            if 'transform' in result.extras else None)
        self.statistics.record_answer(result.assignment, (time.perf_counter() - started) * 1e3,
                                      result.truncated, result.extras[RECOVERED])
        self.statistics.record_candidates(self.candidates.confirmed_total,
                                          self.candidates.expired_total,
                                          len(self.candidates.pending))
        return answer

    def _refind(self, config: dict[str, Any], landmarks: Landmarks, observations, pose: RobotPose,
                state_covariance, first: Association, too_many_pairs: bool
                ) -> tuple[Association, RobotPose]:
        """core/map_refinding.py: the scan associated again from the re-found pose when the
        window registers onto the old landmarks and that pairs more observations with them;
        (answer, the pose it was made from)."""
        self.refinder.reconfigure(refinding_config(config))
        positions, _ = observations_in_map(observations, pose, False)
        registration = self.refinder.refind(landmarks, positions, pose, first)
        if registration is None:
            return first, pose
        moved = registration.pose(pose)
        second = associate_with_pose_recovery(
            landmarks, observations, config['algorithm'], moved, state_covariance,
            pose_recovery(config['recovery_position_std'], config['recovery_yaw_std'],
                          config['recovery_min_new']),
            spatial_index=True if too_many_pairs else None, **algorithm_arguments(config))
        if self.refinder.paired_old(landmarks, second) <= \
                self.refinder.paired_old(landmarks, first):
            return first, pose
        self.refinder.kept(registration)
        self.statistics.refound += 1
        return second, moved

    def _answer_multi_hypothesis(self, config, msg, points, model, item, stamp: int,
                                 started: float) -> Optional[Answer]:
        tolerance = int(config['pose_tolerance'] * NS_PER_S)
        odometry, why = self.odometry_history.nearest(stamp, tolerance)
        if odometry is None:
            self._reject(self.statistics.skipped, 'no_odometry',
                         f'observation message skipped: odometry {why}')
            return None
        prior, _ = self.pose_history.nearest(stamp, tolerance)
        observations = observations_from_points(points, model, config['observation_noise'])
        association, hypotheses, past = self.multi_hypothesis.answer(
            config, item.landmarks, observations, odometry, prior or odometry, stamp)
        tree = self.multi_hypothesis.tree
        best = tree.nodes[max(tree.leaves, key=lambda i: tree.nodes[i].weight)]
        positions, _ = observations_in_map(observations, RobotPose(best.mean, best.covariance))
        map_header = Header(stamp=msg.header.stamp, frame_id=item.frame_id)
        answer = Answer(
            correspondences=correspondences_cloud(msg.header, association, positions,
                                                  association.extras['probability'],
                                                  isinstance(msg, SerializedCloud)),
            new_landmarks=None, markers=None, association=association,
            pose_hypotheses=array_to_cloud(hypotheses, map_header),
            past_associations=array_to_cloud(past, map_header))
        self.statistics.record_answer(association.assignment,
                                      (time.perf_counter() - started) * 1e3, False)
        return answer

    def _confirm(self, config: dict[str, Any], result: Association, positions: np.ndarray,
                 covariances: Optional[np.ndarray], stamp: int, model: str,
                 describe: bool) -> CandidateUpdate:
        """Feed the NEW observations (map frame) to the candidate landmarks; describe False: the
        confirmed landmarks may be left out of the update (with confirm_hits 1 they are only
        counted)."""
        settings = CANDIDATE_SETTINGS(config)
        if settings != self._candidate_settings:
            self.candidates.configure(*settings)
            self._candidate_settings = settings
        new = (result.assignment == NEW).nonzero()[0]
        if self.candidates.confirm_hits == 1 and not describe:
            self.candidates.count_confirmed(len(new))
            return CandidateUpdate((), ())
        try:
            return self.candidates.update(
                positions[new], None if covariances is None else covariances[new], stamp, new,
                model='box' if model == 'box' else 'point_map',
                euclidean=config['algorithm'] == 'euclidean_nn')
        except InvalidInputError as error:  # e.g. a degenerate map-frame covariance
            self.count_invalid('candidates', error)
            return CandidateUpdate((), ())
