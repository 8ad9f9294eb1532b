"""The compiled problem arithmetic (core/problem_kernels.py) against the numpy code it replaces
(jit.compiled(False)) and against the per-pair references of problem_factory: predictions,
prediction covariances, NIS, pair terms, candidate lists and the covariance checks, on random
problems of every 2-D model, with and without a joint covariance, per-observation R and a
variance floor."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from msg_adapters import (array_to_cloud, cloud_points, correspondences_cloud,
                          observations_from_points, packing_kernels)
from std_msgs.msg import Header

from data_association_ros import Landmarks, Observations, RobotPose
from data_association_ros.core import jit, problem_kernels
from data_association_ros.core.associators import REGISTRY, jcbb_compiled, jcbb_kernels
from data_association_ros.core.associators.jcbb import individually_compatible
from data_association_ros.core.errors import InvalidInputError
from data_association_ros.core.initialisation import observations_in_map
from data_association_ros.core.models import wrap_angle
from data_association_ros.core.problem import AssociationProblem, nis_2d, nis_2d_of_sum
from data_association_ros.core.validation import check_covariance_matrix
from problem_factory import pair_nis, random_range_bearing_problem

needs_kernels = pytest.mark.skipif(jit.load_numba() is None,
                                   reason=f'numba not loaded: {jit.import_error()}')


@needs_kernels
def test_kernels_compile_and_pass_their_warm_up_checks():
    """With numba installed the kernels are in use: a warm-up check that fails (a wrong value
    from a kernel) would otherwise silently switch them off."""
    assert problem_kernels.KERNELS.available(), problem_kernels.KERNELS.unavailable_reason()
    assert jcbb_compiled.available(), jcbb_compiled.unavailable_reason()


def random_problem(seed: int, model: str, joint: bool, shared_r: bool, floor: float):
    """A problem of `model` (2-D observations) from problem_factory's range-bearing scene;
    point models observe the landmarks directly (in the map or robot frame)."""
    rng = np.random.default_rng(seed)
    landmarks, observations, pose, state, _ = random_range_bearing_problem(
        rng, int(rng.integers(1, 20)), int(rng.integers(0, 12)), int(rng.integers(0, 4)),
        int(rng.integers(0, 4)), joint)
    values = observations.values
    if model != 'range_bearing':
        values = np.column_stack([values[:, 0] * np.cos(values[:, 1]),
                                  values[:, 0] * np.sin(values[:, 1])])
    r = observations.covariances.copy()
    if not shared_r:
        r *= rng.uniform(0.2, 5.0, (len(r), 1, 1))
    return AssociationProblem(landmarks, Observations(values, r, model), pose, state, floor)


def both(make, quantity):
    """(numpy, compiled) values of quantity(problem) on two fresh problems."""
    with jit.compiled(False):
        reference = quantity(make())
    with jit.compiled(True):
        compiled = quantity(make())
    return reference, compiled


@needs_kernels
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1),
       model=st.sampled_from(['range_bearing', 'point_map', 'point_robot']),
       joint=st.booleans(), shared_r=st.booleans(),
       floor=st.sampled_from([0.0, 1e-4, 0.05, 10.0]))
def test_compiled_problem_arithmetic_equals_numpy(seed, model, joint, shared_r, floor):
    def make():
        return random_problem(seed, model, joint, shared_r, floor)
    for name in ('predictions', 'prediction_covariances'):
        reference, compiled = both(make, lambda p: getattr(p, name))
        np.testing.assert_allclose(compiled, reference, rtol=1e-12, atol=1e-15, err_msg=name)
    reference, compiled = both(make, lambda p: p.nis)
    np.testing.assert_array_equal(np.isinf(compiled), np.isinf(reference))
    finite = np.isfinite(reference)
    np.testing.assert_allclose(compiled[finite], reference[finite], rtol=1e-10, atol=1e-12)
    # the pair terms: innovations and S at chosen pairs, as the full arrays have them
    problem = make()
    k, n = problem.sizes
    rng = np.random.default_rng(seed)
    rows, columns = rng.integers(0, max(k, 1), 25), rng.integers(0, max(n, 1), 25)
    if k and n:
        with jit.compiled(False):
            nu, s = problem.innovations[rows, columns], problem.innovation_covariances[rows,
                                                                                      columns]
        pair_nu, pair_s = problem.pair_terms(rows, columns)
        np.testing.assert_allclose(pair_nu, nu, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(pair_s, s, rtol=1e-12, atol=1e-15)
    # candidate lists: the same gate, the same columns in the same order
    reference, compiled = both(make, lambda p: individually_compatible(p, 0.99))
    np.testing.assert_array_equal(compiled[0], reference[0])
    assert compiled[2] == reference[2]
    assert [c.tolist() for c in compiled[1]] == [c.tolist() for c in reference[1]]


@needs_kernels
@pytest.mark.parametrize('joint', [False, True])
def test_compiled_nis_equals_the_per_pair_reference(joint):
    """The compiled NIS against problem_factory's pair_nis (full Jacobian, joint covariance,
    one pair at a time)."""
    for seed in range(20):
        landmarks, observations, pose, state, _ = random_range_bearing_problem(
            np.random.default_rng(seed), 8, 6, 2, 2, joint)
        with jit.compiled(True):
            nis = AssociationProblem(landmarks, observations, pose, state).nis
        with jit.compiled(False):   # the reference's predictions from the numpy model
            for i in range(len(observations)):
                for j in range(len(landmarks)):
                    assert nis[i, j] == pytest.approx(
                        pair_nis(landmarks, observations, pose, state, i, j)[0], rel=1e-8)


@needs_kernels
def test_nis_ties_keep_numpy_candidate_order():
    """Equal NIS: candidates ordered by column, as numpy's stable argsort orders them."""
    landmarks = Landmarks([5, 6, 7, 8], [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]],
                          np.tile(np.eye(2) * 0.1, (4, 1, 1)))
    observations = Observations([[0.0, 0.0], [1.0, 0.0]], np.tile(np.eye(2), (2, 1, 1)))
    for enabled in (False, True):
        with jit.compiled(enabled):
            _, candidates, order = individually_compatible(
                AssociationProblem(landmarks, observations), 0.999)
        assert [c.tolist() for c in candidates] == [[0, 1, 2, 3], [0, 1, 3, 2]]
        assert order == [0, 1]


