"""Rigid SE(2) transforms: exact recovery, no reflections, covariance consistency, RANSAC."""
import dataclasses

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from data_association_ros.core.errors import InvalidInputError
from data_association_ros.core.transforms import (RigidTransform2D, estimate_rigid_transform,
                                                  ransac_rigid_transform)


def rotation(yaw):
    return np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])


def wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


def transform_points(points, x, y, yaw):
    return points @ rotation(yaw).T + np.array([x, y])


def error_vector(estimate, x, y, yaw):
    return np.array([estimate.x - x, estimate.y - y, wrap(estimate.yaw - yaw)])


yaws = st.floats(-np.pi, np.pi, exclude_min=True)
translations = st.floats(-100, 100)
point_sets = st.integers(2, 50).flatmap(lambda n: hnp.arrays(
    np.float64, (n, 2), elements=st.floats(-50, 50)))


def spread(points):
    return np.sqrt(((points - points.mean(axis=0)) ** 2).sum(axis=1).mean())


def assert_recovers(estimate, source, target, x, y, yaw):
    assert -np.pi < estimate.yaw <= np.pi
    assert abs(wrap(estimate.yaw - yaw)) < 1e-9
    assert estimate.x == pytest.approx(x, abs=1e-9)
    assert estimate.y == pytest.approx(y, abs=1e-9)
    assert estimate.rms_error < 1e-9
    assert estimate.inliers.dtype == bool and estimate.inliers.all()
    np.testing.assert_allclose(estimate.apply(source), target, atol=1e-9)


# ---------------------------------------------------------------- Kabsch, noise-free


@settings(max_examples=150, deadline=None)
@given(source=point_sets, x=translations, y=translations, yaw=yaws)
def test_kabsch_recovers_exact_transform(source, x, y, yaw):
    assume(spread(source) > 0.5)
    target = transform_points(source, x, y, yaw)
    assert_recovers(estimate_rigid_transform(source, target), source, target, x, y, yaw)


@settings(max_examples=50, deadline=None)
@given(source=point_sets, x=translations, y=translations, yaw=yaws)
def test_ransac_recovers_exact_transform_without_outliers(source, x, y, yaw):
    assume(spread(source) > 0.5)
    target = transform_points(source, x, y, yaw)
    assert_recovers(ransac_rigid_transform(source, target), source, target, x, y, yaw)


@pytest.mark.parametrize('yaw', [np.pi, -np.pi, np.nextafter(-np.pi, 0), 0.0, -0.0])
def test_yaw_is_in_half_open_interval(yaw):
    source = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]])
    estimate = estimate_rigid_transform(source, transform_points(source, 1, 2, yaw))
    assert -np.pi < estimate.yaw <= np.pi
    assert abs(wrap(estimate.yaw - yaw)) < 1e-12


def test_two_pairs_are_enough():
    source = np.array([[1.0, 1.0], [3.0, -2.0]])
    target = transform_points(source, -4.0, 0.5, 2.5)
    assert_recovers(estimate_rigid_transform(source, target), source, target, -4.0, 0.5, 2.5)


# ---------------------------------------------------------------- reflections


def total_cost(source, target, yaw):
    """Least-squares cost at `yaw` with its optimal translation (centroid alignment)."""
    t = target.mean(axis=0) - rotation(yaw) @ source.mean(axis=0)
    return ((transform_points(source, *t, yaw) - target) ** 2).sum()


@pytest.mark.parametrize('seed', range(5))
def test_mirrored_target_gives_best_proper_rotation(seed):
    rng = np.random.default_rng(seed)
    source = rng.uniform(-5, 5, (12, 2))
    mirrored = transform_points(source * [1.0, -1.0], *rng.uniform(-3, 3, 2), rng.uniform(-3, 3))
    estimate = estimate_rigid_transform(source, mirrored)
    linear = estimate.matrix()[:2, :2]
    assert np.linalg.det(linear) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(linear @ linear.T, np.eye(2), atol=1e-12)
    # no rotation on a fine grid (nor the grid point refined by the optimum) does better
    grid = np.linspace(-np.pi, np.pi, 20001)
    best_on_grid = min(total_cost(source, mirrored, yaw) for yaw in grid)
    cost = total_cost(source, mirrored, estimate.yaw)
    assert cost <= best_on_grid + 1e-9
    np.testing.assert_allclose(estimate.apply(source), transform_points(
        source, estimate.x, estimate.y, estimate.yaw), atol=1e-12)
    assert estimate.rms_error == pytest.approx(np.sqrt(cost / len(source)), rel=1e-9)


