"""Bad input raises InvalidInputError naming the field (and index), never another exception."""
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from data_association_ros import (InvalidInputError, Landmarks, Observations, RobotPose,
                                  associate, available_algorithms)
from data_association_ros.core import jit
from data_association_ros.core.validation import check_covariance_matrix, check_spd

EYE3 = np.tile(np.eye(2), (3, 1, 1))


def good_landmarks():
    return Landmarks([1, 2, 3], [[0, 0], [1, 0], [0, 1]], EYE3)


def good_observations(model='point_map'):
    return Observations([[0, 0], [1, 0.1], [5, 5]], EYE3 * 0.1, model)


@pytest.mark.parametrize('build,field', [
    (lambda: Landmarks([1, 2, 3], [[0, 0], [np.nan, 0], [0, 1]], EYE3), r'landmarks\.means\[1, 0\]'),
    (lambda: Landmarks([1, 2, 3], [[0, 0], [1, 0], [0, np.inf]], EYE3), r'landmarks\.means\[2, 1\]'),
    (lambda: Landmarks([1, 2, 2], [[0, 0], [1, 0], [0, 1]], EYE3), r'landmarks\.ids\[2\]: duplicate'),
    (lambda: Landmarks([1, 2], [[0, 0], [1, 0], [0, 1]], EYE3), r'landmarks\.ids: expected shape'),
    (lambda: Landmarks([1, 2, -1], [[0, 0], [1, 0], [0, 1]], EYE3), r'landmarks\.ids\[2\]'),
    (lambda: Landmarks([1, 2, 3.5], [[0, 0], [1, 0], [0, 1]], EYE3), r'landmarks\.ids'),
    (lambda: Landmarks([1, 2, 3], [[0, 0], [1, 0], [0, 1]], EYE3[:2]),
     r'landmarks\.covariances: expected shape'),
    (lambda: Landmarks([1, 2, 3], [[0, 0], [1, 0], [0, 1]],
                       [np.eye(2), [[1, 0.5], [0, 1]], np.eye(2)]),
     r'landmarks\.covariances\[1\]: not symmetric'),
    (lambda: Landmarks([1, 2, 3], [[0, 0], [1, 0], [0, 1]],
                       [np.eye(2), np.eye(2), [[1, 2], [2, 1]]]),
     r'landmarks\.covariances\[2\]: not positive definite'),
    (lambda: Landmarks([1, 2, 3], [[0, 0], [1, 0], [0, 1]], [np.eye(2), np.zeros((2, 2)),
                                                             np.eye(2)]),
     r'landmarks\.covariances\[1\]: not positive definite'),
    (lambda: Landmarks([1, 2, 3], [['a', 0], [1, 0], [0, 1]], EYE3), r'landmarks\.means'),
    (lambda: Observations([[0, 0], [1, np.nan]], EYE3[:2]), r'observations\.values\[1, 1\]'),
    (lambda: Observations([[0, 0, 0, 0]], model='range_bearing'), r'observations\.values'),
    (lambda: Observations([[0, 0]], model='lidar'), r'observations\.model: unknown'),
    (lambda: Observations([[0, 0], [1, 1]], [np.eye(2), np.eye(3)]), r'observations\.covariances'),
    (lambda: Observations([[0, 0, -1, 1]], model='box'), r'observations\.values\[0\]'),
    (lambda: RobotPose([0, 0], np.eye(3)), r'pose\.mean'),
    (lambda: RobotPose([0, 0, 0], [[1, 0, 0], [0, 1, 0], [0, 0, -1]]), r'pose\.covariance'),
    (lambda: associate(good_landmarks(), good_observations(), 'magic'), r'algorithm: unknown'),
    (lambda: associate(good_landmarks(), good_observations(), 'jcbb', gate_probability=1.0),
     r'gate_probability'),
    (lambda: associate(good_landmarks(), good_observations(), 'jcbb', gate_probability=0.0),
     r'gate_probability'),
    (lambda: associate(good_landmarks(), good_observations(), 'euclidean_nn', euclidean_gate=-1),
     r'euclidean_gate'),
    (lambda: associate(good_landmarks(), good_observations(), 'gnn', euclidean_gate=1.0),
     r'euclidean_gate: not a parameter'),
    (lambda: associate(good_landmarks(), good_observations(), 'jcbb', time_budget_ms='fast'),
     r'time_budget_ms'),
    (lambda: associate(good_landmarks(), good_observations(), 'mahalanobis_nn', one_to_one=1),
     r'one_to_one'),
    (lambda: associate(good_landmarks(), good_observations('range_bearing'), 'jcbb'), r'pose'),
    (lambda: associate(good_landmarks(), good_observations(), 'jcbb',
                       state_covariance=np.eye(5)), r'state_covariance: expected shape'),
    (lambda: associate(good_landmarks(), good_observations(), 'jcbb',
                       state_covariance=-np.eye(9)), r'state_covariance'),
    (lambda: associate(Landmarks([1], [[0, 0, 0]], [np.eye(3)]), good_observations(), 'gnn'),
     r'landmarks\.means: model'),
    (lambda: associate(Landmarks([1], [[0, 0]]), good_observations(), 'mahalanobis_nn'),
     r'landmarks\.covariances: required'),
    (lambda: associate(good_landmarks(), Observations([[0, 0]]), 'jcbb'),
     r'observations\.covariances: required'),
    (lambda: associate(good_landmarks(), good_observations(), 'iou'), r'observations\.model'),
    (lambda: associate([[0, 0]], good_observations(), 'gnn'), r'landmarks: expected Landmarks'),
])
def test_bad_input_names_the_field(build, field):
    with pytest.raises(InvalidInputError, match=field):
        build()


