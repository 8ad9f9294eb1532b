"""association_node on real rclpy topics: every algorithm and model, runtime switching through
the parameter service, malformed input, and the executable as a separate process."""
import os
import subprocess
import sys

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from sensor_msgs.msg import PointCloud2, PointField

from data_association_ros import (NEW, Landmarks, Observations, RobotPose,
                                  associate)
from data_association_ros.nodes.association_node import AssociationNode
from ros_harness import Graph, cdr, cloud, correspondences, header, odometry, wait_reply

LANDMARKS = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0], [4.0, 4.0]])
IDS = np.array([11, 12, 13, 14])
POSE = (1.0, 0.5, 0.3)


@pytest.fixture
def graph():
    g = Graph()
    node = AssociationNode(context=g.context)
    g.add(node)
    g.node = node
    for topic, msg_type in (('correspondences', PointCloud2), ('new_landmarks', PointCloud2)):
        g.collect(msg_type, topic)
    g.publisher(PointCloud2, 'landmarks')
    g.publisher(PointCloud2, 'observations')
    g.publisher(Odometry, 'robot_pose')
    g.wait_for_subscribers(['landmarks', 'observations', 'robot_pose'])
    yield g
    g.close()


def publish_map(graph, stamp=1.0, ids=IDS, means=LANDMARKS, variance=0.02):
    graph.publisher(PointCloud2, 'landmarks').publish(cloud(
        {'id': ids, 'x': means[:, 0], 'y': means[:, 1], 'cov_xx': np.full(len(ids), variance),
         'cov_xy': np.zeros(len(ids)), 'cov_yy': np.full(len(ids), variance)}, stamp))


def exchange(graph, msg, count=None):
    """Publish an observation message; the correspondences answering it (as an array)."""
    replies = graph.received['correspondences']
    count = len(replies) + 1 if count is None else count
    graph.publisher(PointCloud2, 'observations').publish(msg)
    return wait_reply(graph, 'correspondences', count)[-1]


def settle(graph, seconds=0.2):
    graph.spin_until(lambda: False, seconds)


def observation_clouds(stamp):
    """model -> (observation cloud, true assignment, landmarks model input) for the map above,
    robot at POSE; the last observation of each is clutter far away (NEW)."""
    rng = np.random.default_rng(5)
    x, y, yaw = POSE
    seen = LANDMARKS[[0, 2, 3]] + rng.normal(0, 0.05, (3, 2))
    truth = np.array([11, 13, 14, NEW])
    far = np.array([[30.0, -30.0]])
    points = np.vstack([seen, far])
    delta = points - [x, y]
    c, s = np.cos(yaw), np.sin(yaw)
    robot = np.column_stack([c * delta[:, 0] + s * delta[:, 1], -s * delta[:, 0] + c * delta[:, 1]])
    ranges = np.hypot(delta[:, 0], delta[:, 1])
    bearings = np.arctan2(delta[:, 1], delta[:, 0]) - yaw
    n = len(points)
    return {
        'point_map': (cloud({'x': points[:, 0], 'y': points[:, 1]}, stamp, 'map'), truth),
        'point_robot': (cloud({'x': robot[:, 0], 'y': robot[:, 1]}, stamp, 'base_link'), truth),
        'range_bearing': (cloud({'range': ranges, 'bearing': bearings,
                                 'var_range': np.full(n, 0.01),
                                 'var_bearing': np.full(n, 1e-4)}, stamp, 'base_link'), truth),
    }


def set_parameters(graph, **values):
    client = graph.tester.create_client(SetParameters,
                                        f'/{graph.node.get_name()}/set_parameters')
    assert client.wait_for_service(timeout_sec=5.0)
    request = SetParameters.Request()
    for name, value in values.items():
        if isinstance(value, str):
            pv = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
        elif isinstance(value, bool):
            pv = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
        elif isinstance(value, list):
            pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY,
                                double_array_value=value)
        elif isinstance(value, int):
            pv = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
        else:
            pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
        request.parameters.append(ParameterMsg(name=name, value=pv))
    future = client.call_async(request)
    assert graph.spin_until(future.done, 5.0)
    graph.tester.destroy_client(client)
    return future.result().results


