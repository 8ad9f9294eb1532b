"""Single-scan associators against direct computations, brute force and the seeds' examples."""
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import chi2, multivariate_normal

from data_association_ros import (NEW, UNASSOCIATED, Landmarks, Observations, RobotPose, associate,
                                  available_algorithms)
from data_association_ros.core.associators.iou import iou_matrix
from data_association_ros.core.gating import chi2_threshold
from problem_factory import one_to_one_subsets, pair_nis, random_range_bearing_problem


def pairwise(landmarks, observations, pose, state_covariance=None):
    """NIS and log-likelihood (K, N), one pair at a time from full Jacobians."""
    k, n = len(observations), len(landmarks)
    nis, loglik = np.zeros((k, n)), np.zeros((k, n))
    for i in range(k):
        for j in range(n):
            nis[i, j], s = pair_nis(landmarks, observations, pose, state_covariance, i, j)
            loglik[i, j] = -0.5 * (nis[i, j] + np.log(np.linalg.det(2 * np.pi * s)))
    return nis, loglik


@pytest.mark.parametrize('seed', range(40))
def test_mahalanobis_nn_and_maximum_likelihood_equal_direct_computation(seed):
    rng = np.random.default_rng(seed)
    landmarks, observations, pose, state_covariance, _ = random_range_bearing_problem(
        rng, 8, 5, 2, duplicates=2, joint=seed % 2 == 1)
    if seed >= 20:  # R per observation (the general path; one shared R takes a shortcut)
        scale = rng.uniform(0.5, 2.0, len(observations))[:, None, None]
        observations = Observations(observations.values, observations.covariances * scale,
                                    observations.model)
    nis, loglik = pairwise(landmarks, observations, pose, state_covariance)
    gate = chi2.ppf(0.95, 2)
    mnn = associate(landmarks, observations, 'mahalanobis_nn', pose=pose,
                    state_covariance=state_covariance, gate_probability=0.95)
    best = nis.argmin(axis=1)
    expected = np.where(nis.min(axis=1) <= gate, landmarks.ids[best], NEW)
    np.testing.assert_array_equal(mnn.assignment, expected)
    chosen = mnn.assignment >= 0
    np.testing.assert_allclose(mnn.nis[chosen], nis.min(axis=1)[chosen], rtol=1e-9)
    assert np.all(np.isnan(mnn.nis[~chosen]))

    alpha = 0.05
    ml = associate(landmarks, observations, 'maximum_likelihood', pose=pose,
                   state_covariance=state_covariance, new_landmark_likelihood=alpha)
    best = loglik.argmax(axis=1)
    expected = np.where(loglik.max(axis=1) >= np.log(alpha), landmarks.ids[best], NEW)
    np.testing.assert_array_equal(ml.assignment, expected)


def test_maximum_likelihood_weighs_log_det_where_mahalanobis_does_not():
    # landmark 0 tight and 1.5 sigma away, landmark 1 vague and 1 sigma away
    landmarks = Landmarks([0, 1], [[1.5 * 0.1, 0.0], [-3.0, 0.0]],
                          [np.eye(2) * 0.01, np.eye(2) * 9.0])
    observations = Observations([[0.0, 0.0]], [np.eye(2) * 1e-6], 'point_map')
    assert associate(landmarks, observations, 'mahalanobis_nn').assignment[0] == 1
    assert associate(landmarks, observations, 'maximum_likelihood',
                     new_landmark_likelihood=1e-6).assignment[0] == 0


def test_maximum_likelihood_new_landmark_threshold_hand_computed():
    landmarks = Landmarks([4], [[0.0, 0.0]], [np.eye(2) * 0.5])
    observations = Observations([[1.0, 0.0]], [np.eye(2) * 0.5], 'point_map')
    density = multivariate_normal(np.zeros(2), np.eye(2)).pdf([1.0, 0.0])  # S = I
    assert associate(landmarks, observations, 'maximum_likelihood',
                     new_landmark_likelihood=density * 0.99).assignment[0] == 4
    assert associate(landmarks, observations, 'maximum_likelihood',
                     new_landmark_likelihood=density * 1.01).assignment[0] == NEW


@pytest.mark.parametrize('seed', range(40))
def test_gnn_equals_brute_force_minimum_cost(seed):
    rng = np.random.default_rng(100 + seed)
    landmarks, observations, pose, _, _ = random_range_bearing_problem(
        rng, int(rng.integers(2, 6)), int(rng.integers(1, 5)), int(rng.integers(0, 3)),
        duplicates=2)
    nis, _ = pairwise(landmarks, observations, pose)
    gate = chi2.ppf(0.99, 2)
    compatible = nis <= gate
    costs = [(sum(nis[i, j] for i, j in pairs) + gate * (len(observations) - len(pairs)), pairs)
             for pairs in one_to_one_subsets(compatible)]
    best_cost, best_pairs = min(costs, key=lambda c: c[0])
    result = associate(landmarks, observations, 'gnn', pose=pose)
    paired = np.flatnonzero(result.assignment >= 0)
    column = {lid: j for j, lid in enumerate(landmarks.ids)}
    cost = sum(nis[i, column[result.assignment[i]]] for i in paired) + \
        gate * (len(observations) - len(paired))
    assert cost == pytest.approx(best_cost, rel=1e-9)
    assert len(set(result.assignment[paired])) == len(paired)  # one-to-one
    expected_unpaired = np.where(compatible.any(axis=1), UNASSOCIATED, NEW)
    unpaired = result.assignment < 0
    np.testing.assert_array_equal(result.assignment[unpaired], expected_unpaired[unpaired])