def test_collinear_points_mirrored_across_their_line_are_matched_exactly():
    source = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]])
    target = source * [1.0, -1.0]  # a reflection of collinear points is also a rotation (0)
    estimate = estimate_rigid_transform(source, target)
    assert np.linalg.det(estimate.matrix()[:2, :2]) == pytest.approx(1.0)
    assert estimate.rms_error < 1e-12


# ---------------------------------------------------------------- noise and covariance


SIGMA = 0.01
TRUE = (2.0, -1.0, 0.7)


def noisy_trials(trials=200, n=25, seed=7):
    rng = np.random.default_rng(seed)
    source = rng.uniform(-4, 4, (n, 2)) + [6.0, 3.0]  # off-origin: t and yaw correlate
    clean = transform_points(source, *TRUE)
    for _ in range(trials):
        yield source, clean + rng.normal(0, SIGMA, clean.shape)


def test_noisy_estimate_is_within_a_few_sigma_and_covariance_is_consistent():
    errors, covariances, rms = [], [], []
    for source, target in noisy_trials():
        estimate = estimate_rigid_transform(source, target)
        errors.append(error_vector(estimate, *TRUE))
        covariances.append(estimate.covariance)
        rms.append(estimate.rms_error)
    errors, covariances = np.array(errors), np.array(covariances)
    n = 25
    # per-trial: within 5 reported standard deviations, and the reported sigmas are small
    assert (np.abs(errors) < 5 * np.sqrt(np.einsum('kii->ki', covariances))).all()
    assert np.sqrt(covariances[:, 0, 0]).max() < 3 * SIGMA
    # chi-square of the error w.r.t. the reported covariance: mean 3 (x (2n-3)/(2n-5) for the
    # estimated sigma2, 1.04 here); std of the mean of 200 is ~0.17
    chi2 = np.einsum('ki,kij,kj->k', errors, np.linalg.inv(covariances), errors)
    assert 2.5 < chi2.mean() < 3.6
    assert chi2.max() < 30
    # the shape matches too: the empirical covariance whitened by the mean reported one is ~I
    root = np.linalg.cholesky(covariances.mean(axis=0))
    whitened = np.linalg.solve(root, np.linalg.solve(root, np.cov(errors.T)).T)
    np.testing.assert_allclose(whitened, np.eye(3), atol=0.3)
    # residual variance: E sum |r|^2 = (2n - 3) sigma^2
    assert np.mean(np.square(rms)) * n / (2 * n - 3) == pytest.approx(SIGMA ** 2, rel=0.05)


@pytest.mark.parametrize('n', [2, 3, 10])
def test_covariance_matches_formula_with_numerical_jacobian(n):
    rng = np.random.default_rng(n)
    source = rng.uniform(-3, 3, (n, 2)) + [4.0, -2.0]
    target = transform_points(source, *TRUE) + rng.normal(0, 0.05, (n, 2))
    weights = rng.uniform(0.5, 2.0, n)
    estimate = estimate_rigid_transform(source, target, weights)
    params = np.array([estimate.x, estimate.y, estimate.yaw])

    def residuals(p):
        return (transform_points(source, *p) - target).ravel()

    step = 1e-6
    jacobian = np.column_stack([(residuals(params + step * e) - residuals(params - step * e))
                                / (2 * step) for e in np.eye(3)])
    w = np.repeat(weights, 2)
    np.testing.assert_allclose(jacobian.T @ (w * residuals(params)), 0, atol=1e-9)  # optimum
    sigma2 = w @ residuals(params) ** 2 / max(2 * n - 3, 1)
    expected = sigma2 * np.linalg.inv(jacobian.T @ (w[:, None] * jacobian))
    np.testing.assert_allclose(estimate.covariance, expected, rtol=1e-6, atol=1e-15)


