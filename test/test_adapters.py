"""msg_adapters inputs/outputs on real message classes: hand-computed values, fallbacks, errors."""
import numpy as np
import pytest
from geometry_msgs.msg import Pose, PoseArray

from data_association_ros import NEW, UNASSOCIATED, Association, InvalidInputError, RobotPose
from data_association_ros.core.initialisation import observations_in_map
from data_association_ros.core.candidates import CandidateManager
from msg_adapters import (PointCloudFormatError, candidates_cloud, cloud_to_array,
                          correspondences_cloud, detect_model, landmarks_from_cloud,
                          landmarks_from_pose_array, new_landmarks_cloud, observations_from_cloud,
                          pose_from_odometry, state_covariance_cloud, state_covariance_from_cloud)
from ros_harness import cloud, odometry


def test_pose_from_odometry_yaw_and_covariance_block():
    cov = np.array([[0.1, 0.01, 0.02], [0.01, 0.2, 0.03], [0.02, 0.03, 0.05]])
    pose = pose_from_odometry(odometry(1.5, -2.0, 2.5, cov, 0.0))
    np.testing.assert_allclose(pose.mean, [1.5, -2.0, 2.5])
    np.testing.assert_allclose(pose.covariance, cov)


def test_pose_from_odometry_rejects_a_zero_quaternion():
    msg = odometry(0, 0, 0, np.eye(3), 0.0)
    msg.pose.pose.orientation.w = 0.0
    with pytest.raises(InvalidInputError, match='orientation'):
        pose_from_odometry(msg)


def test_landmarks_from_cloud_with_and_without_covariance_fields():
    with_cov = landmarks_from_cloud(cloud({'id': [4, 9], 'x': [1, 2], 'y': [3, 4],
                                           'cov_xx': [0.5, 0.25], 'cov_xy': [0.1, 0.0],
                                           'cov_yy': [0.5, 1.0]}, 0.0), 0.01)
    np.testing.assert_array_equal(with_cov.ids, [4, 9])
    np.testing.assert_allclose(with_cov.covariances[0], [[0.5, 0.1], [0.1, 0.5]], rtol=1e-6)
    plain = landmarks_from_cloud(cloud({'id': [4], 'x': [1], 'y': [3]}, 0.0), 0.3)
    np.testing.assert_allclose(plain.covariances[0], np.eye(2) * 0.3)
    with pytest.raises(InvalidInputError, match="missing field 'id'"):
        landmarks_from_cloud(cloud({'x': [1], 'y': [3]}, 0.0), 0.3)


def test_landmarks_from_pose_array():
    msg = PoseArray(poses=[Pose(), Pose()])
    msg.poses[1].position.x, msg.poses[1].position.y = 2.0, -1.0
    landmarks = landmarks_from_pose_array(msg, 0.2)
    np.testing.assert_array_equal(landmarks.ids, [0, 1])
    np.testing.assert_allclose(landmarks.means, [[0, 0], [2, -1]])
    np.testing.assert_allclose(landmarks.covariances[1], np.eye(2) * 0.2)


def test_observations_fall_back_to_observation_noise():
    rb = observations_from_cloud(cloud({'range': [2.0], 'bearing': [0.5]}, 0.0), 'range_bearing',
                                 [0.04, 0.001])
    np.testing.assert_allclose(rb.covariances[0], np.diag([0.04, 0.001]))
    given = observations_from_cloud(cloud({'range': [2.0], 'bearing': [0.5], 'var_range': [0.09],
                                           'var_bearing': [0.0004]}, 0.0), 'range_bearing', [1.0])
    np.testing.assert_allclose(given.covariances[0], np.diag([0.09, 0.0004]), rtol=1e-6)
    with pytest.raises(InvalidInputError, match='observation_noise'):
        observations_from_cloud(cloud({'x': [1.0], 'y': [0.5]}, 0.0), 'point_map', [1, 2, 3])


@pytest.mark.parametrize('fields,frames,model', [
    (('range', 'bearing'), ('base', 'map'), 'range_bearing'),
    (('x', 'y', 'width', 'height', 'score'), ('cam', 'cam'), 'box'),
    (('x', 'y', 'cov_xx'), ('map', 'map'), 'point_map'),
    (('x', 'y'), ('base_link', 'map'), 'point_robot'),
])
def test_detect_model(fields, frames, model):
    assert detect_model(fields, *frames) == model


def test_detect_model_without_usable_fields():
    with pytest.raises(InvalidInputError, match='cannot tell'):
        detect_model(('intensity',), 'a', 'a')


