"""Exact spatial gating: with the index every associator gives the unindexed answer, pair for
pair and NIS for NIS, and no pair inside a gate ever lies outside the search radius."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from data_association_ros import InvalidInputError, Landmarks, Observations, RobotPose, associate
from data_association_ros.core.gating import chi2_threshold, likelihood_gate, nis_gate
from data_association_ros.core.models import MODELS
from data_association_ros.core.problem import AssociationProblem
from data_association_ros.core.spatial_index import (INDEX_BUILD_MIN_LANDMARKS,
                                                     INDEX_MIN_LANDMARKS, LandmarkIndex,
                                                     has_index, landmark_index,
                                                     landmark_spreads, search_radii,
                                                     wants_index)
from data_association_ros.core.validation import check_covariance_matrix

GATED = ('euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood', 'gnn', 'jcbb')
MODEL_DIMS = {'point_map': 2, 'point_robot': 2, 'range_bearing': 2, 'box': 4}


def _spd(rng, count: int, dim: int, scale: float) -> np.ndarray:
    a = rng.normal(size=(count, dim, dim)) * scale
    return a @ np.swapaxes(a, 1, 2) + np.eye(dim) * 1e-4 * max(float(np.max(scale, initial=0.0)), 1e-3) ** 2


def random_problem(rng, model: str, n: int, k: int, landmark_scale: float, pose_scale: float,
                   joint: bool = False):
    """(landmarks, observations, pose, state_covariance): observations of some landmarks (with
    noise 10x the stated sigma now and then) and of nothing."""
    dim = MODEL_DIMS[model]
    half = rng.uniform(5, 60)
    means = rng.uniform(-half, half, (n, dim))
    if model == 'box':
        means[:, 2:] = rng.uniform(5, 40, (n, 2))
    covariances = _spd(rng, n, dim, landmark_scale * rng.uniform(0.1, 3.0, (n, 1, 1)))
    pose_cov = _spd(rng, 1, 3, pose_scale)[0]
    pose = RobotPose(rng.uniform(-5, 5, 3), pose_cov)
    state_covariance = None
    if joint and model in ('point_robot', 'range_bearing', 'point_map'):
        size = 3 + dim * n
        g = rng.normal(size=(size, 4)) * pose_scale
        state_covariance = g @ g.T
        state_covariance[:3, :3] += pose_cov
        for j in range(n):
            state_covariance[3 + dim * j:3 + dim * (j + 1), 3 + dim * j:3 + dim * (j + 1)] \
                += covariances[j]
    seen = rng.integers(0, max(n, 1), k)
    if n and model in ('point_robot', 'range_bearing'):
        values = MODELS[model].predict(means[seen], pose.mean)[0]
    elif n:
        values = means[seen].copy()
    else:
        values = rng.uniform(-half, half, (k, dim))
    sigma = np.array([0.3, 0.02]) if model == 'range_bearing' else np.full(dim, 0.3)
    noise = np.tile(np.diag(sigma ** 2), (k, 1, 1))
    values = values + rng.normal(size=values.shape) * sigma * rng.choice([1.0, 10.0], (k, 1))
    if model == 'box':
        values[:, 2:] = np.abs(values[:, 2:])
    return (Landmarks(np.arange(n) * 7 + 3, means, covariances),
            Observations(values, noise, model), pose, state_covariance)


def assert_same(landmarks, observations, pose, state_covariance, algorithm, **params):
    plain = associate(landmarks, observations, algorithm, pose=pose,
                      state_covariance=state_covariance, spatial_index=False, **params)
    indexed = associate(landmarks, observations, algorithm, pose=pose,
                        state_covariance=state_covariance, spatial_index=True, **params)
    np.testing.assert_array_equal(indexed.assignment, plain.assignment)
    np.testing.assert_array_equal(indexed.nis, plain.nis)
    if algorithm == 'jcbb':
        assert indexed.extras['joint_nis'] == plain.extras['joint_nis']
    return plain


@pytest.mark.parametrize('model', ['point_map', 'point_robot', 'range_bearing', 'box'])
def test_indexed_answers_equal_unindexed_on_random_problems(model):
    """600 problems per model, every gated associator, covariances from tight to wider than
    the map, maps of 0, 1 and up to 150 landmarks."""
    rng = np.random.default_rng(sum(map(ord, model)))
    paired = 0
    for trial in range(600):
        n = int(rng.choice([0, 1, 2, rng.integers(3, 150)]))
        k = int(rng.integers(0, 12))
        problem = random_problem(rng, model, n, k, landmark_scale=rng.choice([0.02, 0.3, 3.0]),
                                 pose_scale=rng.choice([0.0, 0.02, 0.2]),
                                 joint=trial % 4 == 0)
        for algorithm in GATED:
            params = {'max_nodes': 2000} if algorithm == 'jcbb' else {}
            if algorithm != 'euclidean_nn':
                params['min_innovation_variance'] = float(rng.choice([0.0, 1e-9, 0.5]))
            result = assert_same(*problem, algorithm, **params)
            paired += int((result.assignment >= 0).sum())
    assert paired > 1000   # the comparison is about real pairings


def test_point_map_3d_and_jcbb_points():
    rng = np.random.default_rng(3)
    for _ in range(150):
        n, k = int(rng.integers(0, 120)), int(rng.integers(0, 10))
        means = rng.uniform(-20, 20, (n, 3))
        landmarks = Landmarks(np.arange(n), means, _spd(rng, n, 3, 0.3))
        values = (means[rng.integers(0, max(n, 1), k)] if n else rng.uniform(-20, 20, (k, 3))) \
            + rng.normal(size=(k, 3)) * 0.2
        assert_same(landmarks, Observations(values, np.tile(np.eye(3) * 0.04, (k, 1, 1)),
                                            'point_map'), None, None, 'mahalanobis_nn')
    for _ in range(150):
        landmarks, observations, pose, _ = random_problem(rng, 'point_robot',
                                                          int(rng.integers(0, 80)),
                                                          int(rng.integers(0, 10)), 0.1, 0.02)
        assert_same(landmarks, observations, pose, None, 'jcbb_points', max_nodes=500)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1), model=st.sampled_from(sorted(MODEL_DIMS)),
       algorithm=st.sampled_from(GATED), n=st.integers(0, 90), k=st.integers(0, 8),
       landmark_scale=st.floats(0.001, 20.0), pose_scale=st.floats(0.0, 1.0),
       joint=st.booleans(), gate=st.floats(0.5, 0.99999))
def test_indexed_equals_unindexed_property(seed, model, algorithm, n, k, landmark_scale,
                                           pose_scale, joint, gate):
    rng = np.random.default_rng(seed)
    problem = random_problem(rng, model, n, k, landmark_scale, pose_scale, joint)
    params = {'max_nodes': 500} if algorithm == 'jcbb' else {}
    if algorithm in ('mahalanobis_nn', 'gnn', 'jcbb'):
        params['gate_probability'] = gate
    assert_same(*problem, algorithm, **params)


@pytest.mark.parametrize('model', ['point_map', 'point_robot', 'range_bearing'])
def test_every_pair_inside_the_gate_lies_inside_the_radius(model):
    """The bound itself, on problems whose gates cover much of the map (large pose and landmark
    covariances, a large floor): every pair with d2 <= gamma is within radius_of(sigma_m)."""
    rng = np.random.default_rng(11)
    inside = 0
    for trial in range(300):
        landmarks, observations, pose, joint = random_problem(
            rng, model, int(rng.integers(1, 60)), int(rng.integers(1, 8)),
            landmark_scale=rng.choice([0.05, 1.0, 5.0]), pose_scale=rng.choice([0.01, 0.1, 0.3]),
            joint=trial % 3 == 0)
        floor = float(rng.choice([0.0, 0.3]))
        problem = AssociationProblem(landmarks, observations, pose, joint, floor)
        gamma = chi2_threshold(0.999, 2)
        points, radius_of = search_radii(model, observations, pose.mean, problem.pose_covariance,
                                         nis_gate(observations, 0.999), floor)
        spreads = landmark_spreads(landmarks, problem.state_covariance)
        distance = np.linalg.norm(points[:, None, :] - landmarks.means[None, :, :], axis=-1)
        for j in range(len(landmarks)):
            gated = problem.nis[:, j] <= gamma
            assert np.all(distance[gated, j] <= radius_of(spreads[j])[gated])
            inside += int(gated.sum())
    assert inside > 200


def test_landmarks_on_the_gate_boundary_are_kept():
    """Isotropic S (no pose, point_map): the radius bound is tight, D = sqrt(gamma s); landmarks
    at NIS = gamma (1 - 1e-9) must still be paired, at gamma (1 + 1e-6) they are NEW."""
    gamma = chi2_threshold(0.99, 2)
    s = 0.04 + 0.01
    angles = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    radius = np.sqrt(gamma * s)
    for factor, paired in ((1 - 1e-9, True), (1 + 1e-6, False)):
        observations_xy = np.column_stack([np.arange(64) * 100.0, np.zeros(64)])
        offsets = np.sqrt(factor) * radius * np.column_stack([np.cos(angles), np.sin(angles)])
        landmarks = Landmarks(np.arange(64), observations_xy + offsets,
                              np.tile(np.eye(2) * 0.04, (64, 1, 1)))
        observations = Observations(observations_xy, np.tile(np.eye(2) * 0.01, (64, 1, 1)))
        result = assert_same(landmarks, observations, None, None, 'mahalanobis_nn',
                             gate_probability=0.99)
        assert np.all((result.assignment == np.arange(64)) == paired)


def test_index_is_built_once_per_map_and_per_joint_covariance():
    rng = np.random.default_rng(5)
    landmarks, observations, pose, joint = random_problem(rng, 'range_bearing', 100, 5, 0.1, 0.02,
                                                         joint=True)
    first = landmark_index(landmarks)
    assert landmark_index(landmarks) is first
    checked = check_covariance_matrix(joint, 'state_covariance')
    with_joint = landmark_index(landmarks, checked)
    assert with_joint is not first and landmark_index(landmarks, checked) is with_joint
    other = check_covariance_matrix(joint.copy(), 'state_covariance')
    assert landmark_index(landmarks, other) is not with_joint
    # a map is immutable, so its index cannot go stale
    with pytest.raises(ValueError):
        landmarks.means[0, 0] = 1.0


def test_automatic_choice_builds_for_large_maps_and_reuses_a_built_index():
    """spatial_index=None: a new map of fewer than INDEX_BUILD_MIN_LANDMARKS is not indexed (one
    scan would not pay for the trees), a larger one is; a map whose index exists is indexed from
    INDEX_MIN_LANDMARKS (a prior map serving every scan); the answers never change."""
    rng = np.random.default_rng(11)
    for n, prebuilt, indexed in ((INDEX_BUILD_MIN_LANDMARKS - 1, False, False),
                                 (INDEX_BUILD_MIN_LANDMARKS, False, True),
                                 (INDEX_MIN_LANDMARKS, True, True),
                                 (INDEX_MIN_LANDMARKS - 1, True, False)):
        landmarks, observations, pose, _ = random_problem(rng, 'range_bearing', n, 8, 0.1, 0.02)
        if prebuilt:
            landmark_index(landmarks)
        assert wants_index(landmarks) == indexed, (n, prebuilt)
        expected = associate(landmarks.subset(np.arange(n)), observations, 'jcbb', pose=pose,
                             spatial_index=False)
        answer = associate(landmarks, observations, 'jcbb', pose=pose)
        np.testing.assert_array_equal(answer.assignment, expected.assignment)
        np.testing.assert_array_equal(answer.nis, expected.nis)
        assert has_index(landmarks) == (indexed or prebuilt), (n, prebuilt)


def test_a_few_uncertain_landmarks_do_not_widen_the_search_for_the_rest():
    """Landmarks every 2 m, one in 100 with sigma 50 m: searched with radius 3 sigma + 1, the
    narrow ones within 1.3 m, the wide ones within 151 m (one tree per spread class); one tree
    with the largest sigma would return all 152 landmarks within 151 m."""
    means = np.column_stack([np.arange(1000) * 2.0, np.zeros(1000)])
    spreads = np.full(1000, 0.1)
    spreads[::100] = 50.0
    point = np.array([[1001.0, 0.0]])
    found = LandmarkIndex(means, spreads).candidates(point, lambda s: np.array([3.0 * s + 1.0]))
    assert list(found) == [500, 501]
    brute = [j for j in range(1000) if abs(2.0 * j - 1001.0) <= 3.0 * spreads[j] + 1.0]
    assert list(found) == brute
    single = LandmarkIndex(means, np.full(1000, 50.0)).candidates(
        point, lambda s: np.array([3.0 * s + 1.0]))
    assert len(single) == 152


def test_far_and_huge_maps_are_exact():
    """A landmark at 1e12 m, and an observation far outside every map."""
    means = np.vstack([np.column_stack([np.arange(200.0), np.zeros(200)]), [[1e12, 1e12]]])
    landmarks = Landmarks(np.arange(201), means, np.tile(np.eye(2) * 0.01, (201, 1, 1)))
    observations = Observations([[5.05, 0.0], [1e12 + 0.05, 1e12], [-5e11, 3.0]],
                                np.tile(np.eye(2) * 0.01, (3, 1, 1)))
    result = assert_same(landmarks, observations, None, None, 'mahalanobis_nn')
    assert list(result.assignment) == [5, 200, -1]


def test_likelihood_gate_bounds_the_likelihood_test():
    """maximum_likelihood accepts log N(nu; 0, S) >= log alpha only where d2 <= its bound."""
    rng = np.random.default_rng(8)
    landmarks, observations, pose, _ = random_problem(rng, 'range_bearing', 80, 10, 0.3, 0.05)
    problem = AssociationProblem(landmarks, observations, pose)
    alpha = 0.01
    accepted = problem.log_likelihoods >= np.log(alpha)
    bound = likelihood_gate(observations, alpha).nis_bound
    assert accepted.any()
    assert np.all(problem.nis[accepted] <= bound[:, None].repeat(len(landmarks), 1)[accepted])


def test_joint_covariance_only_the_local_block_is_factorised():
    """A joint covariance that is not positive semi-definite far from the robot is not read
    (with or without the index: the individual NIS reads the [pose, landmark] blocks, JCBB the
    joint block of the candidates); one whose block in use is not is refused."""
    n = 200
    means = np.column_stack([np.arange(n) * 10.0, np.zeros(n)])
    landmarks = Landmarks(np.arange(n), means, np.tile(np.eye(2) * 0.01, (n, 1, 1)))
    joint = np.eye(3 + 2 * n) * 0.01
    joint[:3, :3] = np.diag([0.01, 0.01, 0.001])
    far = 3 + 2 * 150
    joint[far, far + 2] = joint[far + 2, far] = 1.0      # landmarks 150 and 151: not PSD
    observations = Observations([[10.0, 0.0]], np.eye(2)[None] * 0.01, 'point_robot')
    pose = RobotPose([0.0, 0.0, 0.0], joint[:3, :3])
    for indexed in (True, False):    # unindexed too: only the blocks used are factorised
        result = associate(landmarks, observations, 'jcbb', pose=pose, state_covariance=joint,
                           spatial_index=indexed)
        assert list(result.assignment) == [1]
    near = joint.copy()
    near[far, far + 2] = near[far + 2, far] = 0.0
    near[5, 6] = near[6, 5] = 1.0                        # landmark 1 (read): not PSD
    with pytest.raises(InvalidInputError, match='state_covariance: not positive'):
        associate(landmarks, observations, 'jcbb', pose=pose, state_covariance=near)
    nan = joint.copy()
    nan[far, far] = np.nan
    with pytest.raises(InvalidInputError, match='state_covariance'):
        associate(landmarks, observations, 'jcbb', pose=pose, state_covariance=nan)
    with pytest.raises(InvalidInputError, match='landmarks.means'):
        Landmarks([0, 1], [[0.0, np.nan], [1.0, 1.0]])
