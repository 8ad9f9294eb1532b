"""The bag topics and the messages of one scan (inputs and ground truth)."""
from __future__ import annotations

import numpy as np
from nav_msgs.msg import Odometry
from std_msgs.msg import Header

from msg_adapters import array_to_cloud, odometry_message, state_covariance_cloud
from msg_adapters.outputs import CORRESPONDENCE_DTYPE

from .scenarios import Scan

LANDMARKS = '/landmarks'
OBSERVATIONS = '/observations'
ROBOT_POSE = '/robot_pose'
ODOMETRY = '/odometry'
STATE_COVARIANCE = '/state_covariance'
GROUND_TRUTH = '/ground_truth/correspondences'
CORRESPONDENCES = '/correspondences'
NEW_LANDMARKS = '/new_landmarks'
SENSOR_OBSERVATIONS = '/sensor_observations'
GROUND_TRUTH_POSE = '/ground_truth/pose'
GROUND_TRUTH_LANDMARKS = '/ground_truth/landmarks'
SLAM_MAP = '/slam_map'
SLAM_POSE = '/slam_pose'
POINT_CLOUD, ODOMETRY_TYPE = 'sensor_msgs/msg/PointCloud2', 'nav_msgs/msg/Odometry'
EXPECTED_TYPES = {
    LANDMARKS: (POINT_CLOUD, 'geometry_msgs/msg/PoseArray'), OBSERVATIONS: (POINT_CLOUD,),
    ROBOT_POSE: (ODOMETRY_TYPE,), ODOMETRY: (ODOMETRY_TYPE,),
    STATE_COVARIANCE: (POINT_CLOUD,), GROUND_TRUTH: (POINT_CLOUD,),
    CORRESPONDENCES: (POINT_CLOUD,), NEW_LANDMARKS: (POINT_CLOUD,),
    SENSOR_OBSERVATIONS: (POINT_CLOUD,), GROUND_TRUTH_POSE: (ODOMETRY_TYPE,),
    GROUND_TRUTH_LANDMARKS: (POINT_CLOUD,), SLAM_MAP: (POINT_CLOUD,), SLAM_POSE: (ODOMETRY_TYPE,),
    '/ground_truth/tracks': (POINT_CLOUD,), '/ground_truth/objects': (POINT_CLOUD,),
    '/scan': ('sensor_msgs/msg/LaserScan',)}
"""The message types the bag tools read on each topic (BagReader checks them)."""
INPUT_TOPICS = (LANDMARKS, ROBOT_POSE, ODOMETRY, STATE_COVARIANCE, OBSERVATIONS)
OUTPUT_TOPICS = (CORRESPONDENCES, NEW_LANDMARKS)
INPUT_LEAD_NS = 10_000_000
"""Map, pose and joint covariance are logged this long before the scan's observations."""


def header(time_ns: int, frame: str) -> Header:
    """A Header stamped `time_ns` in `frame`."""
    h = Header(frame_id=frame)
    h.stamp.sec, h.stamp.nanosec = divmod(int(time_ns), 1_000_000_000)
    return h


def _cloud(columns: dict[str, np.ndarray], stamp: int, frame: str, integer=('id',)):
    n = len(next(iter(columns.values()))) if columns else 0
    points = np.zeros(n, dtype=[(k, '<i4' if k in integer else '<f4') for k in columns])
    for k, v in columns.items():
        points[k] = v
    return array_to_cloud(points, header(stamp, frame))


def odometry_at(mean: np.ndarray, covariance: np.ndarray, time_ns: int,
                frame: str = 'map') -> Odometry:
    """nav_msgs/Odometry stamped `time_ns` in `frame` with pose (x, y, yaw) and its covariance."""
    return odometry_message(header(time_ns, frame), mean, covariance)


def scan_messages(scan: Scan) -> list[tuple[str, object, int]]:
    """(topic, message, log time ns) of one scan: inputs first, then observations and truth."""
    t = scan.time_ns
    lead = t - INPUT_LEAD_NS
    messages = []
    if scan.landmark_ids is not None:     # a prior map is published once, with the first scan
        columns = {'id': scan.landmark_ids}
        names = ('x', 'y', 'width', 'height') if scan.landmark_means.shape[1] == 4 \
            else ('x', 'y')
        for k, name in enumerate(names):
            columns[name] = scan.landmark_means[:, k]
        if scan.landmark_covariances is not None:
            columns['cov_xx'] = scan.landmark_covariances[:, 0, 0]
            columns['cov_xy'] = scan.landmark_covariances[:, 0, 1]
            columns['cov_yy'] = scan.landmark_covariances[:, 1, 1]
        messages.append((LANDMARKS, _cloud(columns, t, scan.map_frame), lead))
    if scan.pose is not None:
        messages.append((ROBOT_POSE, odometry_at(*scan.pose, t, scan.map_frame), lead))
    if scan.odometry is not None:
        messages.append((ODOMETRY, odometry_at(*scan.odometry, t, 'odom'), lead))
    if scan.state_covariance is not None:
        messages.append((STATE_COVARIANCE, state_covariance_cloud(
            header(t, scan.map_frame), scan.landmark_ids, scan.state_covariance), lead))
    messages.append((OBSERVATIONS, _cloud(scan.observations, t, scan.observation_frame), t))
    truth = np.zeros(len(scan.truth), dtype=CORRESPONDENCE_DTYPE)
    truth['observation'] = np.arange(len(scan.truth))
    truth['landmark'] = scan.truth
    truth['nis'] = np.nan
    truth['probability'] = 1.0
    truth['x'], truth['y'] = scan.truth_xy[:, 0], scan.truth_xy[:, 1]
    messages.append((GROUND_TRUTH, array_to_cloud(truth, header(t, scan.observation_frame)), t))
    return messages
