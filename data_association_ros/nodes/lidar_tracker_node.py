"""lidar_tracker_node: 2-D LiDAR scans in, tracked rigid objects out (seed 003's tracker).

Subscribes `scan` (sensor_msgs/LaserScan) and `points` (sensor_msgs/PointCloud2 with `x`, `y` in
scan order, the sensor at the frame's origin); each message is one scan for
core.lidar.LidarObjectTracker (clusters, coarse + fine association, rigid correction, Kalman
update).  Publishes, with the scan's header: `tracks` (PointCloud2, msg_adapters.lidar
TRACK_DTYPE: the reported tracks), `track_boundaries` (PointCloud2: id, x, y of each reported
track's visible boundary points) and, when publish_markers, `track_markers` (MarkerArray);
`/diagnostics` every second (scans tracked and dropped, live tracks, last step time).
Every parameter can change at run time except input_qos.  A malformed scan (bad angles, missing
fields) or one not newer than the last is counted and dropped, never fatal; a scan more than
1 s older than the last restarts the tracker (a bag played again).
"""
from __future__ import annotations

import time
from typing import Optional

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan, PointCloud2
from visualization_msgs.msg import MarkerArray

from msg_adapters import PointCloudFormatError, diagnostics_message
from msg_adapters.lidar import (boundaries_cloud, points_from_cloud, points_from_scan,
                                track_markers, tracks_cloud)

from ..core import InvalidInputError
from ..core.lidar import PARAMETERS, LidarObjectTracker, TrackerConfig
from ..core.parameters import ParameterSpec
from ..pipelines.parameters import NodeParameter
from .parameterized_node import ParameterizedNode, spin, usage_text

RESTART_AFTER_S = 1.0
"""A scan this much older than the previous one restarts the tracker."""


def _node_parameter(parameter) -> NodeParameter:
    if isinstance(parameter, ParameterSpec):
        return NodeParameter(parameter.name, parameter.default, parameter.description,
                             spec=parameter)
    return NodeParameter(parameter.name, parameter.default, parameter.description,
                         choices=parameter.choices)


LIDAR_NODE_PARAMETERS = (
    *(_node_parameter(p) for p in PARAMETERS),
    NodeParameter('publish_markers', False, 'publish track_markers (costs time)',
                  spec=ParameterSpec('publish_markers', False, '', kind=bool)),
    NodeParameter('input_qos', 'sensor_data', 'QoS of scan and points: sensor_data (best '
                  'effort, as LiDAR drivers publish) or reliable', choices=('sensor_data',
                                                                           'reliable'),
                  read_only=True),
)


class LidarTrackerNode(ParameterizedNode):
    """The LiDAR tracker node (node name `lidar_tracker_node`, topics relative)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('lidar_tracker_node', LIDAR_NODE_PARAMETERS, **kwargs)
        self.tracker = LidarObjectTracker()
        self.invalid = 0
        self.on_change()
        qos = qos_profile_sensor_data if self.config['input_qos'] == 'sensor_data' else \
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.create_subscription(LaserScan, 'scan', self._on_scan, qos)
        self.create_subscription(PointCloud2, 'points', self._on_points, qos)
        self.tracks_pub = self.create_publisher(PointCloud2, 'tracks', 10)
        self.boundaries_pub = self.create_publisher(PointCloud2, 'track_boundaries', 10)
        self.markers_pub = self.create_publisher(MarkerArray, 'track_markers', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.scans = 0
        self.last_step_ms = float('nan')
        self.create_timer(1.0, self.publish_diagnostics)
        self.get_logger().info(f'lidar_tracker_node ready: coarse {self.config["coarse"]}, '
                               f'fine {self.config["fine"]}, jnis {self.config["jnis"]}')

    def on_change(self) -> None:
        self.tracker.configure(TrackerConfig(**{p.name: self.config[p.name]
                                                for p in PARAMETERS}))

    def _on_scan(self, msg: LaserScan) -> None:
        self._process(msg.header, lambda: points_from_scan(msg))

    def _on_points(self, msg: PointCloud2) -> None:
        self._process(msg.header, lambda: points_from_cloud(msg))

    def _process(self, header, convert) -> None:
        stamp = header.stamp.sec + header.stamp.nanosec * 1e-9
        try:
            points = convert()
            last = self.tracker.time
            if last is not None and stamp < last - RESTART_AFTER_S:
                self.get_logger().warning(f'scan {last - stamp:.2f} s older than the last: '
                                          'tracker restarted')
                self.tracker.reset()
            started = time.perf_counter()
            tracks = self.tracker.step(points, stamp)
            self.last_step_ms = (time.perf_counter() - started) * 1e3
            self.scans += 1
        except (InvalidInputError, PointCloudFormatError) as error:
            self.invalid += 1
            self.get_logger().warning(f'scan dropped ({self.invalid} so far): {error}',
                                      throttle_duration_sec=5.0)
            return
        except Exception as error:  # never let one scan take the node down
            self.invalid += 1
            self.get_logger().error(f'scan dropped by an internal error ({self.invalid} so '
                                    f'far): {error!r}', throttle_duration_sec=5.0)
            return
        spacing, most = self.tracker.config.boundary_spacing, \
            self.tracker.config.max_boundary_points
        self.tracks_pub.publish(tracks_cloud(header, tracks, stamp))
        self.boundaries_pub.publish(boundaries_cloud(
            header, [t.id for t in tracks], [t.boundary(spacing, most) for t in tracks]))
        if self.config['publish_markers']:
            self.markers_pub.publish(track_markers(header, tracks, stamp))


    def publish_diagnostics(self) -> None:
        """One DiagnosticArray: scans tracked, scans dropped, live tracks, last step time."""
        values = {'scans': self.scans, 'scans_dropped': self.invalid,
                  'tracks': len(self.tracker.tracks),
                  'last_step_ms': f'{self.last_step_ms:.2f}'}
        self.diagnostics_pub.publish(diagnostics_message(
            self.get_clock().now().to_msg(), self.get_name(), values, warn=self.invalid > 0,
            message='some scans dropped' if self.invalid else 'ok'))


def main(args: Optional[list[str]] = None) -> None:
    """Entry point of the `lidar_tracker_node` executable."""
    spin(LidarTrackerNode, args,
         usage_text('lidar_tracker_node', __doc__, LIDAR_NODE_PARAMETERS, 'docs/lidar.md'))


if __name__ == '__main__':
    main()
