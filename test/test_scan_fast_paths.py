"""The per-scan fast paths of association_node (issue 18) against the code they stand in for:
mahalanobis_nn's nearest-within answer, gnn's split and labels, observations read from float32
words, the packed correspondences, the fused range-bearing kernel, observations in the map
frame without the pose term, time matching, the NaN test of array_to_cloud, parameters resolved
once, the outcome counts, and the candidate state when confirmed landmarks are not wanted.  Each test is fast (< 1 s)."""
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2
from std_msgs.msg import Header

from msg_adapters import (array_to_cloud, cloud_points, cloud_to_array, correspondences_cloud,
                          observations_from_points)
from msg_adapters import inputs as inputs_module
from msg_adapters.pointcloud import fields_of

from data_association_ros import Observations, RobotPose
from data_association_ros.bag.offline import node_config
from data_association_ros.core import NEW, UNASSOCIATED, Association, InvalidInputError, jit
from data_association_ros.core.api import _resolve
from data_association_ros.core.associators import REGISTRY
from data_association_ros.core.associators.base import nearest_neighbours, nearest_within, result
from data_association_ros.core.initialisation import observations_in_map
from data_association_ros.core.parameters import resolve
from data_association_ros.core.problem import AssociationProblem
from data_association_ros.pipelines.association import AssociationPipeline
from data_association_ros.pipelines.stamped_buffer import StampedBuffer
from data_association_ros.pipelines.statistics import AssociationStatistics
from problem_factory import random_range_bearing_problem

NIS_VALUES = st.one_of(st.floats(0.0, 20.0), st.just(np.inf), st.sampled_from([1.0, 9.21]))


def range_bearing_problem(seed: int, joint: bool) -> AssociationProblem:
    """A random range-bearing problem (problem_factory), per-observation R on odd seeds."""
    rng = np.random.default_rng(seed)
    landmarks, observations, pose, state, _ = random_range_bearing_problem(
        rng, int(rng.integers(1, 25)), int(rng.integers(1, 12)), int(rng.integers(0, 4)),
        int(rng.integers(0, 4)), joint=joint)
    if seed % 2:
        observations = Observations(observations.values, observations.covariances * rng.uniform(
            0.2, 5.0, (len(observations), 1, 1)), observations.model)
    return AssociationProblem(landmarks, observations, pose, state, [0.0, 1e-9, 0.3][seed % 3])


def problem_with_nis(nis: np.ndarray):
    """range_bearing_problem(0) with its NIS matrix (k, n) replaced and its first n landmarks,
    or None when it has fewer than n."""
    n = nis.shape[1]
    problem = range_bearing_problem(0, False)
    problem.__dict__['nis'] = nis
    problem.landmarks = problem.landmarks.subset(np.arange(min(n, len(problem.landmarks))))
    return problem if len(problem.landmarks) == n else None


@pytest.mark.parametrize('compiled', [True, False])
@settings(max_examples=60, deadline=None)
@given(k=st.integers(0, 6), n=st.integers(0, 6), data=st.data())
def test_nearest_within_is_nearest_neighbours_inside_the_gate(compiled, k, n, data):
    """Ties, inf and values on the bound included; K = 0 and N = 0 too; the kernel and the
    numpy form."""
    nis = np.array(data.draw(st.lists(NIS_VALUES, min_size=k * n, max_size=k * n))).reshape(k, n)
    problem = problem_with_nis(nis)
    if problem is None:
        return
    gated = nis <= 9.21
    expected = result(problem, 'x', nearest_neighbours(nis, gated, False), gated)
    with jit.compiled(compiled):
        got = nearest_within(problem, 'x', 9.21)
    np.testing.assert_array_equal(got.assignment, expected.assignment)
    np.testing.assert_array_equal(got.nis, expected.nis)
    assert got.assignment.dtype == np.int64 and not (got.assignment == UNASSOCIATED).any()


