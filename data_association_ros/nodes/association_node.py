"""association_node: landmarks + observations in, correspondences and new landmarks out.

Subscribes `landmarks` (PointCloud2, or PoseArray), `observations` (PointCloud2), `robot_pose`
(Odometry), `state_covariance` (PointCloud2 of the joint covariance's rows, optional) and
`odometry` (multi_hypothesis);
publishes per observation message `correspondences` (PointCloud2: observation, landmark id or
-1 NEW / -2 UNASSOCIATED, nis, ...), `new_landmarks`, `landmark_candidates`,
`estimated_transform`, `pose_hypotheses`, `past_associations`, `association_markers`, and
`/diagnostics` (README "Topics").

Thin by design (DESIGN.md 2): parameters, subscriptions and publishing; the work (time
matching, adapters, the core) is AssociationPipeline's.  No input is ever fatal.
"""
from __future__ import annotations

import time
from collections import deque
from typing import Optional

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from msg_adapters import diagnostics_message, packing_kernels
from msg_adapters.serialized_cloud import SerializedCloud

from ..core import problem_kernels
from ..core.associators import jcbb_compiled
from ..pipelines.association import AssociationPipeline
from ..pipelines.parameters import NODE_PARAMETERS, check_combination
from ..pipelines.warm_up import warm_up
from .parameterized_node import ParameterizedNode, spin, usage_text

MAX_WAITING = 10
"""Observation messages waiting for their pose; beyond, the oldest is answered at once."""