def test_euclidean_nn_direct_and_gate():
    rng = np.random.default_rng(3)
    means = rng.uniform(-5, 5, (30, 2))
    values = rng.uniform(-6, 6, (20, 2))
    landmarks = Landmarks(np.arange(30) + 100, means)
    observations = Observations(values, model='point_map')
    result = associate(landmarks, observations, 'euclidean_nn', euclidean_gate=0.7)
    distance = np.linalg.norm(values[:, None] - means[None], axis=-1)
    expected = np.where(distance.min(axis=1) <= 0.7, distance.argmin(axis=1) + 100, NEW)
    np.testing.assert_array_equal(result.assignment, expected)
    assert np.all(np.isnan(result.nis))  # no covariances given, no NIS


def test_nearest_neighbour_is_greedy_unless_one_to_one():
    landmarks = Landmarks([7, 8], [[0.0, 0.0], [3.0, 0.0]], np.tile(np.eye(2) * 0.1, (2, 1, 1)))
    observations = Observations([[0.1, 0.0], [-0.2, 0.0], [2.5, 0.0]],
                                np.tile(np.eye(2) * 0.1, (3, 1, 1)), 'point_map')
    for algorithm in ('euclidean_nn', 'mahalanobis_nn'):
        greedy = associate(landmarks, observations, algorithm)
        np.testing.assert_array_equal(greedy.assignment, [7, 7, 8])
        # one-to-one: the closer observation keeps landmark 7; the other is inside its gate,
        # so it is UNASSOCIATED, never a new landmark
        exclusive = associate(landmarks, observations, algorithm, one_to_one=True)
        np.testing.assert_array_equal(exclusive.assignment, [7, UNASSOCIATED, 8])


def test_one_to_one_greedy_matches_sorted_greedy_on_random_costs():
    rng = np.random.default_rng(11)
    for _ in range(50):
        means = rng.uniform(-3, 3, (6, 2))
        values = rng.uniform(-3, 3, (7, 2))
        result = associate(Landmarks(np.arange(6), means), Observations(values),
                           'euclidean_nn', euclidean_gate=2.0, one_to_one=True)
        distance = np.linalg.norm(values[:, None] - means[None], axis=-1)
        expected = np.full(7, NEW)
        used_rows, used_cols = set(), set()
        for flat in np.argsort(distance, axis=None):
            i, j = np.unravel_index(flat, distance.shape)
            if distance[i, j] <= 2.0 and i not in used_rows and j not in used_cols:
                expected[i] = j
                used_rows.add(i)
                used_cols.add(j)
        gated = (distance <= 2.0).any(axis=1)
        expected[(expected == NEW) & gated] = UNASSOCIATED
        np.testing.assert_array_equal(result.assignment, expected)


def test_seed_004_iou_example():
    # A: top-left (2, 3), 5 x 4; B: top-left (4, 5), 6 x 3 -> IoU 6 / 32 = 0.1875
    a = np.array([[2 + 2.5, 3 + 2.0, 5.0, 4.0]])
    b = np.array([[4 + 3.0, 5 + 1.5, 6.0, 3.0]])
    assert iou_matrix(a, b)[0, 0] == pytest.approx(0.1875)
    landmarks, observations = Landmarks([1], b), Observations(a, model='box')
    assert associate(landmarks, observations, 'iou').assignment[0] == NEW  # below 0.3
    assert associate(landmarks, observations, 'iou', iou_threshold=0.15).assignment[0] == 1


def test_iou_is_one_to_one_by_total_overlap():
    tracks = Landmarks([5, 6], [[0, 0, 2, 2], [1.5, 0, 2, 2]])
    # detection 0 overlaps both tracks, detection 1 only track 5: Hungarian gives 0->6, 1->5
    detections = Observations([[0.9, 0, 2, 2], [-0.2, 0, 2, 2]], model='box')
    result = associate(tracks, detections, 'iou')
    np.testing.assert_array_equal(result.assignment, [6, 5])
    overlap = iou_matrix(detections.values, tracks.means)
    np.testing.assert_allclose(result.extras['iou'], [overlap[0, 1], overlap[1, 0]])


def test_seed_004_mahalanobis_example():
    # z = (5, 3), x = (4.5, 3.5), S = [[0.5, 0.1], [0.1, 0.3]]: D_M = sqrt(1.78575) = 1.336
    r = np.eye(2) * 0.1
    landmarks = Landmarks([0], [[4.5, 3.5]], [np.array([[0.5, 0.1], [0.1, 0.3]]) - r])
    observations = Observations([[5.0, 3.0]], [r], 'point_map')
    result = associate(landmarks, observations, 'mahalanobis_nn')
    assert result.nis[0] == pytest.approx(0.25 / 0.14)
    assert np.sqrt(result.nis[0]) == pytest.approx(1.336, abs=5e-4)
    assert result.assignment[0] == 0