@needs_kernels
def test_indefinite_joint_covariance_rejected_by_both_paths():
    """A [pose, landmark] block with a negative eigenvalue: the same error either way; a
    definite one passes."""
    landmarks, observations, pose, state, _ = random_range_bearing_problem(
        np.random.default_rng(3), 6, 4, 1, 0, True)
    bad = state.copy()
    bad[3 + 2 * 4, 3 + 2 * 4 + 1] = bad[3 + 2 * 4 + 1, 3 + 2 * 4] = 5.0   # |cov| > variances
    for enabled in (False, True):
        with jit.compiled(enabled):
            AssociationProblem(landmarks, observations, pose, state).check_definite()
            with pytest.raises(InvalidInputError, match='not positive semi-definite'):
                AssociationProblem(landmarks, observations, pose, bad).check_definite()


@needs_kernels
@pytest.mark.parametrize('defect, message', [
    (lambda m: m.__setitem__((0, 1), m[0, 1] + 1.0), 'not symmetric'),
    (lambda m: m.__setitem__((2, 2), -1.0), r'\[2, 2\]: negative variance'),
    (lambda m: m.__setitem__((1, 1), np.nan), r'\[1, 1\]: not finite'),
    (lambda m: None, None)])
def test_covariance_matrix_check_same_either_way(defect, message):
    matrix = np.eye(5) + 0.1
    defect(matrix)
    for enabled in (False, True):
        with jit.compiled(enabled):
            if message is None:
                checked = check_covariance_matrix(matrix, 'state_covariance')
                np.testing.assert_array_equal(checked, matrix)
                assert not checked.flags.writeable
            else:
                with pytest.raises(InvalidInputError, match=message):
                    check_covariance_matrix(matrix, 'state_covariance')


@needs_kernels
def test_no_scan_compiles_a_kernel_version():
    """Inputs reach the kernels as read-only C views (the core's types store their arrays
    read-only), so after the warm-up no scan compiles a new version of a kernel (a fresh
    compile of range_bearing_nis also compiles the kernels it calls for its own arrays)."""
    assert problem_kernels.KERNELS.available() and jcbb_compiled.available() and \
        packing_kernels.available()
    kernels = [getattr(problem_kernels, name) for name in (
        'range_bearing_predict', 'prediction_covariances', 'nis_2d', 'range_bearing_nis',
        'range_bearing_in_map', 'pair_terms', 'is_covariance_matrix', 'are_spd_2x2',
        'first_indefinite_block', 'observations_2d', 'nearest_within', 'gnn_split',
        'label_columns')] + [jcbb_kernels.gated_candidates, jcbb_kernels.search_layout,
                             packing_kernels.correspondence_words]
    versions = [len(kernel.signatures) for kernel in kernels]
    for seed in range(6):
        for model in ('range_bearing', 'point_map'):
            for joint in (False, True):
                problem = random_problem(seed, model, joint, seed % 2 == 0, 0.0)
                problem.check_definite()
                _, candidates, order = individually_compatible(problem, 0.99)
                jcbb_compiled.CompiledSearch(problem, 0.99, candidates, order, None, 0).run()
                problem.pair_terms(np.zeros(1, dtype=np.int32), np.zeros(1, dtype=np.int64)) \
                    if min(problem.sizes) else None
                positions, _ = observations_in_map(problem.observations, problem.pose, joint)
                for name, extra in (('mahalanobis_nn', {'one_to_one': False}), ('gnn', {})):
                    association = REGISTRY[name].run(problem, gate_probability=0.99,
                                                     min_innovation_variance=0.0, **extra)
                    correspondences_cloud(Header(), association, positions)
                fields = ('range', 'bearing', 'var_bearing') if model == 'range_bearing' \
                    else ('x', 'y', 'cov_yy')
                scan = np.zeros(len(problem.observations), dtype=[(f, '<f4') for f in fields])
                observations_from_points(cloud_points(array_to_cloud(scan)), model, [0.1])
        Observations(problem.observations.values, problem.observations.covariances.copy(),
                     problem.observations.model)
    assert [len(kernel.signatures) for kernel in kernels] == versions


