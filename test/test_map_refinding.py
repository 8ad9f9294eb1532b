"""Re-finding the map over several scans (core/map_refinding.py): the registration against
corrections made here by hand, the refinder's rules (old landmarks, NEW count, window), and the
association pipeline answering a drifted scan from the re-found pose."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_association_ros.core import NEW, Association, InvalidInputError, Landmarks, RobotPose
from data_association_ros.core.map_refinding import (MapRefinder, RefindingConfig, Registration,
                                                     matched_landmarks, register)

CONFIG = RefindingConfig(window_scans=5, old_scans=3, radius=30.0, tolerance=0.2,
                         min_landmarks=5, max_rotation=0.4, max_shift=6.0)


def rotation(angle):
    return np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])


def layout(seed: int, count: int = 12) -> np.ndarray:
    """Landmarks at least 1.5 m apart in a 20 m square (no repeating pattern)."""
    rng = np.random.default_rng(seed)
    points = []
    while len(points) < count:
        candidate = rng.uniform(-10, 10, 2)
        if all(np.hypot(*(candidate - p)) >= 1.5 for p in points):
            points.append(candidate)
    return np.array(points)


def drifted(points: np.ndarray, centre: np.ndarray, angle: float, shift: np.ndarray):
    """The points as a drifted filter places them: the inverse of the correction (angle about
    centre, then shift)."""
    return (points - shift - centre) @ rotation(-angle).T + centre


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10 ** 6), angle_deg=st.integers(-20, 20),
       dx=st.floats(-4, 4), dy=st.floats(-4, 4))
def test_register_finds_the_correction_made_by_hand(seed, angle_deg, dx, dy):
    """Whole-degree rotations (the search's grid) and any shift within max_shift: the correction
    that undoes the drift, all landmarks matched, the pose moved onto the truth."""
    landmarks = layout(seed)
    centre = np.array([0.5, -0.3])
    angle, shift = np.radians(angle_deg), np.array([dx, dy])
    seen = drifted(landmarks[:9], centre, angle, shift)
    found = register(seen, landmarks, centre, CONFIG)
    assert found is not None and found.matched == 9
    np.testing.assert_allclose(found.apply(seen), landmarks[:9], atol=1e-9)
    assert np.isclose(found.rotation, angle, atol=1e-12)
    np.testing.assert_allclose(found.shift, shift, atol=1e-9)
    true_pose = np.array([1.0, 2.0, 0.3])
    believed = RobotPose(np.concatenate([drifted(true_pose[None, :2], centre, angle, shift)[0],
                                         [true_pose[2] - angle]]), np.eye(3) * 1e-4)
    np.testing.assert_allclose(found.pose(believed).mean, true_pose, atol=1e-9)


def test_matched_landmarks_counts_distinct_landmarks_within_the_tolerance():
    landmarks = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 0.0]])
    points = np.array([[0.1, 0.0], [-0.1, 0.05], [5.0, 0.25], [9.9, 0.1], [20.0, 0.0]])
    assert matched_landmarks(points, landmarks, 0.2) == (2, pytest.approx(0.0425))  # 0 twice, 2
    assert matched_landmarks(points, landmarks, 0.3) == (3, pytest.approx(0.105))
    assert matched_landmarks(points[:0], landmarks, 0.3) == (0, 0.0)


def test_settings_are_checked():
    with pytest.raises(InvalidInputError, match='refind_tolerance'):
        RefindingConfig(window_scans=5, tolerance=0.0)
    with pytest.raises(InvalidInputError, match='refind_window_scans'):
        RefindingConfig(window_scans=-1)


def landmarks_of(means: np.ndarray) -> Landmarks:
    return Landmarks(np.arange(len(means)), means, np.tile(np.eye(2) * 1e-4, (len(means), 1, 1)))


def association(assignment) -> Association:
    assignment = np.asarray(assignment, dtype=np.int64)
    return Association(assignment, np.full(len(assignment), np.nan), 'x')


def test_refinder_registers_only_against_old_landmarks_and_only_when_scans_come_back_new():
    means = layout(3)
    pose = RobotPose(np.zeros(3), np.eye(3) * 1e-4)
    refinder = MapRefinder(CONFIG)
    truth_angle, truth_shift = np.radians(8.0), np.array([2.0, -1.0])
    seen = drifted(means, np.zeros(2), truth_angle, truth_shift)
    # three scans with the whole map known: its landmarks become old after old_scans scans
    for _ in range(3):
        assert refinder.refind(landmarks_of(means), seen[:2], pose,
                               association([NEW, NEW])) is None   # none old yet
    assert refinder.old_mask(landmarks_of(means)).sum() == 0
    # the fourth: all old; one NEW only: no registration
    assert refinder.refind(landmarks_of(means), seen[2:4], pose, association([0, NEW])) is None
    assert refinder.old_mask(landmarks_of(means)).all()
    # the fifth comes back with 2 NEW: the window (scans 1-5, within window_scans) registers
    found = refinder.refind(landmarks_of(means), seen[4:9], pose, association([NEW] * 5))
    assert found is not None and found.matched == 9
    assert np.isclose(found.rotation, truth_angle) and np.allclose(found.shift, truth_shift)
    refinder.kept(found)
    assert not refinder.window and refinder.used[0][0] == 5
    # a landmark first seen now is not old
    grown = landmarks_of(np.vstack([means, [[30.0, 30.0]]]))
    refinder.refind(grown, seen[:1], pose, association([0]))
    assert not refinder.old_mask(grown)[-1] and refinder.old_mask(grown)[:-1].all()


def test_refinder_needs_min_landmarks():
    means = layout(5)
    refinder = MapRefinder(RefindingConfig(window_scans=2, old_scans=1, radius=30.0,
                                           min_landmarks=7, max_rotation=0.2))
    pose = RobotPose(np.zeros(3))
    seen = drifted(means, np.zeros(2), np.radians(5.0), np.array([1.0, -1.0]))
    refinder.refind(landmarks_of(means), seen[:1], pose, association([0]))
    assert refinder.refind(landmarks_of(means), seen[1:6], pose,
                           association([NEW] * 5)) is None     # scans 1-2: 6 matched < 7
    assert refinder.refind(landmarks_of(means), seen[6:11], pose,
                           association([NEW] * 5)) is not None  # scans 2-3: 10


def test_a_window_already_in_place_is_not_moved():
    """The pose is right (the window lies on the old landmarks as placed) and two observations
    are new landmarks: no registration beats twice the window as placed, so none is used."""
    means = layout(8)
    refinder = MapRefinder(RefindingConfig(window_scans=3, old_scans=1, radius=30.0,
                                           min_landmarks=4, max_rotation=0.2))
    pose = RobotPose(np.zeros(3))
    refinder.refind(landmarks_of(means), means[:4], pose, association([0, 1, 2, 3]))
    new_ones = np.array([[30.0, -30.0], [-30.0, 30.0]])
    assert refinder.refind(landmarks_of(means), np.vstack([means[4:8], new_ones]), pose,
                           association([4, 5, 6, 7, NEW, NEW])) is None


def test_pipeline_answers_a_drifted_scan_from_the_refound_pose():
    """association_node's pipeline (jcbb, range-bearing): the map is seen right once; the next
    scan's pose is 2 m and 10 deg off with a covariance of centimetres, so every observation
    would be NEW; re-finding registers the scan onto the old landmarks and pairs each with its
    own landmark (the ids the scene was made from), with the correspondences' map positions
    from the re-found pose."""
    from msg_adapters import array_to_cloud, cloud_to_array, odometry_message
    from std_msgs.msg import Header

    from data_association_ros.bag.offline import node_config
    from data_association_ros.pipelines.association import AssociationPipeline
    means = layout(11)
    landmark_points = np.zeros(len(means), dtype=[('id', '<i4'), ('x', '<f4'), ('y', '<f4')])
    landmark_points['id'] = np.arange(len(means))
    landmark_points['x'], landmark_points['y'] = means.T
    true_pose = np.array([0.5, -0.5, 0.2])

    def scan(seen: np.ndarray) -> np.ndarray:
        delta = means[seen] - true_pose[:2]
        points = np.zeros(len(seen), dtype=[('range', '<f4'), ('bearing', '<f4')])
        points['range'] = np.hypot(delta[:, 0], delta[:, 1])
        points['bearing'] = np.arctan2(delta[:, 1], delta[:, 0]) - true_pose[2]
        return points
    drift = np.radians(10.0), np.array([2.0, -1.0])
    believed = np.concatenate([drifted(true_pose[None, :2], true_pose[:2] + drift[1],
                                       drift[0], drift[1])[0], [true_pose[2] - drift[0]]])
    for refind, expected in ((0, [NEW] * 8), (1, list(range(4, 12)))):
        pipeline = AssociationPipeline(node_config('jcbb', {
            'refind_window_scans': refind, 'refind_old_scans': 1, 'refind_min_landmarks': 5,
            'observation_noise': [1e-4, 1e-6], 'recovery_position_std': 0.0}))
        for stamp, pose, seen in ((1, true_pose, np.arange(4)), (2, believed, np.arange(4, 12))):
            header = Header(frame_id='map')
            header.stamp.sec = stamp
            pipeline.on_landmarks(array_to_cloud(landmark_points, header))
            pipeline.on_robot_pose(odometry_message(header, pose, np.eye(3) * 1e-6))
            answer = pipeline.answer(array_to_cloud(scan(seen), Header(stamp=header.stamp,
                                                                          frame_id='base')))
        assert answer.association.assignment.tolist() == expected
        assert pipeline.statistics.refound == refind
        if refind:
            points = cloud_to_array(answer.correspondences)
            np.testing.assert_allclose(np.column_stack([points['x'], points['y']]),
                                       means[4:12], atol=0.05)