def test_covariance_is_symmetric_positive_definite_and_read_only():
    source, target = next(noisy_trials(1))
    estimate = estimate_rigid_transform(source, target)
    np.testing.assert_array_equal(estimate.covariance, estimate.covariance.T)
    assert np.linalg.eigvalsh(estimate.covariance).min() > 0
    with pytest.raises(ValueError):
        estimate.covariance[0, 0] = 1.0
    with pytest.raises(ValueError):
        estimate.inliers[0] = False
    with pytest.raises(dataclasses.FrozenInstanceError):
        estimate.x = 0.0


# ---------------------------------------------------------------- weights


def test_zero_weights_drop_pairs_and_scaled_weights_change_nothing():
    source, target = next(noisy_trials(1))
    target = target.copy()
    target[:5] += 3.0  # gross outliers, weighted out below
    weights = np.ones(len(source))
    weights[:5] = 0.0
    weighted = estimate_rigid_transform(source, target, weights)
    subset = estimate_rigid_transform(source[5:], target[5:])
    np.testing.assert_allclose([weighted.x, weighted.y, weighted.yaw],
                               [subset.x, subset.y, subset.yaw], atol=1e-12)
    np.testing.assert_allclose(weighted.covariance, subset.covariance, rtol=1e-9)
    assert weighted.rms_error == pytest.approx(subset.rms_error, rel=1e-12)
    np.testing.assert_array_equal(weighted.inliers, weights > 0)
    scaled = estimate_rigid_transform(source, target, 7.5 * weights)
    np.testing.assert_allclose(scaled.covariance, weighted.covariance, rtol=1e-9)
    assert scaled.yaw == pytest.approx(weighted.yaw, abs=1e-12)


def test_weights_pull_the_fit_toward_heavy_pairs():
    source = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    target = source.copy()
    target[3] += [0.2, 0.0]
    light = estimate_rigid_transform(source, target, [1, 1, 1, 0.1])
    heavy = estimate_rigid_transform(source, target, [1, 1, 1, 10])
    assert heavy.rms_error > light.rms_error  # weighted RMS grows with the misfit pair's weight
    assert np.abs(heavy.apply(source[3:]) - target[3:]).max() < \
        np.abs(light.apply(source[3:]) - target[3:]).max()


# ---------------------------------------------------------------- RANSAC


def outlier_problem(seed, n=50, outlier_fraction=0.4):
    """Inliers with sigma 0.01 noise; outliers displaced 1..20 m from their true image."""
    rng = np.random.default_rng(seed)
    x, y, yaw = rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-np.pi, np.pi)
    source = rng.uniform(-10, 10, (n, 2))
    target = transform_points(source, x, y, yaw) + rng.normal(0, SIGMA, (n, 2))
    outliers = rng.permutation(n)[:int(round(outlier_fraction * n))]
    angle = rng.uniform(0, 2 * np.pi, len(outliers))
    length = rng.uniform(1, 20, len(outliers))
    target[outliers] += np.stack([np.cos(angle), np.sin(angle)], -1) * length[:, None]
    inlier = np.ones(n, dtype=bool)
    inlier[outliers] = False
    return source, target, inlier, (x, y, yaw)


@pytest.mark.parametrize('seed', range(6))
def test_ransac_recovers_transform_and_inliers_despite_40_percent_outliers(seed):
    source, target, inlier, truth = outlier_problem(seed)
    robust = ransac_rigid_transform(source, target, inlier_threshold=0.1, seed=seed)
    np.testing.assert_array_equal(robust.inliers, inlier)
    error = error_vector(robust, *truth)
    assert np.hypot(*error[:2]) < 0.02 and abs(error[2]) < 0.005
    assert robust.rms_error < 3 * SIGMA
    # and it equals Kabsch on exactly the true inliers
    reference = estimate_rigid_transform(source[inlier], target[inlier])
    np.testing.assert_allclose([robust.x, robust.y, robust.yaw],
                               [reference.x, reference.y, reference.yaw], atol=1e-12)
    # plain Kabsch on the same pairs is visibly wrong: RANSAC is what makes this work
    plain = estimate_rigid_transform(source, target)
    plain_error = error_vector(plain, *truth)
    assert np.hypot(*plain_error[:2]) > 0.2 or abs(plain_error[2]) > 0.05
    assert plain.rms_error > 1.0