def matrices(size):
    return hnp.arrays(np.float64, (size, 2, 2), elements=st.floats(allow_nan=True,
                                                                   allow_infinity=True,
                                                                   width=64))


@settings(max_examples=300, deadline=None)
@given(means=hnp.arrays(np.float64, (3, 2), elements=st.floats(allow_nan=True,
                                                               allow_infinity=True)),
       covariances=matrices(3), values=hnp.arrays(np.float64, (2, 2)),
       obs_cov=matrices(2), algorithm=st.sampled_from(available_algorithms()),
       model=st.sampled_from(['point_map', 'point_robot', 'range_bearing']))
def test_arbitrary_numbers_give_a_result_or_invalid_input(means, covariances, values, obs_cov,
                                                          algorithm, model):
    try:
        landmarks = Landmarks([1, 2, 3], means, covariances)
        observations = Observations(values, obs_cov, model)
        result = associate(landmarks, observations, algorithm,
                           pose=RobotPose([0, 0, 0], np.eye(3) * 0.01))
    except InvalidInputError:
        return
    assert result.assignment.shape == (2,)


def test_importing_the_package_imports_no_ros():
    code = ('import sys, data_association_ros; '
            'bad = [m for m in sys.modules if m.split(".")[0] in '
            '("rclpy", "sensor_msgs", "std_msgs", "msg_adapters")]; '
            'assert not bad, bad')
    subprocess.run([sys.executable, '-c', code], check=True)


GARBAGE = st.one_of(st.none(), st.text(max_size=3), st.integers(-5, 5), st.floats(),
                    st.booleans(), st.lists(st.floats(), max_size=4),
                    st.lists(st.lists(st.floats(), max_size=3), max_size=3),
                    hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=4, max_side=3)),
                    hnp.arrays(np.int64, hnp.array_shapes(max_dims=2, max_side=3)),
                    st.just(np.zeros((0, 2))), st.just({'x': 1}))