class AssociationNode(ParameterizedNode):
    """The association node (node name `association_node`, topics relative, DESIGN.md 4)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('association_node', NODE_PARAMETERS, check_combination, **kwargs)
        config = self.config
        self.pipeline = AssociationPipeline(config, warn=self.get_logger().warning)
        # JIT, thresholds, first calls: done before any topic exists, so that no scan waits
        self.start_up_seconds = warm_up(config)
        if not self.start_up_seconds['compiled']:
            self.get_logger().info('kernels not compiled (same answers, slower): '
                                   f'{problem_kernels.KERNELS.unavailable_reason() or "-"}; '
                                   f'{jcbb_compiled.unavailable_reason() or "-"}; '
                                   f'{packing_kernels.KERNELS.unavailable_reason() or "-"}')

        qos = QoSProfile(depth=config['qos_depth'], reliability=(
            ReliabilityPolicy.BEST_EFFORT if config['input_qos'] == 'sensor_data'
            else ReliabilityPolicy.RELIABLE))
        # a prior map is published once, transient_local, as map servers do: a late joiner
        # still gets it
        map_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL) \
            if config['prior_map'] else qos
        if config['landmarks_type'] == 'pose_array':
            self.create_subscription(PoseArray, 'landmarks',
                                     self._then_waiting(self.pipeline.on_pose_array), map_qos)
        else:
            self.create_subscription(PointCloud2, 'landmarks',
                                     self._then_waiting(self.pipeline.on_landmarks), map_qos)
        self.create_subscription(Odometry, 'robot_pose', self._on_robot_pose, qos)
        self.create_subscription(PointCloud2, 'state_covariance',
                                 self._then_waiting(self.pipeline.on_state_covariance), qos)
        self.create_subscription(Odometry, 'odometry',
                                 self._then_waiting(self.pipeline.on_odometry), qos)
        # Created last: when inputs of one scan wait together, the executor serves
        # subscriptions in creation order, so map and pose are taken before the scan.
        # raw: the scan read from its bytes and its correspondences published as bytes
        # (msg_adapters/serialized_cloud.py): rclpy's message objects cost ~0.1 ms a scan
        self.create_subscription(PointCloud2, 'observations', self._on_serialized_observations,
                                 qos, raw=True)
        self.correspondences_pub = self.create_publisher(PointCloud2, 'correspondences', 10)
        self.new_landmarks_pub = self.create_publisher(PointCloud2, 'new_landmarks', 10)
        self.candidates_pub = self.create_publisher(PointCloud2, 'landmark_candidates', 10)
        self.markers_pub = self.create_publisher(MarkerArray, 'association_markers', 10)
        self.hypotheses_pub = self.create_publisher(PointCloud2, 'pose_hypotheses', 10)
        self.past_pub = self.create_publisher(PointCloud2, 'past_associations', 10)
        self.transform_pub = self.create_publisher(PoseWithCovarianceStamped,
                                                   'estimated_transform', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_timer(config['diagnostics_period'], self.publish_diagnostics)
        self._waiting: deque = deque()   # (observation message, wall time it arrived)
        # runs only while messages wait: an idle node is not woken 20 times a second (each
        # wake-up rebuilds the executor's wait set, and a scan arriving then waits for it)
        self._waiting_timer = self.create_timer(0.05, self._answer_waiting)
        self._waiting_timer.cancel()
        self.ready_text = (f'association_node ready: algorithm {config["algorithm"]}, '
                           f'measurement_model {config["measurement_model"]}')

    @property
    def statistics(self):
        """Counters and latency (AssociationStatistics)."""
        return self.pipeline.statistics

    def _on_robot_pose(self, msg: Odometry) -> None:
        self.pipeline.on_robot_pose(msg)
        self._answer_waiting()

    def _then_waiting(self, handler):
        """`handler`, then answer the observation messages that waited for its input."""
        def callback(msg) -> None:
            handler(msg)
            if self._waiting:
                self._answer_waiting()
        return callback

    def _on_serialized_observations(self, raw: bytes) -> None:
        msg = SerializedCloud.from_cdr(raw)
        if msg is None:   # not plain CDR or not a whole cloud: rclpy's deserialization decides
            try:
                msg = deserialize_message(raw, PointCloud2)
            except Exception as error:  # no input is fatal
                self.pipeline.count_invalid('observations', error)
                return
        self._on_observations(msg)

    def _on_observations(self, msg) -> None:
        if self._waiting or self.pipeline.inputs_pending(msg):
            self._waiting.append((msg, time.monotonic()))   # keeps the arrival order
            if len(self._waiting) > MAX_WAITING:
                self._answer(self._waiting.popleft()[0])
            self._answer_waiting()
            if self._waiting and self._waiting_timer.is_canceled():
                self._waiting_timer.reset()
            return
        self._answer(msg)

    def _answer_waiting(self) -> None:
        """Answer the waiting observation messages, oldest first, whose pose has come (or
        whose wait is over)."""
        while self._waiting:
            msg, since = self._waiting[0]
            if self.pipeline.inputs_pending(msg) and \
                    time.monotonic() - since < self.config['pose_wait']:
                return
            self._waiting.popleft()
            self._answer(msg)
        self._waiting_timer.cancel()

    def _answer(self, msg) -> None:
        # the optional outputs only for topics someone subscribes to (building them costs)
        wanted = {topic for topic, publisher in (
            ('new_landmarks', self.new_landmarks_pub), ('landmark_candidates', self.candidates_pub),
            ('association_markers', self.markers_pub)) if publisher.get_subscription_count()}
        answer = self.pipeline.answer(msg, wanted)
        if answer is None:
            return
        # new landmarks first: a SLAM node then has them when the scan's answer arrives
        if answer.new_landmarks is not None:
            self.new_landmarks_pub.publish(answer.new_landmarks)
        self.correspondences_pub.publish(answer.correspondences)
        if answer.candidates is not None:
            self.candidates_pub.publish(answer.candidates)
        if answer.markers is not None:
            self.markers_pub.publish(answer.markers)
        if answer.pose_hypotheses is not None:
            self.hypotheses_pub.publish(answer.pose_hypotheses)
            self.past_pub.publish(answer.past_associations)
        if answer.transform is not None:
            self.transform_pub.publish(answer.transform)

    def publish_diagnostics(self) -> None:
        """One DiagnosticArray with the algorithm, latency and counters."""
        statistics = self.statistics
        values = {'algorithm': self.config['algorithm'],
                  'measurement_model': self.config['measurement_model'],
                  **statistics.key_values()}
        problems = bool(statistics.skipped or statistics.invalid or statistics.fallbacks)
        self.diagnostics_pub.publish(diagnostics_message(
            self.get_clock().now().to_msg(), self.get_name(), values, warn=problems,
            message='some messages skipped, invalid or answered with a fallback' if problems
            else 'ok'))


def main(args: Optional[list[str]] = None) -> None:
    """Entry point of the `association_node` executable."""
    spin(AssociationNode, args, usage_text('association_node', __doc__, NODE_PARAMETERS,
                                           'README.md "Parameters"'))


if __name__ == '__main__':
    main()