@pytest.mark.parametrize('algorithm', ['euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood',
                                       'gnn', 'jcbb'])
def test_every_algorithm_and_point_model_answers_with_the_input_stamp(graph, algorithm):
    assert set_parameters(graph, algorithm=algorithm)[0].successful
    publish_map(graph)
    graph.publisher(Odometry, 'robot_pose').publish(
        odometry(*POSE, np.diag([1e-4, 1e-4, 1e-5]), 2.0))
    settle(graph)
    for model, (msg, truth) in observation_clouds(2.0).items():
        new_before = len(graph.received['new_landmarks'])
        reply_msg = exchange(graph, msg)
        assert reply_msg.header.stamp == msg.header.stamp
        assert reply_msg.header.frame_id == msg.header.frame_id
        reply = correspondences(reply_msg)
        np.testing.assert_array_equal(reply['observation'], np.arange(len(truth)))
        np.testing.assert_array_equal(reply['landmark'], truth, err_msg=model)
        paired = truth >= 0
        assert np.all(np.isfinite(reply['nis'][paired])) or algorithm == 'euclidean_nn'
        assert np.all(np.isnan(reply['nis'][~paired]))
        np.testing.assert_array_equal(reply['probability'], 1.0)
        # x, y: the observation in the map frame, whatever the model
        np.testing.assert_allclose(reply['x'][paired], LANDMARKS[[0, 2, 3], 0], atol=0.2)
        new = wait_reply(graph, 'new_landmarks', new_before + 1)[-1]
        assert new.header.stamp == msg.header.stamp and new.header.frame_id == 'map'
        new_points = correspondences(new)
        np.testing.assert_array_equal(new_points['observation'], [3])
        np.testing.assert_allclose([new_points['x'][0], new_points['y'][0]], [30, -30], atol=1e-3)


@pytest.mark.parametrize('algorithm', ['iou', 'mahalanobis_nn', 'gnn'])
def test_box_model(graph, algorithm):
    results = set_parameters(graph, algorithm=algorithm, default_landmark_covariance=4.0,
                             observation_noise=[1.0])
    assert all(r.successful for r in results)
    graph.publisher(PointCloud2, 'landmarks').publish(cloud(
        {'id': [5, 6], 'x': [10.0, 50.0], 'y': [10.0, 10.0], 'width': [8.0, 8.0],
         'height': [16.0, 16.0]}, 1.0, 'camera'))
    settle(graph)
    detections = cloud({'x': [50.5, 11.0, 200.0], 'y': [10.0, 9.0, 5.0], 'width': [8.0, 8.0, 9.0],
                        'height': [15.0, 16.0, 9.0], 'score': [0.9, 0.8, 0.4]}, 1.5, 'camera')
    reply = correspondences(exchange(graph, detections))
    np.testing.assert_array_equal(reply['landmark'], [6, 5, NEW])


def test_same_result_as_the_library(graph):
    """The node's answer is the core's answer on the same numbers (JCBB, correlated pose)."""
    rng = np.random.default_rng(2)
    means = rng.uniform(-6, 6, (12, 2)).astype(np.float32).astype(float)  # as sent
    ids = np.arange(12) * 2
    x, y, yaw = 0.2, -0.1, 0.05
    pose_cov = np.diag([0.02, 0.02, 0.01])
    observed = means[:8] + rng.normal(0, 0.1, (8, 2))
    delta = observed - [x, y]
    ranges, bearings = np.hypot(*delta.T), np.arctan2(delta[:, 1], delta[:, 0]) - yaw
    assert all(r.successful for r in set_parameters(
        graph, algorithm='jcbb', observation_noise=[0.01, 0.001], time_budget_ms=0.0))
    publish_map(graph, stamp=3.0, ids=ids, means=means, variance=0.03)
    graph.publisher(Odometry, 'robot_pose').publish(odometry(x, y, yaw, pose_cov, 3.0))
    settle(graph)
    reply = correspondences(exchange(graph, cloud({'range': ranges, 'bearing': bearings}, 3.0,
                                                  'base_link', dtype='<f8')))
    variance = float(np.float32(0.03))
    expected = associate(Landmarks(ids, means, np.tile(np.eye(2) * variance, (12, 1, 1))),
                         Observations(np.column_stack([ranges, bearings]),
                                      np.tile(np.diag([0.01, 0.001]), (8, 1, 1)),
                                      'range_bearing'), 'jcbb', pose=RobotPose(
                             [x, y, yaw], pose_cov), time_budget_ms=0.0)
    np.testing.assert_array_equal(reply['landmark'], expected.assignment)
    np.testing.assert_allclose(reply['nis'], expected.nis.astype(np.float32), rtol=1e-5)