@pytest.mark.skipif(jit.problem_kernels() is None, reason='numba kernels not in use')
@pytest.mark.parametrize('seed', range(12))
def test_fused_range_bearing_kernel_is_the_three_kernels(seed):
    """One dispatch instead of three, bit for bit (marginal and joint covariances, shared and
    per-observation R, with and without a variance floor)."""
    fused, separate = range_bearing_problem(seed, seed % 4 > 1), \
        range_bearing_problem(seed, seed % 4 > 1)
    separate.predictions   # computed first: nis then takes the three kernels one by one
    np.testing.assert_array_equal(fused.nis, separate.nis)
    np.testing.assert_array_equal(fused.prediction_covariances, separate.prediction_covariances)
    for a, b in zip(fused._prediction, separate._prediction):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize('seed', range(6))
def test_observations_in_map_kernel_and_without_the_pose_term(seed):
    """range_bearing_in_map against the numpy form (rounding of the 2 x 2 products only), and
    pose_uncertainty False against the zero pose covariance it replaces (exactly)."""
    problem = range_bearing_problem(seed, False)
    observations, pose = problem.observations, problem.pose
    for uncertain in (True, False):
        positions, covariances = observations_in_map(observations, pose, uncertain)
        with jit.compiled(False):
            numpy_positions, numpy_covariances = observations_in_map(observations, pose, uncertain)
        np.testing.assert_array_equal(positions, numpy_positions)
        np.testing.assert_allclose(covariances, numpy_covariances, rtol=1e-12, atol=1e-15)
    with jit.compiled(False):
        _, without = observations_in_map(observations, pose, False)
        _, zero_pose = observations_in_map(observations, RobotPose(pose.mean), True)
    np.testing.assert_array_equal(without, zero_pose)
    empty = Observations(np.zeros((0, 2)), np.zeros((0, 2, 2)), 'range_bearing')
    assert [a.shape for a in observations_in_map(empty, pose, False)] == [(0, 2), (0, 2, 2)]


@settings(max_examples=80, deadline=None)
@given(stamps=st.lists(st.integers(0, 50), min_size=1, max_size=8, unique=True),
       query=st.integers(-10, 60), tolerance=st.integers(0, 30))
def test_nearest_stamp_is_the_first_smallest_difference(stamps, query, tolerance):
    buffer = StampedBuffer(20)
    for stamp in stamps:
        buffer.add(stamp, stamp)
    ordered = sorted(stamps)
    best = min(ordered, key=lambda s: abs(s - query))   # the older one on a tie
    expected = best if abs(best - query) <= tolerance else None
    assert buffer.nearest(query, tolerance)[0] == expected


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(0, 5), data=st.data())
def test_is_dense_and_points_of_any_float_layout(rows, data):
    """is_dense (one reduction per run of adjacent float fields) against a per-field NaN test;
    cloud_points reads what cloud_to_array copies."""
    layout = data.draw(st.lists(st.sampled_from(['<f4', '<f8', '<i4', '<u1']), min_size=1,
                                max_size=5))
    values = st.floats(allow_nan=True, allow_infinity=True, width=32)
    points = np.zeros(rows, dtype=[(f'f{i}', kind) for i, kind in enumerate(layout)])
    for i, kind in enumerate(layout):
        if kind[1] == 'f':
            points[f'f{i}'] = data.draw(st.lists(values, min_size=rows, max_size=rows))
    msg = array_to_cloud(points)
    assert msg.is_dense == (not any(np.isnan(points[name]).any() for name in points.dtype.names
                                    if points.dtype[name].kind == 'f'))
    view, copy = cloud_points(msg), cloud_to_array(msg)
    assert not view.flags.writeable and fields_of(msg) == points.dtype.names
    for name in points.dtype.names:
        np.testing.assert_array_equal(view[name], copy[name])


def test_observations_keep_their_checks():
    """Read into preallocated arrays: NaN is rejected naming the index, an empty cloud needs
    no fields, missing covariance fields fall back to the (cached, read-only) noise."""
    points = np.zeros(3, dtype=[('range', '<f4'), ('bearing', '<f4')])
    points['range'] = [1.0, np.nan, 2.0]
    with pytest.raises(Exception, match=r'observations.values\[1, 0\]: not finite'):
        observations_from_points(points, 'range_bearing', [0.01])
    assert len(observations_from_points(np.zeros(0, dtype=[('a', '<f4')]), 'range_bearing',
                                        [0.01])) == 0
    points['range'][1] = 3.0
    observations = observations_from_points(points, 'range_bearing', [0.01, 1e-4])
    np.testing.assert_array_equal(observations.covariances, np.tile(np.diag([0.01, 1e-4]),
                                                                    (3, 1, 1)))
    assert not (observations.values.flags.writeable or observations.covariances.flags.writeable)


