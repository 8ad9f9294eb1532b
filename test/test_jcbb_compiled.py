"""The compiled joint compatibility search (numba) against the pure-Python one: the same answer,
joint NIS, node count and truncation on random problems (range-bearing with and without a full
state covariance, boxes with m = 4, every search mode, jcbb_points' fixed root), and the
package working without numba."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from data_association_ros import Landmarks, Observations, associate
from data_association_ros.core import jit
from data_association_ros.core.associators import jcbb_compiled
from data_association_ros.core.jit import compiled
from problem_factory import random_range_bearing_problem

ROOT = Path(__file__).resolve().parents[1]
needs_numba = pytest.mark.skipif(jit.load_numba() is None,
                                 reason=f'numba not loaded: {jit.import_error()}')
MODES = [('jcbb', {}), ('jcbb', {'classic_pruning': True, 'nis_tie_break': False}),
         ('jcbb', {'classic_pruning': True}), ('jcbb', {'nis_tie_break': False}),
         ('jcbb', {'max_nodes': 5}), ('jcbb', {'joint_gate_probability': 0.9}),
         ('jcbb_points', {}), ('jcbb_points', {'max_nodes': 3})]


def both(inputs: dict, algorithm: str, **parameters):
    """(pure-Python result, compiled result) of one associate() call."""
    with compiled(False):
        pure = associate(**inputs, algorithm=algorithm, **parameters)
    with compiled(True):
        fast = associate(**inputs, algorithm=algorithm, **parameters)
    return pure, fast


def assert_same(pure, fast, context: str) -> None:
    np.testing.assert_array_equal(fast.assignment, pure.assignment, err_msg=context)
    assert fast.extras['search_nodes'] == pure.extras['search_nodes'], context
    assert fast.truncated == pure.truncated, context
    assert fast.extras['joint_nis'] == pytest.approx(pure.extras['joint_nis'], rel=1e-9,
                                                     abs=1e-12), context


def range_bearing_inputs(seed: int, landmarks: int, seen: int, clutter: int, duplicates: int,
                         joint: bool) -> dict:
    lm, obs, pose, state_covariance, _ = random_range_bearing_problem(
        np.random.default_rng(seed), landmarks, seen, clutter, duplicates, joint)
    return dict(landmarks=lm, observations=obs, pose=pose, state_covariance=state_covariance)


@needs_numba
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2 ** 32 - 1), landmarks=st.integers(1, 24),
       seen=st.integers(0, 16), clutter=st.integers(0, 4), duplicates=st.integers(0, 6),
       joint=st.booleans(), mode=st.sampled_from(MODES))
def test_compiled_equals_pure_on_random_range_bearing_problems(seed, landmarks, seen, clutter,
                                                               duplicates, joint, mode):
    inputs = range_bearing_inputs(seed, landmarks, min(seen, landmarks), clutter, duplicates,
                                  joint)
    algorithm, parameters = mode
    pure, fast = both(inputs, algorithm, **parameters)
    assert_same(pure, fast, f'seed {seed} {mode}')


@needs_numba
@pytest.mark.parametrize('block', range(4))
def test_compiled_equals_pure_on_the_reference_test_problems(block):
    """The 2,000 problems of test_jcbb's reference test (500 per block), every mode."""
    paired = 0
    for seed in range(5000 + block * 500, 5000 + (block + 1) * 500):
        rng = np.random.default_rng(seed)
        lm, obs, pose, state_covariance, _ = random_range_bearing_problem(
            rng, n_landmarks=int(rng.integers(2, 10)), n_seen=int(rng.integers(1, 7)),
            n_clutter=int(rng.integers(0, 3)), duplicates=int(rng.integers(0, 4)),
            joint=bool(seed % 2))
        inputs = dict(landmarks=lm, observations=obs, pose=pose,
                      state_covariance=state_covariance)
        algorithm, parameters = MODES[seed % len(MODES)]
        pure, fast = both(inputs, algorithm, **parameters)
        assert_same(pure, fast, f'seed {seed} {algorithm} {parameters}')
        paired += int((fast.assignment >= 0).sum())
    assert paired > 500


@needs_numba
@pytest.mark.parametrize('seed', range(40))
def test_compiled_equals_pure_on_boxes(seed):
    """m = 4 (boxes): the general Cholesky path of the kernel."""
    rng = np.random.default_rng(seed)
    n, k = int(rng.integers(2, 12)), int(rng.integers(1, 10))
    boxes = np.column_stack([rng.uniform(0, 40, (n, 2)), rng.uniform(5, 10, (n, 2))])
    seen = rng.choice(n, min(k, n), replace=False)
    detections = boxes[seen] + rng.normal(0, 1.5, (len(seen), 4))
    landmarks = Landmarks(np.arange(n) * 3, boxes, np.tile(np.eye(4) * 4.0, (n, 1, 1)))
    observations = Observations(detections, np.tile(np.eye(4) * 2.0, (len(seen), 1, 1)), 'box')
    pure, fast = both(dict(landmarks=landmarks, observations=observations), 'jcbb')
    assert_same(pure, fast, f'seed {seed}')