def test_runtime_algorithm_switch_and_invalid_value(graph):
    # A: vague, 0.7 m away; B: tight, 0.5 m away. Euclidean picks B, Mahalanobis A.
    graph.publisher(PointCloud2, 'landmarks').publish(cloud(
        {'id': [1, 2], 'x': [0.0, 1.2], 'y': [0.0, 0.0], 'cov_xx': [1.0, 1e-3],
         'cov_xy': [0.0, 0.0], 'cov_yy': [1.0, 1e-3]}, 1.0))
    settle(graph)
    observation = cloud({'x': [0.7], 'y': [0.0]}, 1.0)
    assert correspondences(exchange(graph, observation))['landmark'][0] == 1  # default MNN
    result = set_parameters(graph, algorithm='euclidean_nn')[0]
    assert result.successful
    assert graph.node.config['algorithm'] == 'euclidean_nn'
    assert correspondences(exchange(graph, observation))['landmark'][0] == 2
    rejected = set_parameters(graph, algorithm='magic')[0]
    assert not rejected.successful
    assert 'jcbb' in rejected.reason and 'mahalanobis_nn' in rejected.reason
    assert graph.node.get_parameter('algorithm').value == 'euclidean_nn'
    assert correspondences(exchange(graph, observation))['landmark'][0] == 2
    for name, value in (('gate_probability', 1.0), ('gate_probability', 0.0),
                        ('euclidean_gate', -1.0), ('iou_threshold', 2.0),
                        ('observation_noise', [0.0]), ('measurement_model', 'lidar'),
                        ('gate_probability', 'high')):
        outcome = set_parameters(graph, **{name: value})[0]
        assert not outcome.successful and outcome.reason, (name, value)
    assert graph.node.config['gate_probability'] == 0.99
    assert not set_parameters(graph, input_qos='sensor_data')[0].successful  # read-only


def raw_cloud(fields, point_step, data, width, stamp=1.0, frame='map'):
    msg = PointCloud2(header=header(stamp, frame), height=1, width=width, point_step=point_step,
                      row_step=point_step * width, is_dense=True)
    msg.fields = [PointField(name=n, offset=4 * k, datatype=PointField.FLOAT32, count=1)
                  for k, n in enumerate(fields)]
    msg.data = bytes(data)
    return msg


