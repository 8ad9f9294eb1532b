"""Multi-hypothesis belief and retrospective re-evaluation (core) against brute force."""
import itertools

import numpy as np
import pytest

from data_association_ros.core.multi_hypothesis import (HypothesisTree, ParticleReevaluation,
                                                        compose, reevaluate_naive)
from data_association_ros.core.multi_hypothesis.scenario import (LANDMARKS, MEASUREMENT_NOISE,
                                                                 MOTION_NOISE, SENSING_RANGE,
                                                                 simulate)
from data_association_ros.core.models import MODELS

PRIOR = np.diag([0.5 ** 2, 0.5 ** 2, 1e-3 ** 2])


def tree_of(seed, steps, prune=0.0, fov=np.inf, landmarks=LANDMARKS):
    poses, increments, observations, truth = simulate(seed)
    tree = HypothesisTree(landmarks, poses[0], PRIOR, MOTION_NOISE, MEASUREMENT_NOISE,
                          fov_range=fov, prune_threshold=prune)
    for u, z in list(zip(increments, observations))[:steps]:
        tree.step(u, z)
    return tree, truth


def sequence_weight(tree, sequence):
    """Unnormalised weight of one association sequence, by its own EKF run (no tree)."""
    mean, cov, weight = tree.nodes[0].mean.copy(), tree.nodes[0].covariance.copy(), 1.0
    for step, landmark in enumerate(sequence, start=1):
        u, z = tree.inputs[step]
        c, s = np.cos(mean[2]), np.sin(mean[2])
        g = np.array([[1, 0, -s * u[0] - c * u[1]], [0, 1, c * u[0] - s * u[1]], [0, 0, 1]])
        v = np.eye(3)
        v[:2, :2] = [[c, -s], [s, c]]
        mean = compose(mean, u)
        cov = g @ cov @ g.T + v @ MOTION_NOISE @ v.T
        h, _, jac = MODELS['point_robot'].predict(tree.landmarks[[landmark]], mean)
        s_mat = jac[0] @ cov @ jac[0].T + MEASUREMENT_NOISE
        nu = z - h[0]
        weight *= np.exp(-0.5 * nu @ np.linalg.solve(s_mat, nu)) / (
            2 * np.pi * np.sqrt(np.linalg.det(s_mat))) / len(tree.landmarks)
        gain = cov @ jac[0].T @ np.linalg.inv(s_mat)
        mean = mean + gain @ nu
        cov = (np.eye(3) - gain @ jac[0]) @ cov
    return weight


@pytest.mark.parametrize('seed', range(3))
def test_tree_sum_equals_brute_force_marginalisation(seed):
    landmarks = LANDMARKS[:5]
    tree, _ = tree_of(seed, 4, landmarks=landmarks)
    assert len(tree.leaves) == 5 ** 4  # nothing pruned
    brute = {}
    for sequence in itertools.product(range(5), repeat=4):
        brute[sequence[:2]] = brute.get(sequence[:2], 0.0) + sequence_weight(tree, sequence)
    total = sum(brute.values())
    exact = tree.reevaluate_exact(2)
    for q, w in exact.items():
        path = (tree.nodes[tree.nodes[q].parent].decision, tree.nodes[q].decision)
        assert w == pytest.approx(brute[path] / total, rel=1e-9, abs=1e-15)
    assert sum(exact.values()) == pytest.approx(1.0)
    assert sum(tree.decision_probability(exact).values()) == pytest.approx(1.0)


def test_incremental_equals_naive_for_the_same_random_stream():
    tree, _ = tree_of(1, 6, prune=0.005, fov=3.0)
    incremental = ParticleReevaluation(tree, 1, samples=200, seed=7)
    for k in range(2, 7):
        incremental.advance_to(k)
        naive = reevaluate_naive(tree, 1, k, samples=200, seed=7)
        assert incremental.weights().keys() == naive.keys()
        np.testing.assert_allclose(list(incremental.weights().values()),
                                   list(naive.values()), rtol=1e-12)


def test_sampled_reevaluation_converges_to_the_tree_sum():
    """No pruning, every landmark in view: the particle filter estimates the same marginal as
    the tree (up to the EKF's linearisation).  Tolerance 0.03 at S = 4000 (seeded); the error
    at S = 4000 is below the error at S = 20."""
    tree, _ = tree_of(2, 3, landmarks=LANDMARKS[:4])
    exact = tree.reevaluate_exact(1)
    errors = {}
    for samples in (20, 4000):
        sampled = reevaluate_naive(tree, 1, 3, samples, seed=3)
        errors[samples] = max(abs(sampled[q] - exact[q]) for q in exact)
    assert errors[4000] < 0.03 and errors[4000] < errors[20], errors


def true_hypothesis_survives(tree, truth):
    """Whether a current leaf's decisions are exactly the true associations."""
    for leaf in tree.leaves:
        path, index = [], leaf
        while tree.nodes[index].parent is not None:
            path.append(tree.nodes[index].decision)
            index = tree.nodes[index].parent
        if tuple(reversed(path)) == tuple(truth):
            return True
    return False


def test_pruning_keeps_the_true_hypothesis_on_the_scenario():
    """Threshold 0.005 (the paper's), field of view = the sensing range (3 m).  Measured over
    seeds 0-19: the true hypothesis survives in 19; in seed 14 the noise makes the true
    sequence weigh less than 0.005 at one step (pruning is not exact by design).  The test
    allows no other seed to lose it."""
    lost = [seed for seed in range(20) if not true_hypothesis_survives(
        *tree_of(seed, 10, prune=0.005, fov=SENSING_RANGE))]
    assert lost == [14]


def test_enhanced_pruning_drops_the_descendants_of_light_past_hypotheses():
    tree, truth = tree_of(0, 6, prune=0.0, fov=2.5)
    weights = tree.reevaluate_exact(1)
    before = len(tree.leaves)
    dropped = tree.prune_descendants(weights, 0.05)
    light = [q for q, w in weights.items() if w < 0.05]
    assert dropped == before - len(tree.leaves) > 0
    assert all(tree.ancestor(leaf, 1) not in light for leaf in tree.leaves)
    assert sum(tree.nodes[i].weight for i in tree.leaves) == pytest.approx(1.0)


def test_merging_moment_matches_and_keeps_the_mixture_mean():
    from data_association_ros.core.multi_hypothesis.tree import Node, merge
    a = Node(1, 0, 2, 0.6, np.array([0.0, 0.0, 0.0]), np.eye(3))
    b = Node(1, 0, 3, 0.3, np.array([0.5, 0.0, 0.0]), np.eye(3))
    far = Node(1, 0, 4, 0.1, np.array([9.0, 0.0, 0.0]), np.eye(3))
    merged = merge([b, far, a], threshold=1.0)
    assert [n.decision for n in merged] == [2, 4]
    head = merged[0]
    assert head.weight == pytest.approx(0.9)
    np.testing.assert_allclose(head.mean, [0.5 * 0.3 / 0.9, 0, 0])
    # covariance: I + weighted spread of the means: 0.6*0.3/0.9^2 * 0.25 in x
    expected = np.eye(3)
    expected[0, 0] += 0.6 * 0.3 / 0.81 * 0.25
    np.testing.assert_allclose(head.covariance, expected)