def test_ransac_is_deterministic_for_a_seed():
    source, target, _, _ = outlier_problem(3)
    first = ransac_rigid_transform(source, target, iterations=30, seed=11)
    second = ransac_rigid_transform(source, target, iterations=30, seed=11)
    assert (first.x, first.y, first.yaw) == (second.x, second.y, second.yaw)
    np.testing.assert_array_equal(first.inliers, second.inliers)


def test_ransac_stops_early_when_every_pair_is_an_inlier(monkeypatch):
    rng = np.random.default_rng(0)
    source = rng.uniform(-5, 5, (40, 2))
    target = transform_points(source, 1.0, 2.0, 0.3)
    draws = []
    real_default_rng = np.random.default_rng

    class CountingGenerator:
        def __init__(self, seed):
            self.generator = real_default_rng(seed)

        def integers(self, *args, **kwargs):
            draws.append(kwargs.get('size'))
            return self.generator.integers(*args, **kwargs)
    monkeypatch.setattr(np.random, 'default_rng', CountingGenerator)
    estimate = ransac_rigid_transform(source, target, iterations=10 ** 6)
    assert estimate.inliers.all() and abs(estimate.yaw - 0.3) < 1e-9
    # one chunk of hypotheses (two draws) explained every pair: the other 10^6 were not made
    assert len(draws) == 2 and sum(draws) < 2 * 10 ** 5


def test_inlier_threshold_is_a_distance():
    rng = np.random.default_rng(4)
    source = rng.uniform(-10, 10, (14, 2))
    target = transform_points(source, 3.0, -1.0, -2.0)
    offsets = {10: 0.06, 11: 0.2, 12: 0.25, 13: 0.3}  # residual length under the true transform
    for index, length in offsets.items():
        target[index] += length * np.array([0.6, -0.8])
    estimate = ransac_rigid_transform(source, target, inlier_threshold=0.1)
    np.testing.assert_array_equal(estimate.inliers, np.arange(14) <= 10)


def test_ransac_skips_degenerate_samples():
    # 3 of 4 source points coincide: most samples are degenerate, the rest still work
    source = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [2.0, 1.0]])
    target = transform_points(source, 0.5, -0.5, 1.0)
    estimate = ransac_rigid_transform(source, target, iterations=50)
    assert estimate.inliers.all() and abs(estimate.yaw - 1.0) < 1e-9


def test_ransac_raises_when_no_model_reaches_min_inliers():
    rng = np.random.default_rng(1)
    source, target = rng.uniform(-10, 10, (20, 2)), rng.uniform(-10, 10, (20, 2))
    with pytest.raises(InvalidInputError, match='min_inliers=10'):
        ransac_rigid_transform(source, target, min_inliers=10)
    source, target, _, _ = outlier_problem(0)
    with pytest.raises(InvalidInputError, match='min_inliers=31'):
        ransac_rigid_transform(source, target, min_inliers=31)  # only 30 inliers exist
    assert ransac_rigid_transform(source, target, min_inliers=30).inliers.sum() == 30


# ---------------------------------------------------------------- bad input

GOOD = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