def test_malformed_messages_never_kill_the_node(graph):
    diagnostics = graph.collect(DiagnosticArray, '/diagnostics')
    valid = cloud({'x': [0.1], 'y': [0.0]}, 2.0)
    assert set_parameters(graph, pose_wait=0.2)[0].successful
    graph.publisher(PointCloud2, 'observations').publish(valid)  # landmarks never received
    settle(graph, 0.1)
    assert graph.node.statistics.skipped['no_landmarks'] == 0     # waits for a first map
    settle(graph, 0.4)
    assert graph.received['correspondences'] == []
    assert graph.node.statistics.skipped['no_landmarks'] == 1
    publish_map(graph)
    graph.publisher(PointCloud2, 'landmarks').publish(cloud(  # not positive definite: rejected
        {'id': [1], 'x': [0.0], 'y': [0.0], 'cov_xx': [1.0], 'cov_xy': [5.0], 'cov_yy': [1.0]},
        1.5))
    settle(graph)
    assert graph.node.statistics.invalid['landmarks'] == 1
    bad = [cloud({'x': [0.1]}, 2.0),                                   # missing field
           cloud({'x': [np.nan], 'y': [0.0]}, 2.0),                    # NaN
           raw_cloud(['x', 'y'], 8, b'\x00' * 12, 2),                  # wrong byte length
           cloud({'x': [0.0], 'y': [0.0], 'cov_xx': [1.0], 'cov_xy': [3.0], 'cov_yy': [1.0]},
                 2.0),                                                 # covariance not PD
           cloud({'foo': [1.0]}, 2.0)]                                 # no usable fields
    for msg in bad:
        graph.publisher(PointCloud2, 'observations').publish(msg)
    settle(graph, 0.5)
    assert graph.node.statistics.invalid['observations'] == len(bad)
    assert graph.received['correspondences'] == []
    # an empty cloud is valid: an empty answer
    empty = correspondences(exchange(graph, cloud({'x': [], 'y': []}, 2.0)))
    assert len(empty) == 0
    reply = correspondences(exchange(graph, valid))
    assert reply['landmark'][0] == 11  # the landmarks published at 1.0 (1.5 was rejected)
    assert graph.spin_until(lambda: any(
        any(kv.key == 'invalid_observations' and kv.value == str(len(bad))
            for status in d.status for kv in status.values) for d in diagnostics), 3.0)


def test_scans_in_either_byte_order_answered_alike_and_foreign_bytes_counted(graph):
    """The node reads a scan from its bytes (msg_adapters/serialized_cloud.py): big-endian CDR
    gets its little-endian twin's answer; bytes that hold no PointCloud2 (another
    encapsulation, cut short) are counted invalid, and the next scan is answered."""
    publish_map(graph)
    graph.publisher(Odometry, 'robot_pose').publish(
        odometry(*POSE, np.diag([1e-4, 1e-4, 1e-5]), 2.0))
    settle(graph)
    msg, truth = observation_clouds(2.0)['range_bearing']
    little = correspondences(exchange(graph, msg))
    np.testing.assert_array_equal(little['landmark'], truth)
    big = correspondences(exchange(graph, cdr(msg, '>')))
    assert big.tobytes() == little.tobytes()     # NaN nis of the NEW one included
    # 0x0007 (XCDR2 little-endian): left to rclpy, which reads this message alike
    other = correspondences(exchange(graph, b'\x00\x07\x00\x00' + cdr(msg, '<')[4:]))
    assert other.tobytes() == little.tobytes()
    for raw in (b'\x12\x34\x00\x00' + cdr(msg, '<')[4:], cdr(msg, '<')[:40]):
        graph.publisher(PointCloud2, 'observations').publish(raw)
    settle(graph, 0.5)
    assert graph.node.statistics.invalid['observations'] == 2
    assert len(graph.received['correspondences']) == 3
    assert correspondences(exchange(graph, msg)).tobytes() == little.tobytes()


def test_empty_map_gives_all_new(graph):
    publish_map(graph, ids=np.zeros(0, int), means=np.zeros((0, 2)))
    settle(graph)
    reply = correspondences(exchange(graph, cloud({'x': [0.0, 1.0], 'y': [0.0, 1.0]}, 1.0)))
    np.testing.assert_array_equal(reply['landmark'], [NEW, NEW])


def test_time_matching_uses_newest_landmarks_not_newer_and_not_too_old(graph):
    publish_map(graph, stamp=1.0, ids=np.array([1]), means=np.array([[0.0, 0.0]]))
    publish_map(graph, stamp=3.0, ids=np.array([2]), means=np.array([[0.0, 0.0]]))
    settle(graph)
    assert correspondences(exchange(graph, cloud({'x': [0.0], 'y': [0.0]}, 2.0)))['landmark'][0] == 1
    assert correspondences(exchange(graph, cloud({'x': [0.0], 'y': [0.0]}, 3.5)))['landmark'][0] == 2
    graph.publisher(PointCloud2, 'observations').publish(cloud({'x': [0.0], 'y': [0.0]}, 9.0))
    settle(graph)
    assert graph.node.statistics.skipped['no_landmarks'] == 1  # 6 s old > max_landmark_age