@pytest.mark.parametrize('values', [{'gate_probability': 0.9}, {'one_to_one': True},
                                    {'one_to_one': 1}, {'one_to_one': [1]}, {'nope': 1.0},
                                    {'gate_probability': float('nan')}, {}])
def test_parameters_resolved_once_answer_as_resolve(values):
    """associate's cached resolve: the same values or error as resolve, True apart from 1, and a
    dict of the caller's own."""
    specs = REGISTRY['mahalanobis_nn'].parameters
    try:
        expected = resolve(specs, dict(values), 'mahalanobis_nn')
    except InvalidInputError as error:
        with pytest.raises(InvalidInputError, match=re.escape(str(error))):
            _resolve('mahalanobis_nn', dict(values))
        return
    for _ in range(2):
        got = _resolve('mahalanobis_nn', dict(values))
        assert got == expected and all(type(got[k]) is type(expected[k]) for k in got)
        got.clear()


def test_outcome_counts():
    statistics = AssociationStatistics()
    statistics.record_answer(np.array([3, NEW, UNASSOCIATED, 0, NEW], dtype=np.int64), 1.0, False)
    assert dict(statistics.outcomes) == {'paired': 2, 'new': 2, 'unassociated': 1}


def test_confirmed_landmarks_not_wanted_move_the_state_alike():
    """confirm_hits 1: without new_landmarks subscribers the confirmed landmarks are only
    counted; ids, totals and diagnostics stay those of a pipeline that builds them."""
    config = node_config('mahalanobis_nn', {'confirm_hits': 1})
    built, counted = AssociationPipeline(config), AssociationPipeline(config)
    for k, points in enumerate([[[5.0, 5.0], [0.1, 0.0]], [[6.0, 6.0], [0.0, 0.1], [9.0, 1.0]]]):
        header = Header(frame_id='map')
        header.stamp.sec = 1 + k
        landmarks = array_to_cloud({'id': np.array([7]), 'x': np.array([0.0]),
                                    'y': np.array([0.0])}, header)
        scan = array_to_cloud({'x': np.array(points)[:, 0], 'y': np.array(points)[:, 1]}, header)
        for pipeline in (built, counted):
            pipeline.on_landmarks(landmarks)
        full, bare = built.answer(scan), counted.answer(scan, wanted=set())
        assert bare.new_landmarks is None and len(cloud_to_array(full.new_landmarks)) == k + 1
    for name in ('scan', '_next_id', 'confirmed_total', 'expired_total'):
        assert getattr(built.candidates, name) == getattr(counted.candidates, name), name
    assert {k: v for k, v in built.statistics.key_values().items() if 'latency' not in k} == \
        {k: v for k, v in counted.statistics.key_values().items() if 'latency' not in k}


def full_matrix_gnn(nis: np.ndarray, gate: float) -> np.ndarray:
    """gnn's columns as first built: the Hungarian method on the whole K x (N + K) matrix."""
    k, n = nis.shape
    columns = np.full(k, -1, dtype=np.intp)
    gated = nis <= gate
    if k and n and gated.any():
        cost = np.full((k, n + k), np.inf)
        np.copyto(cost[:, :n], nis, where=gated)
        cost[:, n:].flat[::k + 1] = gate
        rows, cols = linear_sum_assignment(cost)
        columns[rows[cols < n]] = cols[cols < n]
    return columns


