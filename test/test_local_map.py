"""ekf_slam_node's automatic local map (core/slam/local_map.py): exactly the landmarks that some
observation can pass a wide gate with (checked against the NIS and |nu| of every pair of the
whole map), the same answers from every associator (with a pose recovery) on the local map as on
the whole map, and a size that follows what the scan sees, not the map."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_association_ros import Landmarks, Observations, RobotPose, associate
from data_association_ros.core.models import MODELS
from data_association_ros.core.pose_recovery import PoseRecovery, associate_with_pose_recovery
from data_association_ros.core.problem import AssociationProblem, state_rows
from data_association_ros.core.slam.local_map import LOCAL_MAP_GATE, local_map_columns

NOISE = {'range_bearing': np.diag([0.05 ** 2, 0.01 ** 2]), 'point_robot': np.eye(2) * 0.05 ** 2}


def joint_state(rng, n: int, pose_scale: float, landmark_scale: float):
    """(pose, joint covariance (3 + 2n)^2 with random cross terms, marginals (n, 2, 2))."""
    g = rng.normal(size=(3 + 2 * n, 3 + 2 * n)) * 0.3
    local = g @ g.T / (3 + 2 * n)
    scales = np.concatenate([[pose_scale] * 2 + [pose_scale / 5],
                             np.repeat(landmark_scale * rng.uniform(0.2, 2.0, n), 2)])
    joint = local * np.outer(scales, scales) + np.diag(scales ** 2) * 0.5
    marginals = np.array([joint[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j] for j in range(n)])
    return rng.uniform(-3, 3, 3), joint, marginals


def scene(seed: int, model: str, pose_scale: float, landmark_scale: float, n: int = 120,
          spread: float = 150.0):
    """A map of n landmarks around a robot, and a scan of 6 observations of near ones."""
    rng = np.random.default_rng(seed)
    pose, joint, marginals = joint_state(rng, n, pose_scale, landmark_scale)
    means = pose[:2] + rng.uniform(-spread, spread, (n, 2))
    nearest = np.argsort(np.hypot(*(means - pose[:2]).T))[:20]
    seen = rng.choice(nearest, 6, replace=False)
    values = MODELS[model].predict(means[seen], pose)[0] + rng.normal(0, 0.3, (6, 2)) * [1, 0.05]
    return pose, joint, means, marginals, values, np.tile(NOISE[model], (6, 1, 1))


def brute_force(model, pose, joint, means, marginals, values, noise, position_std, yaw_std,
                gate):
    """Every landmark some observation passes NIS <= 41.4 (pose widened) or |nu| <= gate with."""
    wide = joint.copy()
    wide[:3, :3] += np.diag([position_std ** 2, position_std ** 2, yaw_std ** 2])
    problem = AssociationProblem(Landmarks(np.arange(len(means)), means, marginals),
                                 Observations(values, noise, model),
                                 RobotPose(pose, wide[:3, :3]), wide)
    return np.flatnonzero(((problem.nis <= LOCAL_MAP_GATE)
                           | (problem.euclidean_distances <= gate)).any(axis=0))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31), model=st.sampled_from(['range_bearing', 'point_robot']),
       pose_scale=st.sampled_from([0.01, 0.1, 0.5]),
       landmark_scale=st.sampled_from([0.01, 0.3, 2.0]),
       position_std=st.sampled_from([0.0, 0.1, 0.5, 3.0]),
       yaw_std=st.sampled_from([0.0, 0.05, 0.1, 0.3]), gate=st.sampled_from([0.0, 1.0, 10.0]))
def test_the_local_map_is_every_landmark_a_wide_gate_can_pass(
        seed, model, pose_scale, landmark_scale, position_std, yaw_std, gate):
    pose, joint, means, marginals, values, noise = scene(seed, model, pose_scale, landmark_scale)
    columns = local_map_columns(model, pose, joint, means, marginals, values, noise,
                                position_std=position_std, yaw_std=yaw_std, euclidean_gate=gate)
    np.testing.assert_array_equal(columns, brute_force(
        model, pose, joint, means, marginals, values, noise, position_std, yaw_std, gate))


ALGORITHMS = {'euclidean_nn': {}, 'mahalanobis_nn': {}, 'maximum_likelihood': {},
              'gnn': {}, 'jcbb': {'joint_gate_probability': 0.99999}}


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 31), model=st.sampled_from(['range_bearing', 'point_robot']),
       algorithm=st.sampled_from(sorted(ALGORITHMS)),
       pose_scale=st.sampled_from([0.01, 0.1, 0.3]), offset=st.sampled_from([0.0, 0.5, 1.5]))
def test_every_associator_answers_the_same_on_the_local_map(seed, model, algorithm, pose_scale,
                                                            offset):
    """The scan's answer from the local map equals the answer from the whole map, with a pose
    recovery (0.1 m, 0.05 rad, inside the defaults) and a pose `offset` m off so that the
    recovery's second pass is taken."""
    pose, joint, means, marginals, values, noise = scene(seed, model, pose_scale, 0.05, n=80,
                                                         spread=25.0)
    believed = pose + np.array([offset, -offset, 0.0])
    recovery = PoseRecovery(position_std=0.1, yaw_std=0.05, min_new=1)

    def answer(columns):
        rows = state_rows(columns, 2)
        block = joint[np.ix_(rows, rows)]
        result = associate_with_pose_recovery(
            Landmarks(columns + 1000, means[columns], marginals[columns]),
            Observations(values, noise, model), algorithm, RobotPose(believed, block[:3, :3]),
            block, recovery, gate_probability=0.999, **ALGORITHMS[algorithm])
        return result.assignment

    local = local_map_columns(model, believed, joint, means, marginals, values, noise)
    np.testing.assert_array_equal(answer(local), answer(np.arange(len(means))))
    assert len(local) < len(means)


