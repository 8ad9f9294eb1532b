"""ekf_slam_node: a 2-D EKF-SLAM that closes the loop with association_node (example consumer).

Subscribes `odometry` (nav_msgs/Odometry; covariance = noise of the increment since the previous
message), `sensor_observations` (PointCloud2, robot frame), `correspondences` and
`new_landmarks` (from association_node) and, with association_source ground_truth,
`ground_truth/correspondences`.  Publishes per scan `landmarks`, `robot_pose`,
`state_covariance`, then `observations` (the scan, forwarded), and after the scan's update
`slam_pose` (nav_msgs/Odometry) and `slam_map` (PointCloud2: id, x, y, cov_*, origin_stamp_sec,
origin_stamp_nanosec, origin_observation).  The work is SlamPipeline's; no input is fatal.
"""
from __future__ import annotations

from typing import Optional

from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import PointCloud2

from msg_adapters import diagnostics_message

from ..pipelines.slam import SLAM_PARAMETERS, SlamPipeline
from .parameterized_node import ParameterizedNode, spin, usage_text

QOS_DEPTH = 100
OUTPUT_TYPES = {'landmarks': PointCloud2, 'robot_pose': Odometry,
                'state_covariance': PointCloud2, 'observations': PointCloud2,
                'slam_map': PointCloud2, 'slam_pose': Odometry}


class EkfSlamNode(ParameterizedNode):
    """The EKF-SLAM node (node name `ekf_slam_node`, topics relative)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('ekf_slam_node', SLAM_PARAMETERS, **kwargs)
        self.pipeline = SlamPipeline(self.config, warn=self.get_logger().warning)
        qos = QoSProfile(depth=QOS_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        sensor_qos = qos_profile_sensor_data if self.config['input_qos'] == 'sensor_data' \
            else qos
        self.publishers_by_topic = {topic: self.create_publisher(kind, topic, qos)
                                    for topic, kind in OUTPUT_TYPES.items()}
        pipeline = self.pipeline
        # Creation order = service order when several wait together: new landmarks before the
        # answer of the same scan, odometry before the scan.
        for kind, topic, handler, profile in (
                (PointCloud2, 'new_landmarks', pipeline.on_new_landmarks, qos),
                (PointCloud2, 'correspondences', pipeline.on_correspondences, qos),
                (PointCloud2, 'ground_truth/correspondences', pipeline.on_ground_truth, qos),
                (Odometry, 'odometry', pipeline.on_odometry, sensor_qos),
                (PointCloud2, 'sensor_observations', pipeline.on_scan, sensor_qos)):
            self.create_subscription(kind, topic, self._publishing(handler), profile)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_timer(1.0, self.publish_diagnostics)
        self.ready_text = ('ekf_slam_node ready: association_source '
                           f'{self.config["association_source"]}')

    def _publishing(self, handler):
        def callback(msg) -> None:
            try:
                outputs = handler(msg)
            except Exception as error:  # never let one message take the node down
                self.pipeline.statistics.invalid['internal_error'] += 1
                self.get_logger().error(f'message dropped by an internal error: {error!r}',
                                        throttle_duration_sec=5.0)
                return
            for topic, out in outputs:
                self.publishers_by_topic[topic].publish(out)
        return callback

    def publish_diagnostics(self) -> None:
        """One DiagnosticArray with the SLAM counters and map size."""
        statistics = self.pipeline.statistics
        slam = self.pipeline.slam
        values = {'association_source': self.config['association_source'],
                  'map_landmarks': 0 if slam is None else len(slam),
                  **statistics.key_values()}
        problems = bool(statistics.invalid or statistics.dropped)
        self.diagnostics_pub.publish(diagnostics_message(
            self.get_clock().now().to_msg(), self.get_name(), values, warn=problems,
            message='some messages rejected or dropped' if problems else 'ok'))


def main(args: Optional[list[str]] = None) -> None:
    """Entry point of the `ekf_slam_node` executable."""
    spin(EkfSlamNode, args, usage_text('ekf_slam_node', __doc__, SLAM_PARAMETERS, 'docs/slam.md'))


if __name__ == '__main__':
    main()
