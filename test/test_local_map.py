"""ekf_slam_node's automatic local map (core/slam/local_map.py): every landmark that can pass an
observation's chi-square gate (probability 1 - 1e-9, the joint covariance's cross terms
included) is in it, checked against the NIS of every pair; and it holds what the scan can see,
not the map."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_association_ros import Landmarks, Observations, RobotPose
from data_association_ros.core.gating import chi2_threshold
from data_association_ros.core.models import MODELS
from data_association_ros.core.problem import AssociationProblem
from data_association_ros.core.slam.local_map import LOCAL_MAP_MARGIN, local_map_columns

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


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31), model=st.sampled_from(['range_bearing', 'point_robot']),
       pose_scale=st.sampled_from([0.01, 0.1, 0.5]), landmark_scale=st.sampled_from([0.01, 0.3, 2.0]))
def test_every_pair_inside_a_wide_gate_is_in_the_local_map(seed, model, pose_scale,
                                                          landmark_scale):
    rng = np.random.default_rng(seed)
    n = 120
    pose, joint, marginals = joint_state(rng, n, pose_scale, landmark_scale)
    means = pose[:2] + rng.uniform(-150, 150, (n, 2))
    nearest = np.argsort(np.hypot(*(means - pose[:2]).T))[:20]
    seen = rng.choice(nearest, 6, replace=False)
    values = MODELS[model].predict(means[seen], pose)[0] + rng.normal(0, 0.3, (6, 2)) * [1, 0.05]
    noise = np.tile(NOISE[model], (6, 1, 1))
    columns = local_map_columns(model, pose, joint[:3, :3], means, marginals, values, noise)
    problem = AssociationProblem(Landmarks(np.arange(n), means, marginals),
                                 Observations(values, noise, model),
                                 RobotPose(pose, joint[:3, :3]), joint)
    inside = np.flatnonzero((problem.nis <= chi2_threshold(1 - 1e-9, 2)).any(axis=0))
    assert set(inside) <= set(columns.tolist())
    # and it is a local map: what lies far beyond the scan's reach is left out
    if pose_scale <= 0.1 and landmark_scale <= 0.3:
        assert len(columns) < n / 2


def test_the_local_map_grows_with_what_the_scan_sees_not_with_the_map():
    """A certain filter in a 1 km x 1 km city of 40,000 landmarks: a 10 m scan's local map is a
    few dozen landmarks around the robot, and an explicit radius still wins."""
    rng = np.random.default_rng(0)
    means = rng.uniform(-500, 500, (40_000, 2))
    marginals = np.tile(np.eye(2) * 0.05 ** 2, (40_000, 1, 1))
    pose, pose_covariance = np.array([1.0, 2.0, 0.3]), np.diag([0.05 ** 2, 0.05 ** 2, 0.01 ** 2])
    values = np.array([[10.0, 0.2], [4.0, -1.0]])
    noise = np.tile(NOISE['range_bearing'], (2, 1, 1))
    columns = local_map_columns('range_bearing', pose, pose_covariance, means, marginals,
                                values, noise)
    distance = np.hypot(*(means[columns] - pose[:2]).T)
    assert distance.max() <= 10.0 + LOCAL_MAP_MARGIN + 6.5 * (0.05 + 0.05 + 0.05)
    assert 20 < len(columns) < 100
    everything_near = np.flatnonzero(np.hypot(*(means - pose[:2]).T) <= 15.0)
    assert set(everything_near) <= set(columns.tolist())
    explicit = local_map_columns('range_bearing', pose, pose_covariance, means, marginals,
                                 values, noise, radius=3.0)
    np.testing.assert_array_equal(explicit, np.flatnonzero(np.hypot(*(means - pose[:2]).T) <= 3.0))


def test_an_uncertain_heading_with_robot_frame_points_takes_the_whole_map():
    """point_robot with a yaw std beyond 1 / 6.4 rad: no distance bound exists."""
    means = np.array([[1.0, 0.0], [1e4, 0.0]])
    columns = local_map_columns('point_robot', np.zeros(3), np.diag([0.01, 0.01, 0.2 ** 2]),
                                means, np.tile(np.eye(2) * 1e-4, (2, 1, 1)),
                                np.array([[1.0, 0.0]]), np.eye(2)[None] * 1e-4)
    np.testing.assert_array_equal(columns, [0, 1])


def test_a_scan_without_observations_keeps_the_margin():
    columns = local_map_columns('range_bearing', np.zeros(3), np.eye(3) * 1e-6,
                                np.array([[3.0, 0.0], [50.0, 0.0]]),
                                np.tile(np.eye(2) * 1e-6, (2, 1, 1)), np.zeros((0, 2)),
                                np.zeros((0, 2, 2)))
    np.testing.assert_array_equal(columns, [0])
