"""lidar_tracker_node: 2-D LiDAR scans in, tracked rigid objects out (seed 003's tracker).

Subscribes `scan` (sensor_msgs/LaserScan) and `points` (sensor_msgs/PointCloud2 with `x`, `y` in
scan order, the sensor at the frame's origin); each message is one scan for
core.lidar.LidarObjectTracker (clusters, coarse + fine association, rigid correction, Kalman
update).  With `odometry` (nav_msgs/Odometry: the sensor's pose; the scan frame is taken to be its
child frame) the tracks live in the odometry's frame and each scan point is moved there with the
sensor pose at its beam's time (pipelines.lidar_tracking: ego motion between scans and, with a
LaserScan's time_increment, within one); without odometry in the scan's frame.  A LaserScan
whose beams go all the way round (msg_adapters.lidar.full_turn_of) is a full turn: an object
across its first and last beams is one object.  Publishes, with the scan's stamp and the
tracks' frame: `tracks` (PointCloud2, msg_adapters.lidar
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

from collections import deque

from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from msg_adapters import PointCloudFormatError, diagnostics_message, pose_from_odometry
from msg_adapters.lidar import (boundaries_cloud, full_turn_of, points_from_cloud,
                                points_from_scan, range_max_of, track_markers, tracks_cloud)

from ..core import InvalidInputError
from ..core.lidar import PARAMETERS, TrackerConfig
from ..core.parameters import ParameterSpec
from ..pipelines.lidar_tracking import LidarTracking
from ..pipelines.parameters import NodeParameter
from .parameterized_node import ParameterizedNode, spin, usage_text

RESTART_AFTER_S = 1.0
"""A scan this much older than the previous one restarts the tracker."""
MAX_WAITING_SCANS = 40
"""Scans kept waiting for the odometry of their time; beyond, the oldest is processed (with
extrapolated odometry, or dropped).  40 (1 s at 40 Hz): when both are ready the executor takes
one odometry and one scan message per round, so a node whose step nears the scan period falls
behind the 80 Hz odometry for a while; with 8 the F1Tenth race bag paced at 40 Hz lost 0-17 of
200 scans on a slower host (step median 16 ms), with 40 none in 4 runs (docs/lidar.md)."""


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
    NodeParameter('max_odometry_extrapolation', 0.1, 'a scan is moved with odometry poses at most '
                  'this far [s] beyond the newest (or before the oldest); further: dropped',
                  spec=ParameterSpec('max_odometry_extrapolation', 0.1, '', low=0.0,
                                     low_open=False)),
    NodeParameter('input_qos', 'sensor_data', 'QoS of scan and points: sensor_data (best '
                  'effort, as LiDAR drivers publish) or reliable', choices=('sensor_data',
                                                                           'reliable'),
                  read_only=True),
)


class LidarTrackerNode(ParameterizedNode):
    """The LiDAR tracker node (node name `lidar_tracker_node`, topics relative)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('lidar_tracker_node', LIDAR_NODE_PARAMETERS, **kwargs)
        self.tracking = LidarTracking()
        self.tracker = self.tracking.tracker
        self.invalid = self.invalid_odometry = self.odometry_count = 0
        self.waiting: deque = deque()
        self.step_ms: deque = deque(maxlen=100000)
        self.on_change()
        qos = qos_profile_sensor_data if self.config['input_qos'] == 'sensor_data' else \
            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        # odometry first: the executor takes ready subscriptions in creation order, and a scan
        # can only be processed once the odometry of its time is in
        self.create_subscription(Odometry, 'odometry', self._on_odometry,
                                 QoSProfile(depth=100, reliability=qos.reliability))
        self.create_subscription(LaserScan, 'scan', self._on_scan, qos)
        self.create_subscription(PointCloud2, 'points', self._on_points, qos)
        self.tracks_pub = self.create_publisher(PointCloud2, 'tracks', 10)
        self.boundaries_pub = self.create_publisher(PointCloud2, 'track_boundaries', 10)
        self.markers_pub = self.create_publisher(MarkerArray, 'track_markers', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.scans = 0
        self.last_step_ms = float('nan')
        self.create_timer(1.0, self.publish_diagnostics)
        self.ready_text = (f'lidar_tracker_node ready: coarse {self.config["coarse"]}, '
                           f'fine {self.config["fine"]}, jnis {self.config["jnis"]}')

    def on_change(self) -> None:
        self.tracker.configure(TrackerConfig(**{p.name: self.config[p.name]
                                                for p in PARAMETERS}))
        self.tracking.max_extrapolation = self.config['max_odometry_extrapolation']

    def _on_odometry(self, msg: Odometry) -> None:
        try:
            pose = pose_from_odometry(msg).mean
            self.tracking.add_odometry(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9,
                                       pose, msg.header.frame_id)
            self.odometry_count += 1
        except InvalidInputError as error:
            self.invalid_odometry += 1
            self.get_logger().warning(f'odometry dropped: {error}', throttle_duration_sec=5.0)
        while self.waiting and (self.tracking.covers(self.waiting[0][3])
                                or len(self.waiting) > MAX_WAITING_SCANS):
            self._process(*self.waiting.popleft()[:3])

    def _on_scan(self, msg: LaserScan) -> None:
        end = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9 + max(
            msg.time_increment, 0.0) * max(len(msg.ranges) - 1, 0)
        self._wait_or_process(msg.header, lambda: (points_from_scan(msg), range_max_of(msg),
                                                   full_turn_of(msg)),
                              msg.time_increment, end)

    def _on_points(self, msg: PointCloud2) -> None:
        self._wait_or_process(msg.header, lambda: (points_from_cloud(msg), None, False), 0.0,
                              msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)

    def _wait_or_process(self, header, convert, time_increment: float, end: float) -> None:
        """Process the scan (`convert`: its points, range_max or None, and whether it is a 360
        deg scan), or, when odometry is used and has not reached the scan's last beam time
        `end` [s] yet, keep it until it has (at most MAX_WAITING_SCANS kept)."""
        if self.waiting or (len(self.tracking.odometry) and not self.tracking.covers(end)):
            self.waiting.append((header, convert, time_increment, end))
            while len(self.waiting) > MAX_WAITING_SCANS:
                self._process(*self.waiting.popleft()[:3])
            return
        self._process(header, convert, time_increment)

    def _process(self, header, convert, time_increment: float = 0.0) -> None:
        stamp = header.stamp.sec + header.stamp.nanosec * 1e-9
        try:
            points, max_range, full_turn = convert()  # range_max: None for a cloud
            last = self.tracker.time
            if last is not None and stamp < last - RESTART_AFTER_S:
                self.get_logger().warning(f'scan {last - stamp:.2f} s older than the last: '
                                          'tracker restarted')
                self.tracking.reset()
            started = time.perf_counter()
            tracks = self.tracking.step(points, stamp, time_increment, header.frame_id,
                                        max_range, full_turn)
            self.last_step_ms = (time.perf_counter() - started) * 1e3
            self.step_ms.append(self.last_step_ms)
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
        header = Header(stamp=header.stamp, frame_id=self.tracking.frame or header.frame_id)
        self.tracks_pub.publish(tracks_cloud(header, tracks, stamp))
        self.boundaries_pub.publish(boundaries_cloud(
            header, [t.id for t in tracks],
            [t.boundary(spacing, most, self.tracker.sensor) for t in tracks]))
        if self.config['publish_markers']:
            self.markers_pub.publish(track_markers(header, tracks, stamp))


    def publish_diagnostics(self) -> None:
        """One DiagnosticArray: scans tracked, scans dropped, live tracks, last step time."""
        values = {'scans': self.scans, 'scans_dropped': self.invalid,
                  'odometry_dropped': self.invalid_odometry, 'frame': self.tracking.frame or '',
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
