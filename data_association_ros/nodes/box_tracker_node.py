"""box_tracker_node: box detections in, Kalman box tracks out (SORT-style, any box associator).

Subscribes `observations` (PointCloud2: x, y = box centre, width, height[, score]); each message
is one frame: predict, associate (parameter `algorithm`), update, confirm after `min_hits`,
delete after `max_age` (core.tracking.BoxTracker).  Publishes the frame's reported tracks on
`landmarks` (PointCloud2: id, x, y, width, height; the detection message's header), so an
association_node can take them as its landmarks.  A malformed message is counted and dropped.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2

from msg_adapters import PointCloudFormatError, array_to_cloud, cloud_to_array

from ..core import InvalidInputError
from ..core.associators import REGISTRY
from ..core.parameters import ParameterSpec
from ..core.tracking import BoxTracker
from ..pipelines.parameters import BY_NAME, NodeParameter
from .parameterized_node import ParameterizedNode, spin, usage_text

TRACK_DTYPE = np.dtype([('id', '<i4'), ('x', '<f4'), ('y', '<f4'), ('width', '<f4'),
                        ('height', '<f4')])
BOX_ALGORITHMS = tuple(name for name, a in REGISTRY.items() if 'box' in a.models)
TRACKER_PARAMETERS = (
    NodeParameter('algorithm', 'iou', 'associator of detections to predicted tracks',
                  choices=BOX_ALGORITHMS),
    NodeParameter('min_hits', 3, 'a track is reported once updated on this many frames in a '
                  'row (and during the first min_hits frames)',
                  spec=ParameterSpec('min_hits', 3, '', kind=int, low=0, high=1000)),
    NodeParameter('max_age', 1, 'a track not updated for more than this many frames is deleted',
                  spec=ParameterSpec('max_age', 1, '', kind=int, low=0, high=1000)),
    BY_NAME['iou_threshold'], BY_NAME['gate_probability'],
    NodeParameter('noise_scale', 1.0, "multiplies SORT's measurement and process noise (new "
                  'tracks; matters to covariance-gated associators)',
                  spec=ParameterSpec('noise_scale', 1.0, '', low=0.0, low_open=True)),
)


class BoxTrackerNode(ParameterizedNode):
    """The box tracker node (node name `box_tracker_node`, topics relative)."""

    def __init__(self, **kwargs) -> None:
        super().__init__('box_tracker_node', TRACKER_PARAMETERS, **kwargs)
        self.tracker = BoxTracker()
        self.invalid = 0
        self.on_change()
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.create_subscription(PointCloud2, 'observations', self._on_detections, qos)
        self.tracks_pub = self.create_publisher(PointCloud2, 'landmarks', 10)
        self.ready_text = f'box_tracker_node ready: algorithm {self.config["algorithm"]}'

    def on_change(self) -> None:
        config = self.config
        associator = REGISTRY[config['algorithm']]
        names = {spec.name for spec in associator.parameters}
        parameters = {k: config[k] for k in ('iou_threshold', 'gate_probability') if k in names}
        self.tracker.configure(config['algorithm'], config['min_hits'], config['max_age'],
                               parameters, config['noise_scale'])

    def _on_detections(self, msg: PointCloud2) -> None:
        try:
            points = cloud_to_array(msg)
            missing = {'x', 'y', 'width', 'height'} - set(points.dtype.names or ())
            if missing:
                raise InvalidInputError(f'observations: fields {sorted(missing)} missing')
            boxes = np.column_stack([points[n].astype(float) for n in
                                     ('x', 'y', 'width', 'height')]).reshape(-1, 4)
            reported = self.tracker.step(boxes)
        except (InvalidInputError, PointCloudFormatError) as error:
            self.invalid += 1
            self.get_logger().warning(f'detections rejected: {error}',
                                      throttle_duration_sec=5.0)
            return
        tracks = np.zeros(len(reported), dtype=TRACK_DTYPE)
        for row, (track_id, box) in zip(tracks, reported):
            row['id'] = track_id
            row['x'], row['y'], row['width'], row['height'] = box
        self.tracks_pub.publish(array_to_cloud(tracks, msg.header))


def main(args: Optional[list[str]] = None) -> None:
    """Entry point of the `box_tracker_node` executable."""
    spin(BoxTrackerNode, args,
         usage_text('box_tracker_node', __doc__, TRACKER_PARAMETERS, 'docs/mot.md'))


if __name__ == '__main__':
    main()
