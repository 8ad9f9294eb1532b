"""association_node: landmarks + observations in, correspondences and new landmarks out.

Thin by design (DESIGN.md 2): parameters, subscriptions, time matching, one call to the core,
publishing, diagnostics.  Every message is answered or counted; no input is ever fatal.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Float64MultiArray
from visualization_msgs.msg import MarkerArray

from msg_adapters import (PointCloudFormatError, association_markers, cloud_to_array,
                          correspondences_cloud, detect_model, diagnostics_message,
                          joint_covariance_from_array, landmarks_from_cloud,
                          landmarks_from_pose_array, new_landmarks_cloud,
                          observations_from_points, pose_from_odometry)

from .core import InvalidInputError, Landmarks, associate
from .core.initialisation import observations_in_map
from .core.models import MODELS
from .node_parameters import BY_NAME, NODE_PARAMETERS, algorithm_arguments
from .stamped_buffer import StampedBuffer
from .statistics import AssociationStatistics

NS_PER_S = 1_000_000_000
INPUT_ERRORS = (InvalidInputError, PointCloudFormatError)


@dataclass(frozen=True)
class StampedLandmarks:
    """A landmarks message converted once on arrival."""

    landmarks: Landmarks
    frame_id: str
    box: bool


def _descriptor(parameter) -> ParameterDescriptor:
    spec = parameter.spec
    descriptor = ParameterDescriptor(
        name=parameter.name, read_only=parameter.read_only,
        description=f'{parameter.description} (valid: {parameter.range_text()})')
    if spec is not None and spec.low is not None and spec.high is not None:
        if spec.kind is float:
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(spec.low), to_value=float(spec.high), step=0.0)]
        elif spec.kind is int:
            descriptor.integer_range = [IntegerRange(from_value=int(spec.low),
                                                     to_value=int(spec.high), step=0)]
    return descriptor


class AssociationNode(Node):
    """The association node (node name `association_node`, topics relative, DESIGN.md 4)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('association_node', **kwargs)
        for parameter in NODE_PARAMETERS:
            self.declare_parameter(parameter.name, parameter.default, _descriptor(parameter))
        self.config: dict[str, Any] = {}
        for parameter in NODE_PARAMETERS:
            value = self.get_parameter(parameter.name).value
            try:
                self.config[parameter.name] = parameter.check(value)
            except InvalidInputError as error:
                self.get_logger().error(f'{error}; using the default {parameter.default!r}')
                self.config[parameter.name] = parameter.default
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self.statistics = AssociationStatistics()
        self.landmark_history: StampedBuffer[StampedLandmarks] = StampedBuffer(50)
        self.pose_history: StampedBuffer = StampedBuffer(200)
        self.state_covariance: Optional[np.ndarray] = None

        qos = QoSProfile(depth=self.config['qos_depth'], reliability=(
            ReliabilityPolicy.BEST_EFFORT if self.config['input_qos'] == 'sensor_data'
            else ReliabilityPolicy.RELIABLE))
        if self.config['landmarks_type'] == 'pose_array':
            self.create_subscription(PoseArray, 'landmarks', self._on_pose_array, qos)
        else:
            self.create_subscription(PointCloud2, 'landmarks', self._on_landmarks, qos)
        self.create_subscription(PointCloud2, 'observations', self._on_observations, qos)
        self.create_subscription(Odometry, 'robot_pose', self._on_robot_pose, qos)
        self.create_subscription(Float64MultiArray, 'state_covariance',
                                 self._on_state_covariance, qos)
        self.correspondences_pub = self.create_publisher(PointCloud2, 'correspondences', 10)
        self.new_landmarks_pub = self.create_publisher(PointCloud2, 'new_landmarks', 10)
        self.markers_pub = self.create_publisher(MarkerArray, 'association_markers', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_timer(self.config['diagnostics_period'], self.publish_diagnostics)
        self.get_logger().info(f'association_node ready: algorithm {self.config["algorithm"]}, '
                               f'measurement_model {self.config["measurement_model"]}')

    # --- parameters: validate in one callback, apply in another ---------------------------
    def _validate_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        for parameter in parameters:
            known = BY_NAME.get(parameter.name)
            if known is None:
                continue
            try:
                known.check(parameter.value)
            except InvalidInputError as error:
                return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters: list[Parameter]) -> None:
        for parameter in parameters:
            known = BY_NAME.get(parameter.name)
            if known is None:
                continue
            old = self.config.get(parameter.name)
            self.config[parameter.name] = known.check(parameter.value)
            self.get_logger().info(f'{parameter.name}: {old!r} -> {self.config[parameter.name]!r}'
                                   ' (from the next observation message)')

    # --- inputs ------------------------------------------------------------------------------
    def _warn(self, cause: str, text: str) -> None:
        if self.statistics.should_warn(cause, time.monotonic()):
            self.get_logger().warning(f'{text} (further {cause!r} warnings throttled)')

    def _reject(self, counter, cause: str, text: str) -> None:
        counter[cause] += 1
        self._warn(cause, text)

    def _on_landmarks(self, msg: PointCloud2) -> None:
        try:
            points = cloud_to_array(msg)
            box = points.dtype.names is not None and {'width', 'height'} <= set(points.dtype.names)
            landmarks = landmarks_from_cloud(msg, self.config['default_landmark_covariance'], box)
        except INPUT_ERRORS as error:
            self._reject(self.statistics.invalid, 'landmarks', f'landmarks rejected: {error}')
            return
        self._store_landmarks(msg.header, StampedLandmarks(landmarks, msg.header.frame_id, box))

    def _on_pose_array(self, msg: PoseArray) -> None:
        try:
            landmarks = landmarks_from_pose_array(msg, self.config['default_landmark_covariance'])
        except INPUT_ERRORS as error:
            self._reject(self.statistics.invalid, 'landmarks', f'landmarks rejected: {error}')
            return
        self._store_landmarks(msg.header, StampedLandmarks(landmarks, msg.header.frame_id, False))

    def _store_landmarks(self, header, item: StampedLandmarks) -> None:
        self.landmark_history.add(Time.from_msg(header.stamp).nanoseconds, item)

    def _on_robot_pose(self, msg: Odometry) -> None:
        try:
            pose = pose_from_odometry(msg)
        except INPUT_ERRORS as error:
            self._reject(self.statistics.invalid, 'robot_pose', f'robot_pose rejected: {error}')
            return
        self.pose_history.add(Time.from_msg(msg.header.stamp).nanoseconds, pose)

    def _on_state_covariance(self, msg: Float64MultiArray) -> None:
        try:
            matrix = joint_covariance_from_array(msg)
        except INPUT_ERRORS as error:
            self._reject(self.statistics.invalid, 'state_covariance',
                         f'state_covariance rejected: {error}')
            return
        self.state_covariance = matrix

    def _on_observations(self, msg: PointCloud2) -> None:
        started = time.perf_counter()
        try:
            self._answer(msg, started)
        except INPUT_ERRORS as error:
            self._reject(self.statistics.invalid, 'observations',
                         f'observations rejected: {error}')
        except Exception as error:  # never let one message take the node down
            self._reject(self.statistics.invalid, 'internal_error',
                         f'observation message dropped by an internal error: {error!r}')

    # --- association -------------------------------------------------------------------------
    def _answer(self, msg: PointCloud2, started: float) -> None:
        config = dict(self.config)
        stamp = Time.from_msg(msg.header.stamp).nanoseconds
        item, why = self.landmark_history.latest_not_after(
            stamp, int(config['max_landmark_age'] * NS_PER_S))
        if item is None:
            self._reject(self.statistics.skipped, 'no_landmarks',
                         f'observation message skipped: landmarks {why}')
            return
        points = cloud_to_array(msg)
        model = config['measurement_model']
        if model == 'auto':
            model = detect_model(points.dtype.names or (), msg.header.frame_id, item.frame_id)
        pose = None
        if MODELS[model].needs_pose:
            pose, why = self.pose_history.nearest(stamp, int(config['pose_tolerance'] * NS_PER_S))
            if pose is None:
                self._reject(self.statistics.skipped, 'no_pose',
                             f'observation message skipped: robot pose {why}')
                return
        observations = observations_from_points(points, model, config['observation_noise'])
        landmarks = item.landmarks
        state_covariance = self.state_covariance
        if state_covariance is not None and \
                state_covariance.shape[0] != 3 + len(landmarks) * landmarks.dim:
            state_covariance = None
        result = associate(landmarks, observations, config['algorithm'], pose=pose,
                           state_covariance=state_covariance, **algorithm_arguments(config))
        positions, covariances = observations_in_map(observations, pose)
        header = msg.header
        self.correspondences_pub.publish(correspondences_cloud(header, result, positions))
        map_header = type(header)(stamp=header.stamp, frame_id=item.frame_id)
        new = new_landmarks_cloud(map_header, result, positions, covariances)
        if new is not None:
            self.new_landmarks_pub.publish(new)
        if config['publish_markers']:
            self.markers_pub.publish(association_markers(map_header, result, positions,
                                                         landmarks.ids, landmarks.means))
        self.statistics.record_answer(result.assignment, (time.perf_counter() - started) * 1e3,
                                      result.truncated)

    def publish_diagnostics(self) -> None:
        """One DiagnosticArray with the algorithm, latency and counters."""
        values = {'algorithm': self.config['algorithm'],
                  'measurement_model': self.config['measurement_model'],
                  **self.statistics.key_values()}
        problems = bool(self.statistics.skipped or self.statistics.invalid)
        self.diagnostics_pub.publish(diagnostics_message(
            self.get_clock().now().to_msg(), self.get_name(), values, warn=problems,
            message='some messages skipped or invalid' if problems else 'ok'))


def main(args: Optional[list[str]] = None) -> None:
    """Entry point of the `association_node` executable."""
    rclpy.init(args=args if args is not None else sys.argv)
    node = AssociationNode()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == '__main__':
    main()