def test_robot_model_without_pose_is_skipped_then_answered(graph):
    publish_map(graph, stamp=5.0)
    settle(graph)
    msg = cloud({'range': [1.0], 'bearing': [0.0]}, 5.0, 'base_link')
    graph.publisher(PointCloud2, 'observations').publish(msg)
    settle(graph)
    assert graph.node.statistics.skipped['no_pose'] == 1
    graph.publisher(Odometry, 'robot_pose').publish(odometry(0.0, 0.0, 0.0, np.eye(3) * 1e-3,
                                                             5.01))
    settle(graph)
    reply = correspondences(exchange(graph, msg))
    # the observation lies at (1, 0): 1 m from landmark 11, NIS about 33, outside the gate
    assert reply['landmark'][0] == NEW


def test_executable_answers_over_dds():
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    process = subprocess.Popen([sys.executable, '-m', 'data_association_ros.nodes.association_node', '--ros-args',
                                '-p', 'algorithm:=jcbb', '-r', '__ns:=/da_test'], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    g = Graph(namespace='/da_test')
    try:
        g.collect(PointCloud2, 'correspondences')
        g.publisher(PointCloud2, 'landmarks')
        g.publisher(PointCloud2, 'observations')
        g.wait_for_subscribers(['landmarks', 'observations'], timeout=60.0)  # start-up
        assert g.spin_until(lambda: g.tester.count_publishers('correspondences') > 0, 10.0)
        publish_map(g)
        settle(g, 0.5)
        msg = cloud({'x': [0.05, 4.02], 'y': [0.0, 3.9]}, 1.2)
        g.publisher(PointCloud2, 'observations').publish(msg)
        replies = wait_reply(g, 'correspondences', 1, timeout=10.0)
        assert replies[0].header.stamp == msg.header.stamp
        np.testing.assert_array_equal(correspondences(replies[0])['landmark'], [11, 14])
        assert process.poll() is None
    finally:
        g.close()
        process.terminate()
        output = process.communicate(timeout=10)[0].decode(errors='replace')
    assert 'algorithm jcbb' in output


def test_jcbb_points_publishes_the_estimated_transform(graph):
    from geometry_msgs.msg import PoseWithCovarianceStamped
    transforms = graph.collect(PoseWithCovarianceStamped, 'estimated_transform')
    assert set_parameters(graph, algorithm='jcbb_points')[0].successful
    corners = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]])
    publish_map(graph, stamp=1.0, ids=np.arange(6), means=corners, variance=0.01)
    settle(graph)
    yaw, shift = 0.05, np.array([0.1, -0.05])
    c, s = np.cos(yaw), np.sin(yaw)
    scan = corners @ np.array([[c, -s], [s, c]]).T + shift  # the object moved
    reply = correspondences(exchange(graph, cloud({'x': scan[:, 0], 'y': scan[:, 1]}, 1.0)))
    np.testing.assert_array_equal(reply['landmark'], np.arange(6))
    assert graph.spin_until(lambda: len(transforms) == 1)
    pose = transforms[0].pose.pose
    # scan -> boundary is the inverse motion
    assert 2 * np.arctan2(pose.orientation.z, pose.orientation.w) == pytest.approx(-yaw, abs=1e-3)
    assert transforms[0].header.stamp == graph.received['correspondences'][-1].header.stamp