def test_the_local_map_grows_with_what_the_scan_sees_not_with_the_map():
    """A certain filter in a 160 m x 160 m block of 1,000 landmarks: two observations' local map
    is the few landmarks they can be paired with, and an explicit radius still wins."""
    rng = np.random.default_rng(0)
    n = 1_000
    means = rng.uniform(-80, 80, (n, 2))
    marginals = np.tile(np.eye(2) * 0.05 ** 2, (n, 1, 1))
    pose = np.array([1.0, 2.0, 0.3])
    joint = np.diag(np.concatenate([[0.05 ** 2, 0.05 ** 2, 0.01 ** 2], np.full(2 * n, 0.05 ** 2)]))
    seen = np.argsort(np.hypot(*(means - pose[:2]).T))[[3, 10]]
    values = MODELS['range_bearing'].predict(means[seen], pose)[0]
    noise = np.tile(NOISE['range_bearing'], (2, 1, 1))
    columns = local_map_columns('range_bearing', pose, joint, means, marginals, values, noise)
    assert set(seen) <= set(columns.tolist())
    assert len(columns) < 60
    explicit = local_map_columns('range_bearing', pose, joint, means, marginals, values, noise,
                                 radius=3.0)
    np.testing.assert_array_equal(explicit, np.flatnonzero(np.hypot(*(means - pose[:2]).T) <= 3.0))


def test_an_uncertain_heading_with_robot_frame_points_tests_every_landmark():
    """point_robot with a yaw std beyond 1 / 6.4 rad: no distance bound exists, so every
    landmark is tested and the far ones, which no gate passes, are left out."""
    n = 600
    means = np.vstack([[[1.0, 0.0]], np.column_stack([np.linspace(1e3, 2e3, n - 1),
                                                      np.zeros(n - 1)])])
    joint = np.diag(np.concatenate([[0.01, 0.01, 0.2 ** 2], np.full(2 * n, 1e-4)]))
    columns = local_map_columns('point_robot', np.zeros(3), joint, means,
                                np.tile(np.eye(2) * 1e-4, (n, 1, 1)), np.array([[1.0, 0.0]]),
                                np.eye(2)[None] * 1e-4)
    np.testing.assert_array_equal(columns, [0])


