"""JCBB against brute force: the most pairs, then the smallest joint NIS, among all one-to-one
sets of individually compatible pairs passing the joint chi-square test of their dimension."""
import numpy as np
import pytest
from scipy.stats import chi2

from data_association_ros import NEW, UNASSOCIATED, Landmarks, Observations, RobotPose, associate
from problem_factory import (joint_nis, one_to_one_subsets, pair_nis,
                             random_range_bearing_problem)

GATE = 0.99


def brute_force_jcbb(landmarks, observations, pose, state_covariance):
    """(best pairs [(i, j)], their joint NIS, individual-compatibility matrix)."""
    k, n = len(observations), len(landmarks)
    compatible = np.zeros((k, n), dtype=bool)
    for i in range(k):
        for j in range(n):
            compatible[i, j] = pair_nis(landmarks, observations, pose, state_covariance, i, j)[0] \
                <= chi2.ppf(GATE, observations.dim)
    best, best_nis = [], 0.0
    for pairs in one_to_one_subsets(compatible):
        if len(pairs) < len(best):
            continue
        d2 = joint_nis(landmarks, observations, pose, state_covariance, pairs)
        if d2 <= chi2.ppf(GATE, observations.dim * len(pairs)) and (
                len(pairs) > len(best) or d2 < best_nis):
            best, best_nis = pairs, d2
    return best, best_nis, compatible


def expected_assignment(landmarks, pairs, compatible):
    expected = np.where(compatible.any(axis=1), UNASSOCIATED, NEW)
    for i, j in pairs:
        expected[i] = landmarks.ids[j]
    return expected


def check_against_brute_force(seed, joint):
    rng = np.random.default_rng(seed)
    landmarks, observations, pose, state_covariance, _ = random_range_bearing_problem(
        rng, n_landmarks=int(rng.integers(2, 7)), n_seen=int(rng.integers(1, 5)),
        n_clutter=int(rng.integers(0, 3)), duplicates=int(rng.integers(0, 3)), joint=joint)
    best, best_nis, compatible = brute_force_jcbb(landmarks, observations, pose,
                                                  state_covariance)
    result = associate(landmarks, observations, 'jcbb', pose=pose,
                       state_covariance=state_covariance, gate_probability=GATE)
    np.testing.assert_array_equal(result.assignment,
                                  expected_assignment(landmarks, best, compatible))
    assert result.extras['joint_nis'] == pytest.approx(best_nis, rel=1e-7, abs=1e-9)
    assert not result.truncated
    return len(best)


@pytest.mark.parametrize('block', range(6))
def test_jcbb_equals_brute_force_block_diagonal(block):
    pairs = [check_against_brute_force(seed, joint=False) for seed in range(block * 50,
                                                                           block * 50 + 50)]
    assert sum(pairs) > 50  # the problems are not trivially empty


@pytest.mark.parametrize('block', range(3))
def test_jcbb_equals_brute_force_full_state_covariance(block):
    pairs = [check_against_brute_force(seed, joint=True) for seed in range(1000 + block * 50,
                                                                           1050 + block * 50)]
    assert sum(pairs) > 50


def shared_yaw_error_scan():
    """Four landmarks 10 m away at bearings 0, 0.2, 0.4, 0.6 rad; the robot's yaw is 0.12 rad
    more than its estimate, so every observation appears 0.12 rad clockwise: each of the last
    three lies closer (0.08 rad) to the wrong neighbour than to its own landmark (0.12 rad)."""
    bearings = np.array([0.0, 0.2, 0.4, 0.6])
    means = 10.0 * np.column_stack([np.cos(bearings), np.sin(bearings)])
    landmarks = Landmarks([0, 1, 2, 3], means, np.tile(np.eye(2) * 1e-4, (4, 1, 1)))
    pose = RobotPose([0.0, 0.0, 0.0], np.diag([1e-4, 1e-4, 0.1 ** 2]))
    values = np.column_stack([np.full(4, 10.0), bearings - 0.12])
    observations = Observations(values, np.tile(np.diag([0.01, 1e-4]), (4, 1, 1)),
                                'range_bearing')
    return landmarks, observations, pose


def test_jcbb_right_where_mahalanobis_nn_is_wrong_under_shared_pose_error():
    landmarks, observations, pose = shared_yaw_error_scan()
    jcbb = associate(landmarks, observations, 'jcbb', pose=pose)
    nn = associate(landmarks, observations, 'mahalanobis_nn', pose=pose)
    np.testing.assert_array_equal(jcbb.assignment, [0, 1, 2, 3])
    np.testing.assert_array_equal(nn.assignment, [0, 0, 1, 2])


def test_node_budget_cuts_search_short_and_flags_it():
    rng = np.random.default_rng(7)
    landmarks, observations, pose, _, _ = random_range_bearing_problem(
        rng, n_landmarks=12, n_seen=10, n_clutter=2, duplicates=4)
    full = associate(landmarks, observations, 'jcbb', pose=pose)
    assert full.extras['search_nodes'] > 5 and not full.truncated
    cut = associate(landmarks, observations, 'jcbb', pose=pose, max_nodes=3)
    assert cut.truncated and cut.extras['search_nodes'] <= 3
    assert (cut.assignment >= 0).sum() <= (full.assignment >= 0).sum()


@pytest.mark.parametrize('block', range(10))
def test_fast_jcbb_equals_the_straightforward_reference(block):
    """2,000 random problems (200 per block): clutter, near-duplicates, correlated pose error,
    half with a full state covariance."""
    from reference_jcbb import reference_jcbb
    for seed in range(5000 + block * 200, 5000 + (block + 1) * 200):
        rng = np.random.default_rng(seed)
        landmarks, observations, pose, state_covariance, _ = random_range_bearing_problem(
            rng, n_landmarks=int(rng.integers(2, 10)), n_seen=int(rng.integers(1, 7)),
            n_clutter=int(rng.integers(0, 3)), duplicates=int(rng.integers(0, 4)),
            joint=bool(seed % 2))
        expected, expected_nis, _ = reference_jcbb(landmarks, observations, pose,
                                                   state_covariance)
        result = associate(landmarks, observations, 'jcbb', pose=pose,
                           state_covariance=state_covariance)
        np.testing.assert_array_equal(result.assignment, expected, err_msg=f'seed {seed}')
        assert result.extras['joint_nis'] == pytest.approx(expected_nis, rel=1e-7, abs=1e-9)