@pytest.mark.parametrize('algorithm', ['euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood',
                                       'gnn', 'jcbb'])
def test_empty_sets(algorithm):
    lm = Landmarks([3, 4], [[0, 0], [1, 1]], np.tile(np.eye(2), (2, 1, 1)))
    obs = Observations([[0, 0.1]], [np.eye(2)], 'point_map')
    no_obs = associate(lm, Observations(np.zeros((0, 2)), np.zeros((0, 2, 2))), algorithm)
    assert no_obs.assignment.shape == (0,) and no_obs.nis.shape == (0,)
    no_map = associate(Landmarks([], np.zeros((0, 2)), np.zeros((0, 2, 2))), obs, algorithm)
    np.testing.assert_array_equal(no_map.assignment, [NEW])


def test_every_algorithm_is_registered():
    assert set(available_algorithms()) == {'euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood',
                                           'gnn', 'jcbb', 'jcbb_points', 'iou'}


@pytest.mark.parametrize('algorithm', ['euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood',
                                       'gnn', 'jcbb'])
def test_landmark_behind_robot_is_associated(algorithm):
    # MRPT's EKF-SLAM lost landmarks at bearing +-pi: the innovation must be wrapped
    landmarks = Landmarks([9], [[-5.0, 0.01]], [np.eye(2) * 0.01])
    pose = RobotPose([0.0, 0.0, 0.0], np.eye(3) * 1e-4)
    observations = Observations([[5.0, -np.pi + 0.001]], [np.diag([0.01, 1e-4])],
                                'range_bearing')
    assert associate(landmarks, observations, algorithm, pose=pose).assignment[0] == 9


@pytest.mark.parametrize('seed', range(12))
def test_nis_matrix_equals_pairwise_solve_with_and_without_a_floor(seed):
    """AssociationProblem.nis (the closed 2 x 2 form, shared S per landmark or S per pair built
    from components) against nu^T solve(S, nu) pair by pair, with the diagonal floor."""
    from data_association_ros.core.problem import AssociationProblem
    from problem_factory import innovation
    rng = np.random.default_rng(300 + seed)
    landmarks, observations, pose, state_covariance, _ = random_range_bearing_problem(
        rng, 7, 5, 2, duplicates=1, joint=seed % 2 == 1)
    if seed % 4 >= 2:   # R per observation
        scale = rng.uniform(0.5, 2.0, len(observations))[:, None, None]
        observations = Observations(observations.values, observations.covariances * scale,
                                    observations.model)
    floor = [0.0, 0.5][seed % 3 == 0]   # 0.5 binds on most range variances
    problem = AssociationProblem(landmarks, observations, pose, state_covariance, floor)
    for i in range(len(observations)):
        for j in range(len(landmarks)):
            _, s = pair_nis(landmarks, observations, pose, state_covariance, i, j)
            s[np.diag_indices(2)] = np.maximum(np.diag(s), floor)
            nu = innovation(landmarks, observations, pose, i, j)
            assert problem.nis[i, j] == pytest.approx(float(nu @ np.linalg.solve(s, nu)),
                                                      rel=1e-9)


def test_nis_of_a_singular_or_absurd_s_is_never_gated():
    from data_association_ros.core.problem import nis_2d, nis_of_innovations
    nu = np.array([[1.0, 2.0], [0.0, 0.0], [1.0, 0.0], [1e200, 1e200]])
    s = np.array([[[1.0, 1.0], [1.0, 1.0]],       # det 0
                  [[1.0, 2.0], [2.0, 1.0]],       # indefinite
                  [[4.0, 0.0], [0.0, 1.0]],       # fine: 1 / 4
                  [[1.0, 0.0], [0.0, 1.0]]])      # overflows
    np.testing.assert_array_equal(nis_of_innovations(nu, s), [np.inf, np.inf, 0.25, np.inf])
    assert nis_2d(np.array(3.0), np.array(4.0), 1.0, 0.0, 1.0) == 25.0
    # a 3-D model takes the general path (LAPACK inverse)
    s3 = np.diag([4.0, 1.0, 2.0])[None]
    np.testing.assert_allclose(nis_of_innovations(np.array([[2.0, 1.0, 2.0]]), s3), [4.0])


@given(st.floats(1e-6, 1.0 - 1e-9), st.integers(1, 400))
def test_chi2_threshold_is_scipy_stats_chi2_ppf(probability, dof):
    # gating computes it without importing scipy.stats (a second of every node's start-up)
    assert chi2_threshold(probability, dof) == pytest.approx(chi2.ppf(probability, dof),
                                                             rel=1e-12, abs=1e-300)


def test_chi2_threshold_of_two_dof_hand_computed():
    # chi2 with 2 dof is exponential with mean 2: quantile -2 ln(1 - p)
    assert chi2_threshold(0.99, 2) == pytest.approx(-2.0 * np.log(0.01), rel=1e-13)