def test_a_scan_without_observations_has_an_empty_local_map():
    columns = local_map_columns('range_bearing', np.zeros(3), np.eye(7) * 1e-6,
                                np.array([[3.0, 0.0], [50.0, 0.0]]),
                                np.tile(np.eye(2) * 1e-6, (2, 1, 1)), np.zeros((0, 2)),
                                np.zeros((0, 2, 2)))
    assert columns.shape == (0,)


def test_a_landmark_with_a_non_finite_block_is_kept_when_near():
    """NaN in landmark 0's cross term with the pose: its NIS is undefined, and the association
    node would refuse that covariance and pair with the marginals, so the local map keeps it
    (the far landmark 1 is still left out by the distance bound)."""
    joint = np.eye(7) * 1e-4
    joint[3, 0] = joint[0, 3] = np.nan
    columns = local_map_columns('range_bearing', np.zeros(3), joint,
                                np.array([[3.0, 0.0], [300.0, 0.0]]),
                                np.tile(np.eye(2) * 1e-4, (2, 1, 1)), np.array([[3.0, 0.5]]),
                                NOISE['range_bearing'][None], position_std=0.0, yaw_std=0.0,
                                euclidean_gate=0.0)
    np.testing.assert_array_equal(columns, [0])
    joint[3, 0] = joint[0, 3] = 0.0
    assert local_map_columns('range_bearing', np.zeros(3), joint,
                             np.array([[3.0, 0.0], [300.0, 0.0]]),
                             np.tile(np.eye(2) * 1e-4, (2, 1, 1)), np.array([[3.0, 0.5]]),
                             NOISE['range_bearing'][None], position_std=0.0, yaw_std=0.0,
                             euclidean_gate=0.0).tolist() == []


@pytest.mark.parametrize('model', ['range_bearing', 'point_robot'])
def test_a_landmark_just_outside_every_gate_is_left_out(model):
    """Two landmarks on the observation's line of sight: one whose NIS is just below 41.4, one
    just above (hand-computed: S = R + pose and landmark blocks, no cross terms)."""
    sigma = 0.1
    joint = np.diag([1e-12, 1e-12, 1e-12] + [1e-12] * 4)
    noise = np.eye(2)[None] * sigma ** 2
    values = np.array([[5.0, 0.0]])   # range 5, bearing 0 / x 5, y 0: straight ahead
    edge = np.sqrt(LOCAL_MAP_GATE) * sigma
    means = np.array([[5.0 + edge * 0.999, 0.0], [5.0 + edge * 1.001, 0.0]])
    columns = local_map_columns(model, np.zeros(3), joint, means,
                                np.tile(np.eye(2) * 1e-12, (2, 1, 1)), values, noise,
                                position_std=0.0, yaw_std=0.0, euclidean_gate=0.0)
    np.testing.assert_array_equal(columns, [0])


def test_a_landmark_only_a_euclidean_gate_can_pass_is_kept():
    """0.8 m from the observation with 1 cm noise and no pose widening: NIS 6400 (1e-8: the
    landmark and pose variances), far beyond any chi-square gate,
    but euclidean_nn's default gate (1.0) pairs them, and the local map keeps it for that."""
    joint = np.diag([1e-8] * 5)
    columns = local_map_columns('point_robot', np.zeros(3), joint, np.array([[5.8, 0.0]]),
                                np.eye(2)[None] * 1e-8, np.array([[5.0, 0.0]]),
                                np.eye(2)[None] * 1e-4, position_std=0.0, yaw_std=0.0)
    np.testing.assert_array_equal(columns, [0])
    assert associate(Landmarks([7], [[5.8, 0.0]], np.eye(2)[None] * 1e-8),
                     Observations([[5.0, 0.0]], np.eye(2)[None] * 1e-4, 'point_robot'),
                     'euclidean_nn', pose=RobotPose(np.zeros(3))).assignment.tolist() == [7]
