"""jcbb_points (seed 003): one-to-one pruning, minimal association, search from it, transform."""
import numpy as np
import pytest
from scipy.stats import chi2

from data_association_ros import Landmarks, Observations, associate
from data_association_ros.core.associators.jcbb_points import (joint_nis_terms,
                                                               minimal_association)
from data_association_ros.core.problem import AssociationProblem
from problem_factory import joint_nis, one_to_one_subsets, pair_nis


def outline(width=4.0, height=2.0, spacing=0.25):
    """Points along a rectangle's boundary, centred at the origin."""
    xs = np.arange(-width / 2, width / 2 + 1e-9, spacing)
    ys = np.arange(-height / 2, height / 2 + 1e-9, spacing)
    return np.unique(np.round(np.vstack([
        np.column_stack([xs, np.full_like(xs, -height / 2)]),
        np.column_stack([xs, np.full_like(xs, height / 2)]),
        np.column_stack([np.full_like(ys, -width / 2), ys]),
        np.column_stack([np.full_like(ys, width / 2), ys])]), 9), axis=0)


def moved(points, x, y, yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return points @ np.array([[c, -s], [s, c]]).T + [x, y]


def object_covariance(boundary, centre, pose_sigma, point_sigma):
    """Joint covariance (3 + 2N) of [robot pose (unused), boundary points] when the points move
    together with the object's pose uncertainty (x, y, yaw sigmas) plus independent noise."""
    n = len(boundary)
    jacobian = np.zeros((2 * n, 3))
    jacobian[0::2, 0] = 1.0
    jacobian[1::2, 1] = 1.0
    jacobian[0::2, 2] = -(boundary[:, 1] - centre[1])
    jacobian[1::2, 2] = boundary[:, 0] - centre[0]
    p = np.zeros((3 + 2 * n, 3 + 2 * n))
    p[3:, 3:] = jacobian @ np.diag(np.square(pose_sigma)) @ jacobian.T + \
        np.eye(2 * n) * point_sigma ** 2
    return p


def test_recovers_the_motion_of_a_rigid_object():
    rng = np.random.default_rng(1)
    centre = np.array([10.0, 5.0])
    boundary = outline() + centre
    # the car moved by (0.06, -0.03, 0.02 rad) about its centre; the scan sees two sides
    scan = moved(boundary - centre, 0.06, -0.03, 0.02) + centre
    visible = np.flatnonzero((scan[:, 1] < 4.3) | (scan[:, 0] < 8.3))
    seen = scan[visible] + rng.normal(0, 0.01, (len(visible), 2))
    state = object_covariance(boundary, centre, (0.1, 0.1, 0.05), 0.02)
    landmarks = Landmarks(np.arange(len(boundary)), boundary,
                          np.array([state[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j]
                                    for j in range(len(boundary))]))
    observations = Observations(seen, np.tile(np.eye(2) * 0.01 ** 2, (len(seen), 1, 1)))
    result = associate(landmarks, observations, 'jcbb_points', state_covariance=state)
    # every scan point is paired with the boundary point it came from
    np.testing.assert_array_equal(result.assignment, visible)
    transform = result.extras['transform']
    # it maps scan points onto boundary points: the inverse of the motion
    np.testing.assert_allclose(transform.apply(seen), boundary[visible], atol=0.05)
    assert transform.yaw == pytest.approx(-0.02, abs=0.005)


def test_double_pairings_are_cleared_and_an_inconsistent_pair_is_dropped():
    # boundary points 0.5 m apart on a line; scan points 0 and 1 both nearest boundary point 2
    boundary = np.column_stack([np.arange(6) * 0.5, np.zeros(6)])
    landmarks = Landmarks(np.arange(6), boundary, np.tile(np.eye(2) * 0.04, (6, 1, 1)))
    scan = np.array([[0.95, 0.05], [1.05, -0.05], [2.0, 0.0], [2.5, 0.0]])
    observations = Observations(scan, np.tile(np.eye(2) * 0.01, (4, 1, 1)))
    result = associate(landmarks, observations, 'jcbb_points')
    assert result.extras['minimal_pairs'] == 2  # only scan points 2 and 3 kept at first
    assert result.assignment[2] == 4 and result.assignment[3] == 5
    # the search then adds back the cleared scan points one-to-one
    assert sorted(result.assignment[:2]) == [1, 2] or sorted(result.assignment[:2]) == [2, 3]
    assert len(set(result.assignment[result.assignment >= 0])) == (result.assignment >= 0).sum()


def test_leave_one_out_joint_nis_matches_direct_computation():
    rng = np.random.default_rng(3)
    boundary = rng.uniform(0, 5, (8, 2))
    landmarks = Landmarks(np.arange(8), boundary, np.tile(np.eye(2) * 0.02, (8, 1, 1)))
    observations = Observations(boundary[:6] + rng.normal(0, 0.1, (6, 2)),
                                np.tile(np.eye(2) * 0.01, (6, 1, 1)))
    problem = AssociationProblem(landmarks, observations)
    pairs = [(i, i) for i in range(6)]
    d2, without = joint_nis_terms(problem, pairs)
    assert d2 == pytest.approx(joint_nis(landmarks, observations, None, None, pairs))
    for k in range(6):
        rest = pairs[:k] + pairs[k + 1:]
        assert without[k] == pytest.approx(joint_nis(landmarks, observations, None, None, rest))


def test_minimal_association_drops_the_pair_that_breaks_the_joint_test():
    boundary = np.column_stack([np.arange(5.0), np.zeros(5)])
    landmarks = Landmarks(np.arange(5), boundary, np.tile(np.eye(2) * 0.01, (5, 1, 1)))
    scan = boundary.copy()
    scan[3] += [0.0, 0.8]  # NIS 32 alone: the set of five fails chi2(10) = 23.2
    observations = Observations(scan, np.tile(np.eye(2) * 0.01, (5, 1, 1)))
    problem = AssociationProblem(landmarks, observations)
    kept = minimal_association(problem, [(i, i) for i in range(5)], 0.99, 10)
    assert (3, 3) not in kept and len(kept) == 4


@pytest.mark.parametrize('seed', range(30))
def test_search_from_the_minimal_set_is_the_best_superset(seed):
    """Brute force over one-to-one supersets of the minimal association: most pairs, then the
    smallest joint NIS, among those passing the joint test."""
    rng = np.random.default_rng(200 + seed)
    boundary = rng.uniform(0, 3, (7, 2))
    scan = np.vstack([boundary[:5] + rng.normal(0, 0.08, (5, 2)), rng.uniform(0, 3, (1, 2))])
    landmarks = Landmarks(np.arange(7), boundary, np.tile(np.eye(2) * 0.01, (7, 1, 1)))
    observations = Observations(scan, np.tile(np.eye(2) * 0.01, (6, 1, 1)))
    result = associate(landmarks, observations, 'jcbb_points')
    gate = chi2.ppf(0.99, 2)
    compatible = np.array([[pair_nis(landmarks, observations, None, None, i, j)[0] <= gate
                            for j in range(7)] for i in range(6)])
    problem = AssociationProblem(landmarks, observations)
    nis = problem.nis
    nearest = [int(np.argmin(np.where(compatible[i], nis[i], np.inf))) if compatible[i].any()
               else -1 for i in range(6)]
    doubled = {j for j in nearest if j >= 0 and nearest.count(j) > 1}
    initial = [(i, j) for i, j in enumerate(nearest) if j >= 0 and j not in doubled]
    minimal = set(minimal_association(problem, initial, 0.99, 50))
    best, best_nis = None, np.inf
    for pairs in one_to_one_subsets(compatible):
        if not minimal <= set(pairs):
            continue
        d2 = joint_nis(landmarks, observations, None, None, pairs)
        if d2 > chi2.ppf(0.99, 2 * len(pairs)) if pairs else False:
            continue
        if best is None or len(pairs) > len(best) or (len(pairs) == len(best) and d2 < best_nis):
            best, best_nis = pairs, d2
    expected = np.full(6, -3)
    for i, j in best:
        expected[i] = j
    paired = result.assignment >= 0
    np.testing.assert_array_equal(np.where(paired, result.assignment, -3), expected)