@pytest.mark.parametrize('compiled', [True, False])
@settings(max_examples=300, deadline=None)
@given(k=st.integers(0, 9), n=st.integers(0, 9), ties=st.booleans(), data=st.data())
def test_gnn_solves_only_competing_pairs_as_the_whole_matrix(compiled, k, n, ties, data):
    """Pairs alone in their row and column are decided without the Hungarian method: the same
    pairs as the whole matrix, or, where whole numbers and values on the gate make equal-cost
    optima, one of them (scipy's choice among tied optima depends on the matrix it is given);
    the kernels' split and labels and the numpy form give the same pairs, ties included."""
    gate = chi2.ppf(0.99, 2)
    values = st.sampled_from([0.0, 1.0, 2.0, 3.0, 4.5, 6.0, gate, 10.0, np.inf]) if ties \
        else st.floats(0.0, 30.0)
    nis = np.array(data.draw(st.lists(values, min_size=k * n, max_size=k * n)),
                   dtype=float).reshape(k, n)
    problem = problem_with_nis(nis)
    if problem is None:
        return
    gated = nis <= gate
    expected = result(problem, 'gnn', full_matrix_gnn(nis, gate), gated)
    with jit.compiled(compiled):
        got = REGISTRY['gnn'].run(problem, gate_probability=0.99, min_innovation_variance=0.0)
    with jit.compiled(not compiled):
        other = REGISTRY['gnn'].run(problem, gate_probability=0.99, min_innovation_variance=0.0)
    np.testing.assert_array_equal(got.assignment, other.assignment)   # ties included
    assert got.assignment.dtype == np.int64
    if np.array_equal(got.assignment, expected.assignment):
        np.testing.assert_array_equal(got.nis, expected.nis)
    else:   # another optimum of a tie (hypothesis: 2 x 8, rows [10, 1 x 6, 0]: 1 -> 4 or 1)
        assert pairing_cost(got.assignment, problem, nis, gate) == pytest.approx(
            pairing_cost(expected.assignment, problem, nis, gate))
        paired = got.assignment >= 0
        assert len(set(got.assignment[paired])) == paired.sum()   # one-to-one


def test_gnn_on_a_tie_picks_an_optimum_the_same_in_both_forms():
    """Hypothesis's tie (fresh-clone run, 2026-12-06): two observations, NIS rows [10, 1 x 6,
    0]: every optimum pairs one with the last landmark (0) and the other with one of landmarks
    1-6 (1), total 1; the whole matrix gives the second observation landmark 1, the reduced one
    landmark 4.  Both forms of the reduced one give the same pairs."""
    gate = chi2.ppf(0.99, 2)
    nis = np.array([[10.0, 1, 1, 1, 1, 1, 1, 0], [10.0, 1, 1, 1, 1, 1, 1, 0]])
    problem = problem_with_nis(nis)
    answers = []
    for compiled in (True, False):
        with jit.compiled(compiled):
            answers.append(REGISTRY['gnn'].run(problem, gate_probability=0.99,
                                               min_innovation_variance=0.0).assignment)
    np.testing.assert_array_equal(answers[0], answers[1])
    assert pairing_cost(answers[0], problem, nis, gate) == pytest.approx(1.0)
    assert len(set(answers[0])) == 2 and set(answers[0]) <= set(problem.landmarks.ids[1:])


def pairing_cost(assignment: np.ndarray, problem, nis: np.ndarray, gate: float) -> float:
    """gnn's objective: the NIS of each pair + the gate for each observation left unpaired."""
    column = {int(i): c for c, i in enumerate(problem.landmarks.ids)}
    return float(sum(nis[r, column[int(a)]] if int(a) in column else gate
                     for r, a in enumerate(assignment)))


OBSERVATION_FIELDS = ('range', 'bearing', 'var_range', 'var_bearing', 'x', 'y', 'cov_xx',
                      'cov_xy', 'cov_yy')


def general_observations(points: np.ndarray, model: str, noise) -> object:
    """observations_from_points by its field-by-field path (or the error it raises)."""
    original = inputs_module._float32_columns
    inputs_module._float32_columns = lambda dtype, model: None
    try:
        return observations_from_points(points, model, noise)
    except InvalidInputError as error:
        return str(error)
    finally:
        inputs_module._float32_columns = original


@settings(max_examples=150, deadline=None)
@given(data=st.data(), rows=st.integers(0, 6),
       model=st.sampled_from(['range_bearing', 'point_map', 'point_robot']))