@pytest.mark.parametrize('function', [estimate_rigid_transform, ransac_rigid_transform])
@pytest.mark.parametrize('source,target,pattern', [
    (GOOD[:, :1], GOOD, r'^source: expected shape'),
    (GOOD.ravel(), GOOD, r'^source: expected 2 dimensions'),
    (GOOD, GOOD[:2], r'^target: expected shape \(3, 2\)'),
    (GOOD, GOOD.T, r'^target: expected shape'),
    (np.where(np.eye(3, 2, dtype=bool), np.nan, GOOD), GOOD, r'^source\[0, 0\]: not finite'),
    (GOOD, np.where(np.eye(3, 2, k=-2, dtype=bool), np.inf, GOOD), r'^target\[2, 0\]'),
    ([['a', 'b'], ['c', 'd']], GOOD[:2], r'^source: not numeric'),
    (GOOD[:1], GOOD[:1], r'^source: need at least 2 pairs, got 1'),
    (np.zeros((0, 2)), np.zeros((0, 2)), r'^source: need at least 2 pairs, got 0'),
    (np.ones((4, 2)), GOOD.tolist() + [[1, 1]], r'^source'),  # all source points coincide
])
def test_bad_pairs_raise_naming_the_field(function, source, target, pattern):
    with pytest.raises(InvalidInputError, match=pattern):
        function(source, target)


@pytest.mark.parametrize('weights,pattern', [
    ([1, 1], r'^weights: expected shape \(3,?\)'),
    ([[1, 1, 1]], r'^weights: expected 1 dimensions'),
    ([1, -1, 1], r'^weights\[1\]: negative'),
    ([1, np.nan, 1], r'^weights\[1\]: not finite'),
    ([0, 0, 1], r'^weights: need at least 2 positive'),
])
def test_bad_weights_raise_naming_the_field(weights, pattern):
    with pytest.raises(InvalidInputError, match=pattern):
        estimate_rigid_transform(GOOD, GOOD, weights)


def test_positive_weights_only_on_coincident_points_raise():
    source = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(InvalidInputError, match=r'^source: .*coincide'):
        estimate_rigid_transform(source, source, [1, 1, 0])


@pytest.mark.parametrize('keyword,value', [
    ('inlier_threshold', 0.0), ('inlier_threshold', -0.1), ('inlier_threshold', np.nan),
    ('inlier_threshold', 'x'), ('iterations', 0), ('iterations', 2.5), ('iterations', True),
    ('min_inliers', 1), ('min_inliers', 3.0), ('seed', -1), ('seed', 1.5),
])
def test_bad_ransac_parameters_raise_naming_the_field(keyword, value):
    with pytest.raises(InvalidInputError, match=f'^{keyword}:'):
        ransac_rigid_transform(GOOD, GOOD, **{keyword: value})


def test_seed_none_is_accepted():
    assert ransac_rigid_transform(GOOD, GOOD, seed=None).inliers.all()


@pytest.mark.parametrize('points,pattern', [
    (np.zeros(2), r'^points: expected 2 dimensions'),
    (np.zeros((3, 3)), r'^points: expected shape'),
    ([[0.0, np.nan]], r'^points\[0, 1\]: not finite'),
])
def test_apply_rejects_bad_points(points, pattern):
    with pytest.raises(InvalidInputError, match=pattern):
        estimate_rigid_transform(GOOD, GOOD).apply(points)


# ---------------------------------------------------------------- apply / matrix


@settings(max_examples=50, deadline=None)
@given(x=translations, y=translations, yaw=yaws,
       points=hnp.arrays(np.float64, st.tuples(st.integers(0, 20), st.just(2)),
                         elements=st.floats(-1e3, 1e3)))
def test_apply_and_matrix_agree(x, y, yaw, points):
    transform = RigidTransform2D(x=x, y=y, yaw=yaw, covariance=np.eye(3),
                                 inliers=np.ones(0, bool), rms_error=0.0)
    matrix = transform.matrix()
    assert matrix.shape == (3, 3)
    np.testing.assert_array_equal(matrix[2], [0, 0, 1])
    assert np.linalg.det(matrix[:2, :2]) == pytest.approx(1.0)
    homogeneous = np.column_stack([points, np.ones(len(points))]) @ matrix.T
    applied = transform.apply(points)
    assert applied.shape == points.shape
    np.testing.assert_allclose(applied, homogeneous[:, :2], atol=1e-9)
    np.testing.assert_allclose(applied, transform_points(points, x, y, yaw), atol=1e-9)