def test_state_covariance_cloud_round_trip_and_rejections():
    """ids and matrix survive the cloud; a malformed layout or matrix is refused naming it."""
    from std_msgs.msg import Header
    rng = np.random.default_rng(4)
    a = rng.normal(size=(7, 7))
    matrix = a @ a.T
    msg = state_covariance_cloud(Header(frame_id='map'), np.array([12, 40]), matrix)
    assert [f.name for f in msg.fields] == ['id', 'axis', 'row'] and msg.width == 7
    ids, back = state_covariance_from_cloud(msg)
    assert list(ids) == [12, 40]
    np.testing.assert_array_equal(back, matrix)
    assert not back.flags.writeable           # checked once on arrival, read-only after
    empty_ids, empty = state_covariance_from_cloud(
        state_covariance_cloud(Header(), np.zeros(0, dtype=int), np.eye(3)))
    assert len(empty_ids) == 0 and empty.shape == (3, 3)
    for bad, reason in ((np.arange(49.0).reshape(7, 7), 'not symmetric'),
                        (-np.eye(7), 'negative variance'),
                        (np.diag([1.0, np.inf, 1, 1, 1, 1, 1]), 'not finite')):
        with pytest.raises(InvalidInputError, match=reason):
            state_covariance_from_cloud(state_covariance_cloud(Header(), np.array([1, 2]), bad))
    broken = state_covariance_cloud(Header(), np.array([12, 40]), matrix)
    broken.fields[2].count = 6
    with pytest.raises(PointCloudFormatError, match="'row' must be FLOAT64 with count 7"):
        state_covariance_from_cloud(broken)
    broken = state_covariance_cloud(Header(), np.array([12, 40]), matrix)
    broken.data = bytes(broken.data)[:-8]
    with pytest.raises(PointCloudFormatError, match='does not hold 7 rows'):
        state_covariance_from_cloud(broken)
    rows = np.frombuffer(bytes(msg.data), dtype=[('id', '<i4'), ('axis', '<i4'),
                                                  ('row', '<f8', (7,))]).copy()
    rows['id'][4] = 41                            # landmark 12's y row under another id
    tampered = state_covariance_cloud(Header(), np.array([12, 40]), matrix)
    tampered.data = rows.tobytes()
    with pytest.raises(InvalidInputError, match='landmark rows must come'):
        state_covariance_from_cloud(tampered)


def test_output_clouds_carry_assignment_nis_and_inverse_model_covariance():
    from data_association_ros import Observations
    observations = Observations([[2.0, 0.0], [1.0, np.pi / 2]], [np.diag([0.01, 0.0004])] * 2,
                                'range_bearing')
    pose = RobotPose([1.0, 1.0, 0.0], np.diag([0.0, 0.0, 0.01]))
    positions, covariances = observations_in_map(observations, pose)
    np.testing.assert_allclose(positions, [[3.0, 1.0], [1.0, 2.0]], atol=1e-12)
    # first: along x at 2 m; var_x = var_range, var_y = r^2 (var_bearing + var_yaw)
    np.testing.assert_allclose(covariances[0], np.diag([0.01, 4 * (0.0004 + 0.01)]), atol=1e-12)
    result = Association(np.array([NEW, UNASSOCIATED]), np.array([np.nan, np.nan]))
    points = cloud_to_array(correspondences_cloud(None, result, positions))
    np.testing.assert_array_equal(points['landmark'], [NEW, UNASSOCIATED])
    manager = CandidateManager(confirm_hits=1)
    update = manager.update(positions[:1], covariances[:1], 1_500_000_007, np.array([0]))
    new = cloud_to_array(new_landmarks_cloud(None, update.confirmed))
    np.testing.assert_array_equal(new['observation'], [0])
    np.testing.assert_array_equal([new['stamp_sec'][0], new['stamp_nanosec'][0]], [1, 500000007])
    np.testing.assert_allclose([new['x'][0], new['y'][0]], [3.0, 1.0], rtol=1e-6)
    np.testing.assert_allclose([new['cov_xx'][0], new['cov_yy'][0]], [0.01, 0.0416], rtol=1e-6)
    assert new_landmarks_cloud(None, ()) is None


def test_confirmed_landmark_has_one_point_per_confirming_observation_and_candidates_clear():
    manager = CandidateManager(confirm_hits=2, confirm_window=2, max_misses=1)
    r = np.eye(2) * 0.01
    manager.update(np.array([[1.0, 2.0], [9.0, 9.0]]), np.array([r, r]), 10, np.array([4, 5]))
    pending = cloud_to_array(candidates_cloud(None, manager.pending, manager.scan))
    np.testing.assert_array_equal(pending['candidate'], [0, 1])
    np.testing.assert_array_equal(pending['hits'], [1, 1])
    np.testing.assert_allclose(pending['cov_xx'], [0.01, 0.01], rtol=1e-6)
    update = manager.update(np.array([[1.02, 2.0]]), np.array([r]), 20, np.array([0]))
    new = cloud_to_array(new_landmarks_cloud(None, update.confirmed))
    np.testing.assert_array_equal(new['candidate'], [0, 0])
    np.testing.assert_array_equal(new['observation'], [4, 0])
    np.testing.assert_array_equal(new['stamp_nanosec'], [10, 20])
    np.testing.assert_allclose(new['x'], [1.01, 1.01], rtol=1e-6)  # fused, on every point
    np.testing.assert_allclose(new['cov_xx'], [0.005, 0.005], rtol=1e-6)
    assert len(cloud_to_array(candidates_cloud(None, manager.pending, manager.scan))) == 0