def test_observations_from_float32_words_are_those_of_the_general_path(data, rows, model):
    """Any layout (float32 at word boundaries or not, float64, big-endian, padding, missing
    fields) and any values (NaN, inf, negative or indefinite variances): the same observations,
    or the same error, compiled or not."""
    names = data.draw(st.lists(st.sampled_from(OBSERVATION_FIELDS), unique=True, max_size=6))
    formats = data.draw(st.lists(st.sampled_from(['<f4', '<f4', '<f8', '>f4']),
                                 min_size=len(names), max_size=len(names)))
    offsets, offset = [], 0
    for kind in formats:
        offset += data.draw(st.sampled_from([0, 0, 1, 4]))
        offsets.append(offset)
        offset += np.dtype(kind).itemsize
    itemsize = offset + data.draw(st.sampled_from([0, 3, 4]))
    dtype = np.dtype({'names': names, 'formats': formats, 'offsets': offsets,
                      'itemsize': max(itemsize, 1)})
    values = st.one_of(st.floats(-3.0, 3.0), st.floats(0.01, 2.0),
                       st.sampled_from([np.nan, np.inf, 0.0, 1e30]))
    points = np.zeros(rows, dtype=dtype)
    for name in names:
        points[name] = data.draw(st.lists(values, min_size=rows, max_size=rows))
    points.flags.writeable = False
    noise = data.draw(st.sampled_from([[0.01], [0.04, 1e-4], [-1.0]]))
    expected = general_observations(points, model, noise)
    for compiled in (True, False):
        with jit.compiled(compiled):
            try:
                got = observations_from_points(points, model, noise)
            except InvalidInputError as error:
                got = str(error)
        if isinstance(expected, str):
            assert got == expected
            continue
        assert not isinstance(got, str), got
        assert got.model == expected.model
        np.testing.assert_array_equal(got.values, expected.values)
        np.testing.assert_array_equal(got.covariances, expected.covariances)
        assert not (got.values.flags.writeable or got.covariances.flags.writeable)


@settings(max_examples=150, deadline=None)
@given(data=st.data(), rows=st.integers(0, 8), given_probabilities=st.booleans())
def test_correspondences_cloud_packed_by_the_kernel_as_by_numpy(data, rows,
                                                              given_probabilities):
    """Ids of any size (int32 casts alike), NaN and huge floats (is_dense alike)."""
    floats = st.one_of(st.floats(-1e3, 1e3), st.sampled_from([np.nan, np.inf, 1e300]))
    association = Association(
        np.array(data.draw(st.lists(st.integers(-2, 2 ** 40), min_size=rows, max_size=rows)),
                 dtype=np.int64),
        np.array(data.draw(st.lists(floats, min_size=rows, max_size=rows)), dtype=float), 'x')
    positions = np.array(data.draw(st.lists(floats, min_size=2 * rows, max_size=2 * rows)),
                         dtype=float).reshape(rows, 2)
    probabilities = np.array(data.draw(st.lists(floats, min_size=rows, max_size=rows)),
                             dtype=float) if given_probabilities else None
    header = Header(frame_id='base_link')
    header.stamp.sec = 3
    with np.errstate(over='ignore', invalid='ignore'):
        packed = correspondences_cloud(header, association, positions, probabilities)
        with jit.compiled(False):
            reference = correspondences_cloud(header, association, positions, probabilities)
    assert packed == reference


def test_float32_words_read_where_every_field_is_one():
    """The layouts DESIGN.md's clouds use take the one-pass path; others the general one."""
    def columns(fields, model='range_bearing', itemsize=None):
        dtype = np.dtype(fields) if itemsize is None else np.dtype(
            {'names': [n for n, _ in fields], 'formats': [f for _, f in fields],
             'offsets': [4 * i + 1 for i in range(len(fields))], 'itemsize': itemsize})
        found = inputs_module._float32_columns(dtype, model)
        return None if found is None else found.tolist()
    f4 = '<f4'
    assert columns([('range', f4), ('bearing', f4)]) == [0, 1, -1, -1, -1]
    assert columns([('bearing', f4), ('range', f4), ('var_range', f4), ('var_bearing', f4)]) \
        == [1, 0, 2, -1, 3]
    assert columns([('x', f4), ('y', f4), ('cov_yy', f4), ('cov_xy', f4), ('cov_xx', f4)],
                   'point_map') == [0, 1, 4, 3, 2]
    assert columns([('x', f4), ('y', f4), ('cov_xx', f4)], 'point_robot') == [0, 1, -1, -1, -1]
    assert columns([('range', '<f8'), ('bearing', f4)]) is None
    assert columns([('range', f4), ('bearing', f4)], itemsize=12) is None   # offsets 1, 5
    assert columns([('range', f4)]) is None
    assert columns([('x', f4), ('y', f4), ('width', f4), ('height', f4)], 'box') is None