@settings(max_examples=1500, deadline=None)
@given(ids=st.one_of(GARBAGE, st.just([1, 2]), st.just([1, 1])),
       means=st.one_of(GARBAGE, st.just(np.zeros((2, 2))), st.just(np.ones((2, 4)))),
       landmark_cov=st.one_of(GARBAGE, st.just(np.tile(np.eye(2), (2, 1, 1)))),
       values=st.one_of(GARBAGE, st.just(np.ones((3, 2))), st.just(np.ones((3, 4)))),
       observation_cov=st.one_of(GARBAGE, st.just(np.tile(np.eye(2), (3, 1, 1)))),
       model=st.one_of(st.sampled_from(['point_map', 'point_robot', 'range_bearing', 'box']),
                       GARBAGE),
       algorithm=st.one_of(st.sampled_from(available_algorithms()), GARBAGE),
       pose=st.one_of(st.none(), GARBAGE, st.just(RobotPose([0, 0, 0], np.eye(3)))),
       gate=st.one_of(st.floats(), GARBAGE), extra=st.dictionaries(
           st.sampled_from(['time_budget_ms', 'max_nodes', 'one_to_one', 'euclidean_gate',
                            'iou_threshold', 'unknown_parameter']), GARBAGE, max_size=2))
def test_any_python_values_raise_only_invalid_input(ids, means, landmark_cov, values,
                                                    observation_cov, model, algorithm, pose,
                                                    gate, extra):
    """Whatever the caller passes, the library answers or raises InvalidInputError."""
    try:
        result = associate(Landmarks(ids, means, landmark_cov),
                           Observations(values, observation_cov, model), algorithm,
                           pose=pose, gate_probability=gate, **extra)
    except InvalidInputError:
        return
    assert len(result.assignment) == len(result.nis)


def test_a_singular_covariance_of_huge_entries_is_rejected_compiled_or_not():
    """[[1e308, 1e308], [1e308, 1e308]] is singular: its eigenvalue test must not overflow
    (a + c = inf made it pass before), in numpy's check and in the compiled one alike."""
    singular = np.full((1, 2, 2), 1e308)
    with pytest.raises(InvalidInputError, match='not positive definite'):
        check_spd(singular, 'covariances')
    for compiled in (True, False):
        with jit.compiled(compiled):
            with pytest.raises(InvalidInputError, match='not positive definite'):
                Observations(np.array([[1.0, 0.0]]), singular, 'range_bearing')
    check_spd(np.array([[[1e308, 0.0], [0.0, 1e308]]]), 'covariances')   # huge but definite


@pytest.mark.filterwarnings('error::RuntimeWarning')
def test_the_smallest_eigenvalue_of_a_huge_indefinite_matrix_is_reported_without_overflow():
    """[[-M, M], [M, -M]], M = 1.5e308: scaled to [[-1, 1], [1, -1]], smallest eigenvalue -2,
    which times the scale 1.5e308 is beyond the largest float: the message says -inf, with no
    RuntimeWarning (found by the fuzz test below in a fresh-clone run)."""
    huge = 1.5e308 * np.array([[[-1.0, 1.0], [1.0, -1.0]]])
    with pytest.raises(InvalidInputError, match=r'smallest eigenvalue -inf\)'):
        check_spd(huge, 'covariances')


@pytest.mark.filterwarnings('error::RuntimeWarning')
def test_a_stack_with_opposite_huge_entries_is_rejected_as_asymmetric_without_overflow():
    """check_spd on [[1e308, -1.7e308], [1.7e308, 1e308]]: M - M^T overflowed (a
    RuntimeWarning in a fresh-clone run of the fuzz test below); the test is made on M scaled
    by 1 + max |M|, the same test without the overflow."""
    with pytest.raises(InvalidInputError, match=r'covariances\[1\]: not symmetric'):
        check_spd(np.array([np.eye(2), [[1e308, -1.7e308], [1.7e308, 1e308]]]), 'covariances')
    check_spd(np.array([[[1e308, 1e307], [1e307, 1e308]]]), 'covariances')  # SPD: accepted


@pytest.mark.filterwarnings('error::RuntimeWarning')
def test_an_asymmetric_matrix_of_opposite_huge_entries_is_rejected_without_overflow():
    """1e308 against -1e308: their difference overflows to inf, which is asymmetry, reported
    as such (no RuntimeWarning), compiled or not."""
    for compiled in (True, False):
        with jit.compiled(compiled):
            with pytest.raises(InvalidInputError, match='not symmetric'):
                check_covariance_matrix(np.array([[1.0, 1e308], [-1e308, 1.0]]), 'P')