def test_new_landmark_announced_only_after_confirmation_with_candidates_shown(graph):
    refused = set_parameters(graph, confirm_hits=4)  # more than confirm_window (3)
    assert not refused[0].successful and 'confirm_window' in refused[0].reason
    assert graph.node.config['confirm_hits'] == 1
    assert all(r.successful for r in set_parameters(graph, confirm_hits=2, confirm_window=3))
    graph.collect(PointCloud2, 'landmark_candidates')
    publish_map(graph)
    settle(graph)
    stray_then_landmark = [[[30.0, -30.0]], [[50.0, 50.0], [30.02, -30.0]]]
    for k, points in enumerate(stray_then_landmark):
        points = np.array(points)
        reply = correspondences(exchange(graph, cloud({'x': points[:, 0], 'y': points[:, 1]},
                                                      1.5 + 0.5 * k, 'map')))
        np.testing.assert_array_equal(reply['landmark'], NEW)  # NEW in correspondences
        candidates = correspondences(wait_reply(graph, 'landmark_candidates', k + 1)[-1])
        if k == 0:
            assert len(graph.received['new_landmarks']) == 0  # one sighting is not enough
            np.testing.assert_array_equal(candidates['hits'], [1])
    new = correspondences(wait_reply(graph, 'new_landmarks', 1)[-1])
    np.testing.assert_array_equal(new['observation'], [0, 1])  # scan 1 index 0, scan 2 index 1
    np.testing.assert_array_equal(new['stamp_sec'], [1, 2])
    np.testing.assert_array_equal(new['stamp_nanosec'], [500_000_000, 0])
    np.testing.assert_array_equal(new['candidate'], [0, 0])
    np.testing.assert_allclose(new['x'], [30.01, 30.01], atol=1e-4)
    np.testing.assert_array_equal(candidates['hits'], [1])  # the (50, 50) stray is pending
    assert graph.node.statistics.candidates_confirmed == 1


def test_when_landmarks_stop_the_last_map_serves_until_max_landmark_age(graph):
    publish_map(graph, stamp=1.0)
    settle(graph)
    answered = []
    for k in range(1, 9):  # observations 0.25 s apart after the last map
        stamp = 1.0 + 0.25 * k
        before = len(graph.received['correspondences'])
        graph.publisher(PointCloud2, 'observations').publish(
            cloud({'x': [4.0], 'y': [0.0]}, stamp))
        graph.spin_until(lambda: len(graph.received['correspondences']) > before, 0.5)
        answered.append(len(graph.received['correspondences']) > before)
    assert answered == [True] * 4 + [False] * 4  # ages 0.25-1.0 s answered, 1.25-2.0 s not
    assert graph.node.statistics.skipped['no_landmarks'] == 4


def test_a_scan_waits_for_its_late_pose_and_not_longer_than_pose_wait(graph):
    """DDS does not order topics: a pose published before the scan may arrive after it."""
    publish_map(graph, stamp=6.0)
    variance = np.eye(3) * 1e-4
    graph.publisher(Odometry, 'robot_pose').publish(odometry(*POSE, variance, 5.9))
    settle(graph)
    scan, truth = observation_clouds(6.0)['point_robot']
    graph.publisher(PointCloud2, 'observations').publish(scan)
    settle(graph, 0.3)
    assert graph.received['correspondences'] == []       # waiting, not skipped
    graph.publisher(Odometry, 'robot_pose').publish(odometry(*POSE, variance, 6.0))
    reply = wait_reply(graph, 'correspondences', 1)
    assert correspondences(reply[-1])['landmark'].tolist() == truth.tolist()
    assert graph.node.statistics.skipped['no_pose'] == 0
    # a pose that never comes: skipped once pose_wait is over
    assert set_parameters(graph, pose_wait=0.3)[0].successful
    late, _ = observation_clouds(6.5)['point_robot']
    graph.publisher(PointCloud2, 'observations').publish(late)
    assert graph.spin_until(lambda: graph.node.statistics.skipped['no_pose'] == 1, 3.0)
    assert len(graph.received['correspondences']) == 1


def test_a_map_frame_scan_does_not_wait_for_a_pose(graph):
    assert set_parameters(graph, pose_wait=30.0)[0].successful
    publish_map(graph, stamp=6.0)
    graph.publisher(Odometry, 'robot_pose').publish(odometry(*POSE, np.eye(3) * 1e-4, 5.0))
    settle(graph)
    scan, truth = observation_clouds(6.0)['point_map']
    reply = exchange(graph, scan)          # within wait_reply's 5 s, far below pose_wait
    assert correspondences(reply)['landmark'].tolist() == truth.tolist()