def test_numpy_path_answers_inside_compiled_false():
    """compiled(False) turns the kernels off (the numpy code is what the tests compare with)."""
    with jit.compiled(False):
        assert jit.problem_kernels() is None
        problem = AssociationProblem(
            Landmarks([1], [[3.0, 4.0]], [np.eye(2)]),
            Observations([[5.0, 0.0]], [np.eye(2) * 0.01], 'range_bearing'),
            RobotPose([0.0, 0.0, np.arctan2(4.0, 3.0)]))
        assert problem.nis[0, 0] == pytest.approx(0.0, abs=1e-12)


@needs_kernels
@pytest.mark.parametrize('defect, message', [
    (lambda c: c.__setitem__((1, 0, 1), 0.5), r'observations.covariances\[1\]: not symmetric'),
    (lambda c: c.__setitem__((2, slice(None), slice(None)), [[1.0, 2.0], [2.0, 1.0]]),
     r'observations.covariances\[2\]: not positive definite'),
    (lambda c: c.__setitem__((0, 1, 1), np.inf),
     r'observations.covariances\[0, 1, 1\]: not finite'),
    (lambda c: None, None)])
def test_covariance_stack_check_same_either_way(defect, message):
    covariances = np.tile([[2.0, 0.3], [0.3, 1.0]], (3, 1, 1))
    defect(covariances)
    for enabled in (False, True):
        with jit.compiled(enabled):
            if message is None:
                observations = Observations(np.zeros((3, 2)), covariances)
                np.testing.assert_array_equal(observations.covariances, covariances)
            else:
                with pytest.raises(InvalidInputError, match=message):
                    Observations(np.zeros((3, 2)), covariances)


finite_or_not = st.one_of(st.floats(-1e3, 1e3), st.floats(allow_nan=True, allow_infinity=True),
                          st.sampled_from([0.0, 1e-300, 1e300, -1e300, np.pi, -np.pi]))


@needs_kernels
@settings(max_examples=300, deadline=None)
@given(data=st.data(), k=st.integers(1, 4), n=st.integers(1, 4), shared=st.booleans(),
       floor=st.sampled_from([0.0, 1e-9, 1.0]), angular=st.sampled_from([(), (1,)]))
def test_nis_kernel_equals_numpy_on_adversarial_numbers(data, k, n, shared, floor, angular):
    """NaN, inf and overflowing S or innovations (reachable through absurd magnitudes): the
    kernel's NIS is numpy's, inf where numpy's is (a NaN in S must not become the floor)."""
    def array(*shape):
        return np.array(data.draw(st.lists(finite_or_not, min_size=int(np.prod(shape)),
                                           max_size=int(np.prod(shape))))).reshape(shape)
    values, predictions, prediction_covs, r = array(k, 2), array(n, 2), array(n, 2, 2), \
        array(k, 2, 2)
    if shared:
        r[:] = r[0]
    with np.errstate(all="ignore"):
        nu = np.stack([values[:, None, c] - predictions[None, :, c] for c in range(2)])
    with np.errstate(all='ignore'):
        for c in angular:
            nu[c] = wrap_angle(nu[c])
        if shared:
            s = prediction_covs + r[0]
            if floor > 0:
                s[:, 0, 0], s[:, 1, 1] = np.maximum(s[:, 0, 0], floor), np.maximum(s[:, 1, 1],
                                                                                     floor)
            expected = nis_2d(nu[0], nu[1], s[:, 0, 0], s[:, 0, 1], s[:, 1, 1])
        else:
            expected = nis_2d_of_sum(nu[0], nu[1], prediction_covs, r,
                                     floor if floor > 0 else -np.inf)
        got = problem_kernels.run_nis_2d(values, predictions, angular, prediction_covs, r,
                                         shared, floor)
    np.testing.assert_array_equal(np.isinf(got), np.isinf(expected))
    both = np.isfinite(expected)
    np.testing.assert_allclose(got[both], expected[both], rtol=1e-12, atol=0)


def test_importing_the_library_does_not_import_numba():
    """numba (about 0.5 s to import) is loaded at the first NIS or check, not by the import."""
    code = ('import sys, data_association_ros; from data_association_ros.core.api import '
            'associate; from data_association_ros.core.associators import REGISTRY; '
            'print("numba" in sys.modules)')
    output = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parents[1], timeout=120)
    assert output.returncode == 0, output.stderr
    assert output.stdout.strip() == 'False'