@needs_numba
def test_compiled_time_budget_truncates_and_flags():
    """A search far longer than its budget stops near the budget with the best set so far."""
    inputs = range_bearing_inputs(3, 60, 40, 4, 30, False)
    full = associate(**inputs, algorithm='jcbb', max_nodes=2000)
    assert full.truncated and full.extras['search_nodes'] == 2000
    cut = associate(**inputs, algorithm='jcbb', time_budget_ms=1e-6)
    assert cut.truncated and cut.extras['search_nodes'] == 1
    with compiled(False):
        pure_cut = associate(**inputs, algorithm='jcbb', time_budget_ms=1e-6)
    assert pure_cut.truncated and pure_cut.extras['search_nodes'] == 1
    # a budget it does not reach: the same answer as without one
    small = range_bearing_inputs(4, 15, 10, 2, 3, True)
    np.testing.assert_array_equal(
        associate(**small, algorithm='jcbb', time_budget_ms=10_000.0).assignment,
        associate(**small, algorithm='jcbb').assignment)


def run_python(code: str, **environment) -> subprocess.CompletedProcess:
    env = {**os.environ, **environment}
    return subprocess.run([sys.executable, '-c', code], cwd=ROOT, env=env, text=True,
                          capture_output=True, timeout=300)


JCBB_SCRIPT = """
import sys
sys.path.insert(0, 'test')
import numpy as np
{block}
from data_association_ros import associate
from data_association_ros.core import problem_kernels
from data_association_ros.core.associators import jcbb_compiled
from problem_factory import random_range_bearing_problem
lm, obs, pose, p, _ = random_range_bearing_problem(np.random.default_rng(11), 8, 6, 2, 2, True)
r = associate(lm, obs, 'jcbb', pose=pose, state_covariance=p)
print(jcbb_compiled.available(), problem_kernels.KERNELS.available(), list(r.assignment),
      r.extras['search_nodes'], np.round(r.nis, 9).tolist())
"""


@needs_numba
def test_package_works_without_numba_with_the_same_answer():
    """numba missing (import blocked) or switched off: the pure-Python search and the numpy
    NIS answer, the same as the compiled ones (assignment, nodes, NIS to 9 decimals)."""
    with_numba = run_python(JCBB_SCRIPT.format(block=''))
    blocked = run_python(JCBB_SCRIPT.format(block="sys.modules['numba'] = None"))
    switched_off = run_python(JCBB_SCRIPT.format(block=''), DATA_ASSOCIATION_ROS_NO_JIT='1')
    for process in (with_numba, blocked, switched_off):
        assert process.returncode == 0, process.stderr
    assert with_numba.stdout.startswith('True True ')
    for process in (blocked, switched_off):
        assert process.stdout.startswith('False False ')
    answer = with_numba.stdout.split(' ', 2)[2]
    assert blocked.stdout.split(' ', 2)[2] == answer == switched_off.stdout.split(' ', 2)[2]


def test_cache_dir_falls_back_to_a_user_directory(monkeypatch, tmp_path):
    """A read-only package directory: NUMBA_CACHE_DIR becomes a directory under the user's
    cache ($XDG_CACHE_HOME); an explicit NUMBA_CACHE_DIR is kept."""
    package = Path(jit.__file__).resolve().parent / '__pycache__'
    # setenv first so that the undo removes what _choose_cache_dir sets (delenv of an unset
    # name records nothing: the directory would leak to every later test's subprocesses, whose
    # nodes then compiled their kernels afresh in it, 35-60 s)
    monkeypatch.setenv('NUMBA_CACHE_DIR', '')
    monkeypatch.delenv('NUMBA_CACHE_DIR')
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path))
    real = jit._writable
    monkeypatch.setattr(jit, '_writable',
                        lambda directory: directory != package and real(directory))
    jit._choose_cache_dir()
    assert os.environ['NUMBA_CACHE_DIR'] == str(tmp_path / 'data_association_ros' / 'numba')
    assert (tmp_path / 'data_association_ros' / 'numba').is_dir()
    monkeypatch.setenv('NUMBA_CACHE_DIR', '/somewhere/else')
    jit._choose_cache_dir()
    assert os.environ['NUMBA_CACHE_DIR'] == '/somewhere/else'
