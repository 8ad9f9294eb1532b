"""The widened second association after a motion outlier (core.pose_recovery)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_association_ros import Landmarks, Observations, RobotPose, associate
from data_association_ros.core import InvalidInputError
from data_association_ros.core.models import MODELS
from data_association_ros.core.pose_recovery import (RECOVERED, PoseRecovery,
                                                     associate_with_pose_recovery)
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2

from data_association_ros import NEW
from problem_factory import random_range_bearing_problem
from ros_harness import cloud, correspondences, odometry
from test_node import exchange, graph, set_parameters, settle  # noqa: F401 (graph: fixture)

# a corridor of landmarks 2 m apart; the robot believes it is at the origin (pose std 1 cm,
# 0.2 deg) but a wheel slip put it 0.4 m further and 3 deg turned
IDS = np.array([10, 11, 12, 13, 14])
MEANS = np.array([[2.0, 1.5], [4.0, 1.5], [6.0, 1.5], [2.0, -1.5], [4.0, -1.5]])
LANDMARK_COV = np.tile(np.eye(2) * 1e-4, (5, 1, 1))
POSE = RobotPose(np.zeros(3), np.diag([1e-4, 1e-4, 1e-5]))
TRUE_POSE = np.array([0.4, 0.0, np.radians(3.0)])
NOISE = np.eye(2) * 0.02 ** 2
SEEN = np.array([0, 1, 3, 4])


def slipped_scan() -> Observations:
    values, _, _ = MODELS['point_robot'].predict(MEANS[SEEN], TRUE_POSE)
    return Observations(values, np.tile(NOISE, (len(SEEN), 1, 1)), 'point_robot')


def landmarks() -> Landmarks:
    return Landmarks(IDS, MEANS, LANDMARK_COV)


def test_a_motion_outlier_is_recovered_with_the_true_pairs():
    plain = associate(landmarks(), slipped_scan(), 'jcbb', pose=POSE)
    assert (plain.assignment == -1).all()       # every landmark left its gate
    result = associate_with_pose_recovery(landmarks(), slipped_scan(), 'jcbb', POSE, None,
                                           PoseRecovery(0.5, 0.1))
    assert result.extras[RECOVERED] is True
    assert result.assignment.tolist() == IDS[SEEN].tolist()


def test_off_or_not_wanted_gives_the_plain_answer():
    off = associate_with_pose_recovery(landmarks(), slipped_scan(), 'jcbb', POSE, None,
                                       PoseRecovery())
    assert off.extras[RECOVERED] is False and (off.assignment == -1).all()
    # from the believed pose the scan is explained: no second pass however wide
    values, _, _ = MODELS['point_robot'].predict(MEANS[SEEN], POSE.mean)
    good = Observations(values, np.tile(NOISE, (len(SEEN), 1, 1)), 'point_robot')
    result = associate_with_pose_recovery(landmarks(), good, 'jcbb', POSE, None,
                                          PoseRecovery(5.0, 1.0))
    assert result.extras[RECOVERED] is False
    assert result.assignment.tolist() == IDS[SEEN].tolist()


def test_the_second_answer_needs_min_new_more_pairs():
    # one landmark seen: widening pairs one more observation, fewer than min_new 2
    values, _, _ = MODELS['point_robot'].predict(MEANS[:1], TRUE_POSE)
    one = Observations(np.vstack([values, [[30.0, 30.0]]]), np.tile(NOISE, (2, 1, 1)),
                       'point_robot')
    kept = associate_with_pose_recovery(landmarks(), one, 'jcbb', POSE, None,
                                        PoseRecovery(0.5, 0.1, min_new=2))
    assert kept.extras[RECOVERED] is False and kept.assignment.tolist() == [-1, -1]
    taken = associate_with_pose_recovery(landmarks(), one, 'jcbb', POSE, None,
                                         PoseRecovery(0.5, 0.1, min_new=1))
    assert taken.extras[RECOVERED] is True and taken.assignment.tolist() == [10, -1]


def test_widen_adds_to_the_pose_block_only():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(7, 7))
    joint = a @ a.T
    pose, wide = PoseRecovery(0.3, 0.2).widen(POSE, joint)
    extra = np.diag([0.09, 0.09, 0.04])
    np.testing.assert_allclose(pose.covariance, POSE.covariance + extra)
    expected = joint.copy()
    expected[:3, :3] += extra
    np.testing.assert_array_equal(wide, expected)
    assert not np.shares_memory(wide, joint)


@pytest.mark.parametrize('values', [dict(position_std=-1.0), dict(yaw_std=float('nan')),
                                    dict(min_new=0)])
def test_bad_settings_are_rejected(values):
    with pytest.raises(InvalidInputError):
        PoseRecovery(**values)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), clutter=st.integers(0, 6), slip=st.floats(0.0, 1.0),
       position_std=st.floats(0.0, 2.0), min_new=st.integers(1, 4))
def test_recovery_keeps_the_plain_answer_or_pairs_min_new_more(seed, clutter, slip,
                                                               position_std, min_new):
    rng = np.random.default_rng(seed)
    lm, obs, pose, joint, _ = random_range_bearing_problem(rng, 8, 5, clutter, joint=True)
    # the believed pose off by a slip (about 1 in 10 examples takes the second answer)
    pose = RobotPose(pose.mean + slip * rng.normal(size=3) * [0.5, 0.5, 0.1], pose.covariance)
    recovery = PoseRecovery(position_std, 0.05, min_new)
    plain = associate(lm, obs, 'jcbb', pose=pose, state_covariance=joint)
    result = associate_with_pose_recovery(lm, obs, 'jcbb', pose, joint, recovery)
    if result.extras[RECOVERED]:
        assert recovery.wanted(plain.assignment)
        assert (result.assignment >= 0).sum() >= (plain.assignment >= 0).sum() + min_new
        wide_pose, wide_joint = recovery.widen(pose, joint)
        np.testing.assert_array_equal(result.assignment, associate(
            lm, obs, 'jcbb', pose=wide_pose, state_covariance=wide_joint).assignment)
    else:
        np.testing.assert_array_equal(result.assignment, plain.assignment)


def test_the_node_recovers_over_dds_after_a_runtime_switch(graph):
    """association_node on a real rclpy graph: the slipped scan is all NEW, then (parameters
    set at run time) the true pairs, counted in the node's statistics."""
    graph.publisher(PointCloud2, 'landmarks').publish(cloud(
        {'id': IDS, 'x': MEANS[:, 0], 'y': MEANS[:, 1], 'cov_xx': LANDMARK_COV[:, 0, 0],
         'cov_xy': LANDMARK_COV[:, 0, 1], 'cov_yy': LANDMARK_COV[:, 1, 1]}, 5.0))
    graph.publisher(Odometry, 'robot_pose').publish(odometry(*POSE.mean, POSE.covariance, 5.0))
    settle(graph)
    scan = slipped_scan()
    msg = cloud({'x': scan.values[:, 0], 'y': scan.values[:, 1],
                 'cov_xx': np.full(len(scan), NOISE[0, 0]), 'cov_xy': np.zeros(len(scan)),
                 'cov_yy': np.full(len(scan), NOISE[1, 1])}, 5.0, 'base_link')
    assert set_parameters(graph, algorithm='jcbb')[0].successful
    assert correspondences(exchange(graph, msg))['landmark'].tolist() == [NEW] * len(SEEN)
    assert all(r.successful for r in set_parameters(graph, recovery_position_std=0.5,
                                                    recovery_yaw_std=0.1))
    assert correspondences(exchange(graph, msg))['landmark'].tolist() == IDS[SEEN].tolist()
    assert graph.node.statistics.pose_recoveries == 1
    assert not set_parameters(graph, recovery_position_std=-0.1)[0].successful
