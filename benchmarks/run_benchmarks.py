"""The benchmark suite: prints markdown tables (with core count and date) and writes a plot.

    bash scripts/run_benchmarks.sh            # installs the extras (matplotlib, stonesoup), runs all
    python benchmarks/run_benchmarks.py [--quick] [--sections sweep,jcbb,stonesoup,seed,budget]
                                        [--out benchmarks/results]

Sections:
  sweep      each associator on K = N from 10 to 1000 (while a call stays under --max-call-s):
             median and p95 per call, and OUT/associators.png (time versus size)
  jcbb       fast jcbb versus the straightforward reference JCBB of the test suite on 20-40
             observation scans (the clutter_range_bearing scenario, and denser random scans):
             identical answers, time ratio
  compiled   jcbb with the compiled search (numba) versus the pure-Python search (the jcbb of
             before the compiled one) on the same scans and node_latency's K = 50, N = 200
             scan: identical answers and node counts, time ratio
  stonesoup  gnn versus Stone Soup's GNNWith2DAssignment at N = 10, 50, 200
  seed       seed 003's approximate Cholesky joint NIS versus the exact incremental one
  budget     jcbb's time_budget_ms: elapsed time and overshoot on searches that need longer
             (a dense scan; every observation compatible with every landmark, K = 40)
  multi_hypothesis  the re-evaluation experiment of Shelly & Indelman (multi_hypothesis_experiment.py)
Timings are per call of the public associate() (inputs built beforehand); ratios compare
runs in the same process on the same machine.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import data_association_ros  # noqa: F401  (before numpy: one BLAS thread, as in the node)
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'test'))  # the reference JCBB and random problems of the tests

from data_association_ros import (Landmarks, Observations, RobotPose,  # noqa: E402
                                  associate, available_algorithms)
from data_association_ros.core.associators import REGISTRY  # noqa: E402
from data_association_ros.core.problem import AssociationProblem  # noqa: E402
from problem_factory import random_range_bearing_problem  # noqa: E402
from reference_jcbb import reference_jcbb  # noqa: E402
from scenes import Scene, bag_scenes, box_scene, point_map_scene, range_bearing_scene  # noqa: E402
from seed_approximate_jnis import approximate_nis, search_pairs  # noqa: E402
from timing import median_p95_ms, time_calls  # noqa: E402

SECTIONS = ('sweep', 'jcbb', 'compiled', 'stonesoup', 'seed', 'budget', 'multi_hypothesis')


def machine_line() -> str:
    """Date, cores, Python and numpy versions: printed above every table."""
    return (f'{datetime.date.today().isoformat()}, {os.cpu_count()} cores '
            f'({platform.machine()}), Python {platform.python_version()}, numpy {np.__version__}')


def table(title: str, header: list[str], rows: list[list]) -> str:
    """A markdown table under a bold title and the machine line."""
    def cell(value):
        return f'{value:.3g}' if isinstance(value, float) else str(value)
    lines = [f'**{title}** ({machine_line()})', '',
             '| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    lines += ['| ' + ' | '.join(cell(v) for v in row) + ' |' for row in rows]
    return '\n'.join(lines) + '\n'


def scene_for(algorithm: str, size: int) -> Scene:
    """The natural problem of an algorithm at K = N = size."""
    return box_scene(size, size) if REGISTRY[algorithm].models == ('box',) else \
        range_bearing_scene(size, size)


def sweep(sizes: list[int], max_call_s: float, out: Path) -> str:
    """Section sweep: per-call time of every associator versus K = N."""
    rows, curves = [], {}
    for algorithm in available_algorithms():
        for size in sizes:
            scene = scene_for(algorithm, size)
            if algorithm in curves:  # extrapolate cubically before paying for a slow size
                last_size, last_median, _ = curves[algorithm][-1]
                estimate = last_median / 1e3 * (size / last_size) ** 3
                if estimate > max_call_s:
                    rows.append([algorithm, scene.observations.model, size,
                                 f'not run (~{estimate:.0f} s estimated)', '', ''])
                    break
            started = time.perf_counter()
            associate(**scene.inputs(), algorithm=algorithm)
            if time.perf_counter() - started > max_call_s:
                rows.append([algorithm, scene.observations.model, size, f'> {max_call_s:g} s',
                             '', ''])
                break
            median, p95 = median_p95_ms(time_calls(
                lambda: associate(**scene.inputs(), algorithm=algorithm)))
            rows.append([algorithm, scene.observations.model, size, median, p95,
                         median * 1e3 / (size * size)])
            curves.setdefault(algorithm, []).append((size, median, p95))
    plot_sweep(curves, out / 'associators.png')
    return table('Per call, K observations x N landmarks (K = N)',
                 ['algorithm', 'model', 'K = N', 'median ms', 'p95 ms', 'us per pair'], rows)


def plot_sweep(curves: dict, path: Path) -> None:
    """Log-log plot of median time (p95 as error bar) versus size."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(figsize=(7, 4.5))
    for algorithm, points in curves.items():
        size, median, p95 = np.array(points).T
        axes.errorbar(size, median, yerr=[np.zeros_like(median), p95 - median], marker='o',
                      capsize=3, label=algorithm)
    axes.set(xscale='log', yscale='log', xlabel='K = N (observations = landmarks)',
             ylabel='time per associate() call [ms]',
             title=f'data_association_ros associators ({machine_line().split(",")[1].strip()})')
    axes.grid(True, which='both', alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def hard_scans(count: int, landmarks: int = 24, seen: int = 16) -> list[Scene]:
    """Random EKF-SLAM scans denser than the bag's: 24 landmarks in 16 m x 16 m (3 near
    duplicates), 16 seen + 4 clutter, a random full joint covariance.  (With 30 landmarks and
    20 seen, the reference needs minutes on some scans.)"""
    scenes = []
    for seed in range(count):
        lm, obs, pose, p, _ = random_range_bearing_problem(
            np.random.default_rng(100 + seed), landmarks, seen, 4, duplicates=3, joint=True)
        scenes.append(Scene(lm, obs, pose, p, np.zeros(len(obs), dtype=int)))
    return scenes


def fast_versus_reference(sets: dict[str, list[Scene]]) -> str:
    """Section jcbb: same answers and time ratio, fast jcbb versus reference_jcbb."""
    rows = []
    for name, scenes in sets.items():
        fast, slow, same, ratios = [], [], 0, []
        for scene in scenes:
            started = time.perf_counter()
            expected, _, _ = reference_jcbb(scene.landmarks, scene.observations, scene.pose,
                                            scene.state_covariance)
            reference_s = time.perf_counter() - started
            times = time_calls(lambda: associate(**scene.inputs(), algorithm='jcbb'),
                               min_repeats=5, max_repeats=20, min_seconds=0.05)
            answer = associate(**scene.inputs(), algorithm='jcbb').assignment
            same += int(np.array_equal(answer, expected))
            fast.append(float(np.median(times)))
            slow.append(reference_s)
            ratios.append(reference_s / fast[-1])
        k = [len(s.observations) for s in scenes]
        rows.append([name, len(scenes), f'{min(k)}-{max(k)}', f'{same}/{len(scenes)}',
                     np.median(fast) * 1e3, np.median(slow) * 1e3, float(np.median(ratios)),
                     sum(slow) / sum(fast)])
    return table('jcbb versus the reference JCBB (full joint covariance factorised per node)',
                 ['scans', 'count', 'K', 'same answer', 'jcbb median ms', 'reference median ms',
                  'median ratio', 'total-time ratio'], rows)


def compiled_versus_python(sets: dict[str, list[Scene]]) -> str:
    """Section compiled: jcbb with the compiled kernels (problem arithmetic, candidates, search)
    versus without them (numpy arithmetic, pure-Python search), each scan timed for both in
    turn."""
    from data_association_ros.core.associators import jcbb_compiled
    from data_association_ros.core.jit import compiled
    if not jcbb_compiled.available():
        return f'compiled search unavailable: {jcbb_compiled.unavailable_reason()}\n'
    rows = []
    for name, scenes in sets.items():
        fast, slow, same, ratios = [], [], 0, []
        for scene in scenes:
            def call():
                return associate(**scene.inputs(), algorithm='jcbb')
            with compiled(False):
                python_times = time_calls(call, min_repeats=5, max_repeats=50, min_seconds=0.05)
                expected = call()
            compiled_times = time_calls(call, min_repeats=5, max_repeats=200, min_seconds=0.05)
            answer = call()
            same += int(np.array_equal(answer.assignment, expected.assignment)
                        and answer.extras['search_nodes'] == expected.extras['search_nodes'])
            fast.append(float(np.median(compiled_times)))
            slow.append(float(np.median(python_times)))
            ratios.append(slow[-1] / fast[-1])
        k = [len(s.observations) for s in scenes]
        rows.append([name, len(scenes), f'{min(k)}-{max(k)}', f'{same}/{len(scenes)}',
                     np.median(slow) * 1e3, np.median(fast) * 1e3, float(np.median(ratios)),
                     sum(slow) / sum(fast)])
    return table('jcbb: compiled kernels (numba) versus numpy and the pure-Python search, whole '
                 'associate() call', ['scans', 'count', 'K', 'same answer and nodes',
                                      'Python median ms', 'compiled median ms', 'median ratio',
                                      'total-time ratio'], rows)


def node_scene() -> Scene:
    """node_latency.py's scan as a Scene: K = 50 range-bearing returns (10 clutter), N = 200
    landmarks, no state covariance."""
    from node_latency import scene
    landmark_points, observation_points, pose = scene(50, 200)
    covariances = np.zeros((50, 2, 2))
    covariances[:, 0, 0] = observation_points['var_range']
    covariances[:, 1, 1] = observation_points['var_bearing']
    landmarks = Landmarks(landmark_points['id'].astype(int),
                          np.column_stack([landmark_points['x'], landmark_points['y']]).astype(
                              float), np.tile(np.eye(2) * 0.01, (200, 1, 1)))
    observations = Observations(np.column_stack([observation_points['range'],
                                                 observation_points['bearing']]).astype(float),
                                covariances, 'range_bearing')
    return Scene(landmarks, observations, RobotPose(pose, np.diag([0.01, 0.01, 0.003])), None,
                 np.zeros(50, dtype=int))


def stone_soup(sizes: list[int], seeds: int) -> str:
    """Section stonesoup: gnn versus GNNWith2DAssignment on point_map problems."""
    from stone_soup_gnn import StoneSoupGnn
    rows = []
    for size in sizes:
        ours, theirs, same = [], [], 0
        for seed in range(seeds):
            scene = point_map_scene(size, size, seed)
            reference = StoneSoupGnn(scene)
            answer = associate(**scene.inputs(), algorithm='gnn').assignment
            pairs = {(i, int(a)) for i, a in enumerate(answer) if a >= 0}
            same += int(pairs == reference.pairs(reference.associate()))
            theirs.append(np.median(time_calls(reference.associate, min_repeats=3,
                                               max_repeats=20, min_seconds=0.3)))
            ours.append(np.median(time_calls(
                lambda: associate(**scene.inputs(), algorithm='gnn'))))
        rows.append([size, f'{same}/{seeds}', np.median(ours) * 1e3, np.median(theirs) * 1e3,
                     float(np.median(theirs) / np.median(ours))])
    return table("gnn versus Stone Soup GNNWith2DAssignment (SquaredMahalanobis, "
                 "missed_distance = chi-square gate), K = N", ['N', 'same assignment',
                 'gnn median ms', 'Stone Soup median ms', 'ratio'], rows)


def seed_approximation(sets: dict[str, list[Scene]]) -> str:
    """Section seed: approximate versus exact joint NIS in the same branch and bound."""
    rows = []
    for name, scenes in sets.items():
        exact_t, approx_t, changed, invalid, errors = [], [], 0, 0, []
        for scene in scenes:
            problem = lambda: AssociationProblem(scene.landmarks, scene.observations,  # noqa
                                                 scene.pose, scene.state_covariance)
            exact, exact_nis, _ = search_pairs(problem())
            if exact_nis > 0:
                errors.append(abs(approximate_nis(problem(), exact) / exact_nis - 1.0))
            approx, _, _ = search_pairs(problem(), approximate=True)
            exact_t.append(np.median(time_calls(lambda: search_pairs(problem()),
                                                max_repeats=20, min_seconds=0.05)))
            approx_t.append(np.median(time_calls(lambda: search_pairs(problem(), approximate=True),
                                                 max_repeats=20, min_seconds=0.05)))
            if approx != exact:
                changed += 1
                invalid += int(not jointly_compatible(problem(), approx))
        rows.append([name, len(scenes), np.median(exact_t) * 1e3, np.median(approx_t) * 1e3,
                     float(np.median(np.array(exact_t) / np.array(approx_t))),
                     float(np.median(errors)) * 100, float(np.max(errors)) * 100,
                     f'{changed}/{len(scenes)}', f'{invalid}/{len(scenes)}'])
    return table("Seed 003's approximate Cholesky joint NIS versus the exact incremental one "
                 '(same search)', ['scans', 'count', 'exact median ms', 'approximate median ms',
                                   'speed-up of the approximation',
                                   'jNIS error of the answer median %', 'max %',
                                   'answer changed',
                                   'approximate answer fails the exact joint test'], rows)


def jointly_compatible(problem, pairs: set, gate_probability: float = 0.99) -> bool:
    """Whether `pairs` pass the exact joint chi-square test."""
    from data_association_ros.core.associators.jcbb_points import joint_nis_terms
    from data_association_ros.core.gating import chi2_threshold
    if not pairs:
        return True
    d2, _ = joint_nis_terms(problem, sorted(pairs))
    return d2 <= chi2_threshold(gate_probability, problem.observations.dim * len(pairs))


def adversarial_scan(k: int = 40):
    """(landmarks, observations) where every observation is compatible with every landmark:
    k landmarks within 0.1 m of the origin with sigma 1 m, k observations there too."""
    rng = np.random.default_rng(11)
    landmarks = Landmarks(np.arange(k), rng.normal(0, 0.1, (k, 2)), np.tile(np.eye(2), (k, 1, 1)))
    observations = Observations(rng.normal(0, 0.1, (k, 2)), np.tile(np.eye(2) * 0.01, (k, 1, 1)),
                                'point_map')
    return landmarks, observations


def budget(budgets_ms: list[float], repeats: int, nodes: int = 200_000) -> str:
    """Section budget: elapsed time of associate() with a time budget on searches that need
    far longer: a dense scan, and the adversarial all-compatible K = 40 scan."""
    lm, obs, pose, p, _ = random_range_bearing_problem(np.random.default_rng(7), 100, 80, 20,
                                                       duplicates=20)
    problems = {'dense K = N = 100': (lm, obs, pose), 'all compatible K = N = 40':
                adversarial_scan() + (None,)}
    rows = []
    for name, (landmarks, observations, robot) in problems.items():
        unlimited = time.perf_counter()
        associate(landmarks, observations, 'jcbb', pose=robot, max_nodes=nodes)
        unlimited = (time.perf_counter() - unlimited) * 1e3
        for limit in budgets_ms:
            elapsed, truncated = [], 0
            for _ in range(repeats):
                started = time.perf_counter()
                result = associate(landmarks, observations, 'jcbb', pose=robot,
                                   time_budget_ms=limit)
                elapsed.append((time.perf_counter() - started) * 1e3)
                truncated += int(result.extras['truncated'])
            over = (np.array(elapsed) - limit) / limit * 100
            rows.append([name, f'{nodes} nodes: {unlimited:.0f} ms', limit,
                         f'{truncated}/{repeats}', float(np.median(elapsed)),
                         float(np.max(elapsed)), float(np.median(over)), float(np.max(over))])
    return table('jcbb time_budget_ms on searches that need far longer',
                 ['scan', 'without budget', 'budget ms', 'cut short', 'median elapsed ms',
                  'max elapsed ms', 'median overshoot %', 'max overshoot %'], rows)


def multi_hypothesis(out: Path) -> str:
    """Section multi_hypothesis: the Shelly & Indelman experiment (its own script)."""
    import io
    from contextlib import redirect_stdout

    import multi_hypothesis_experiment
    buffer = io.StringIO()
    with redirect_stdout(buffer):
        multi_hypothesis_experiment.main(['--out', str(out / 'multi_hypothesis')])
    return buffer.getvalue()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sections', default=','.join(SECTIONS),
                        help=f'comma-separated subset of {",".join(SECTIONS)}')
    parser.add_argument('--quick', action='store_true', help='small sizes and few scans')
    parser.add_argument('--max-call-s', type=float, default=2.0,
                        help='stop an algorithm\'s sweep once one call takes longer')
    parser.add_argument('--out', type=Path, default=ROOT / 'benchmarks' / 'results',
                        help='directory for associators.png and benchmarks.md')
    args = parser.parse_args(argv)
    chosen = [s.strip() for s in args.sections.split(',') if s.strip()]
    unknown = set(chosen) - set(SECTIONS)
    if unknown:
        parser.error(f'unknown sections {sorted(unknown)}; valid: {", ".join(SECTIONS)}')
    quick = args.quick
    scans = {'clutter_range_bearing': bag_scenes((2,))[::8] if quick else bag_scenes((2, 5)),
             'dense random': hard_scans(1, 16, 10) if quick else hard_scans(12)}
    runners = {
        'sweep': lambda: sweep([10, 30] if quick else [10, 30, 100, 300, 1000],
                               args.max_call_s, args.out),
        'jcbb': lambda: fast_versus_reference(scans),
        'compiled': lambda: compiled_versus_python({**scans, 'node_latency K=50 N=200':
                                                    [node_scene()]}),
        'stonesoup': lambda: stone_soup([10, 50] if quick else [10, 50, 200], 1 if quick else 3),
        'seed': lambda: seed_approximation(scans),
        'multi_hypothesis': lambda: multi_hypothesis(args.out),
        'budget': lambda: budget([10.0, 50.0] if quick else [10.0, 50.0, 100.0],
                                 2 if quick else 30, 20_000 if quick else 200_000),
    }
    report = []
    for name in chosen:
        text = runners[name]()
        print(text, flush=True)
        report.append(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / 'benchmarks.md').write_text('\n'.join(report))
    return 0


if __name__ == '__main__':
    sys.exit(main())
