"""Per-scan cost on large maps: associate() at N = 100 ... 100,000 landmarks, and with a joint
covariance of N = 5,000 (issue: cost grows with what the sensor sees, not with the map).

    python benchmarks/large_maps.py [--sizes 100,1000,10000,100000] [--ks 30,100]
    python benchmarks/large_maps.py --crossover     # when building an index pays, new map each scan

Scenes: the N landmarks nearest the robot of a city of 100,000 uniform at one per 16 m^2,
sigma 0.1 m (so the robot sees the same landmarks on every map size); pose sigma (0.05 m,
0.05 m, 0.02 rad); K observations: 90 % of them the K nearest landmarks (point_robot: sigma
0.05 m; range_bearing: 0.05 m, 0.01 rad), 10 % clutter within the same range.  Each map is
built once (the index is built at the first call, untimed, as for a prior map); times are
medians of repeated associate() calls on the same scan, in blocks of consecutive calls (scan
after scan on one map) taken round-robin over the map sizes (a busy machine slows them alike);
the answers are checked equal on every size.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import numpy as np  # noqa: E402


from data_association_ros import Landmarks, Observations, RobotPose, associate  # noqa: E402
from data_association_ros.core.models import MODELS  # noqa: E402
from data_association_ros.core.validation import check_covariance_matrix  # noqa: E402

ALGORITHMS = ('mahalanobis_nn', 'gnn', 'jcbb')
JCBB_NODES_K100 = 1000
"""jcbb with K = 100 stops after this many search nodes (the full search of 90 returns 25 m
around the robot takes minutes); the same search on every map size."""
MODELS_TIMED = ('point_robot', 'range_bearing')
POSE_COVARIANCE = np.diag([0.05 ** 2, 0.05 ** 2, 0.02 ** 2])
NOISE = {'point_robot': np.diag([0.05 ** 2, 0.05 ** 2]),
         'range_bearing': np.diag([0.05 ** 2, 0.01 ** 2])}


LARGEST = 100_000


def landmark_map(n: int, seed: int = 0) -> tuple[Landmarks, np.ndarray]:
    """(Landmarks, true positions): the N landmarks nearest the origin of one city of LARGEST
    (max(N, LARGEST)) landmarks uniform at one per 16 m^2, sigma 0.1 m; so every size holds the
    same landmarks around the robot, and a scan is the same problem on every map."""
    total = max(n, LARGEST)
    rng = np.random.default_rng(seed)
    half = 2.0 * np.sqrt(total)
    true = rng.uniform(-half, half, (total, 2))
    means = true + rng.normal(0.0, 0.1, (total, 2))
    nearest = np.argsort(np.hypot(true[:, 0], true[:, 1]), kind='stable')[:n]
    return (Landmarks(np.arange(n), means[nearest], np.tile(np.eye(2) * 0.1 ** 2, (n, 1, 1))),
            true[nearest])


def scan(true: np.ndarray, k: int, model: str, seed: int = 1) -> tuple[Observations, RobotPose]:
    """K observations from a pose near the origin: the nearest landmarks and 10 % clutter."""
    rng = np.random.default_rng(seed)
    pose_mean = rng.multivariate_normal(np.zeros(3), POSE_COVARIANCE, method='cholesky')
    seen_count = min(len(true), k - k // 10)
    seen = np.argsort(np.hypot(true[:, 0], true[:, 1]))[:seen_count]
    reach = float(np.hypot(*true[seen].T).max()) if seen_count else 10.0
    clutter_count = k - seen_count
    angle = rng.uniform(-np.pi, np.pi, clutter_count)
    radius = reach * np.sqrt(rng.uniform(0.0, 1.0, clutter_count))
    points = np.vstack([true[seen], np.column_stack([radius * np.cos(angle),
                                                     radius * np.sin(angle)])])
    z, _, _ = MODELS[model].predict(points, np.zeros(3))
    z = z + rng.multivariate_normal(np.zeros(2), NOISE[model], len(z), method='cholesky')
    return (Observations(z, np.tile(NOISE[model], (k, 1, 1)), model),
            RobotPose(pose_mean, POSE_COVARIANCE))


def joint_covariance(landmarks: Landmarks, seed: int = 2) -> np.ndarray:
    """A valid joint covariance of [pose, landmarks]: the marginals plus the correlation a
    SLAM filter builds, every landmark sharing the pose error (P = D + G Q G^T)."""
    rng = np.random.default_rng(seed)
    n = 3 + 2 * len(landmarks)
    g = np.zeros((n, 3))
    g[:3] = np.eye(3)
    g[3:, :2] = np.tile(np.eye(2), (len(landmarks), 1)) * 0.8
    g[3:, 2] = rng.normal(0.0, 0.3, n - 3)
    matrix = g @ POSE_COVARIANCE @ g.T
    for j in range(len(landmarks)):
        matrix[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j] += landmarks.covariances[j]
    return matrix


def interleaved_ms(calls: dict, rounds: int = 25, block: int = 4) -> dict:
    """Median ms of each call: rounds of `block` + 1 consecutive calls of each (the first of a
    block untimed: as scan after scan on one map, not after another map's calls evicted the
    caches), the calls round-robin so that a busy machine slows all alike.  One untimed call
    each first (it builds the index)."""
    times = {key: [] for key in calls}
    for call in calls.values():
        call()
    for _ in range(rounds):
        for key, call in calls.items():
            call()
            for _ in range(block):
                started = time.perf_counter()
                call()
                times[key].append(time.perf_counter() - started)
    return {key: float(np.median(values)) * 1e3 for key, values in times.items()}


def size_table(sizes: list[int], ks: list[int]) -> list[dict]:
    """Median ms per (K, model, algorithm, N), indexed, and unindexed where N <= 10,000; the
    answers on every map are checked equal (the same problem, only the map grows)."""
    rows = []
    maps = {n: landmark_map(n) for n in sizes}
    for k in ks:
        for model in MODELS_TIMED:
            for algorithm in ALGORITHMS:
                calls = {}
                for n in sizes:
                    landmarks, true = maps[n]
                    observations, pose = scan(true, k, model)
                    budget = {'max_nodes': JCBB_NODES_K100} if algorithm == 'jcbb' and k > 30 \
                        else {}
                    for indexed in (None, False) if n <= 10_000 else (None,):
                        calls[n if indexed is None else f'{n} unindexed'] = (
                            lambda lm=landmarks, o=observations, p=pose, i=indexed: associate(
                                lm, o, algorithm, pose=p, spatial_index=i, **budget))
                answers = {key: call().assignment for key, call in calls.items()}
                first = next(iter(answers.values()))
                assert all(np.array_equal(a, first) for a in answers.values()), answers
                row = {'k': k, 'model': model, 'algorithm': algorithm,
                       **interleaved_ms(calls, rounds=10, block=4 if k <= 30 or algorithm != 'jcbb'
                                        else 1)}
                rows.append(row)
                print(row, flush=True)
    return rows


def joint_table(sizes: tuple[int, ...] = (100, 5000), k: int = 30) -> list[dict]:
    """Median ms with a joint covariance, range_bearing, per algorithm; and the arrival check
    (finite, symmetric, non-negative diagonal) of the matrix, once per message."""
    rows = []
    prepared = {}
    for n in sizes:
        landmarks, true = landmark_map(n)
        raw = joint_covariance(landmarks)
        started = time.perf_counter()
        checked = check_covariance_matrix(raw, 'state_covariance')
        prepared[n] = (landmarks, true, checked, (time.perf_counter() - started) * 1e3)
    for algorithm in ALGORITHMS:
        calls = {}
        for n in sizes:
            landmarks, true, checked, _ = prepared[n]
            observations, pose = scan(true, k, 'range_bearing')
            calls[n] = (lambda lm=landmarks, o=observations, p=pose, c=checked: associate(
                lm, o, algorithm, pose=p, state_covariance=c))
        row = {'algorithm': algorithm, **interleaved_ms(calls)}
        row.update({f'{n} arrival': prepared[n][3] for n in sizes})
        rows.append(row)
        print(row, flush=True)
    return rows


def crossover_table(sizes=(64, 128, 256, 512, 1024), ks=(2, 5, 10, 30, 100),
                    algorithms=('mahalanobis_nn', 'jcbb')) -> str:
    """Median ms of associate() with a new map every call (as a SLAM node's map), unindexed
    versus indexed (the trees built inside the call), range_bearing: where INDEX_BUILD_MIN_LANDMARKS
    comes from."""
    lines = [f'`python benchmarks/large_maps.py --crossover` ({time.strftime("%Y-%m-%d")}, '
             f'{os.cpu_count()} cores); median ms per associate() call with a new map each call, '
             'unindexed / index built in the call', '',
             '| algorithm | N | ' + ' | '.join(f'K = {k}' for k in ks) + ' |',
             '|---|---|' + '---|' * len(ks)]
    for algorithm in algorithms:
        for n in sizes:
            landmarks, true = landmark_map(n)
            cells = []
            for k in ks:
                if k > n:
                    cells.append('')
                    continue
                observations, pose = scan(true, k, 'range_bearing')
                arrays = (landmarks.ids, landmarks.means, landmarks.covariances)
                budget = {'max_nodes': JCBB_NODES_K100} if algorithm == 'jcbb' else {}
                calls = {indexed: (lambda i=indexed, o=observations, p=pose: associate(
                    Landmarks(*arrays), o, algorithm, pose=p, spatial_index=i, **budget))
                    for indexed in (False, True)}
                times = interleaved_ms(calls, rounds=5, block=3)
                cells.append(f'{times[False]:.2f} / {times[True]:.2f}')
            lines.append(f'| {algorithm} | {n} | ' + ' | '.join(cells) + ' |')
            print(lines[-1], flush=True)
    return '\n'.join(lines)


def markdown(rows: list[dict], joint: list[dict], sizes: list[int]) -> str:
    first, last = 1000 if 1000 in sizes else sizes[0], sizes[-1]
    big_unindexed = max(n for n in sizes if n <= 10_000)
    lines = [f'`python benchmarks/large_maps.py` ({time.strftime("%Y-%m-%d")}, '
             f'{os.cpu_count()} cores ({platform.machine()}), Python {platform.python_version()}'
             f', numpy {np.__version__}); median ms per associate() call, index built once '
             'per map', '',
             '| K | model | algorithm | ' + ' | '.join(f'N = {n:,}' for n in sizes)
             + f' | N = {last:,} / N = {first:,} | unindexed N = {big_unindexed:,} |',
             '|---|---|---|' + '---|' * (len(sizes) + 2)]
    note = f' (max_nodes {JCBB_NODES_K100})'
    for r in rows:
        budget = note if r['algorithm'] == 'jcbb' and r['k'] > 30 else ''
        lines.append(f'| {r["k"]} | {r["model"]} | {r["algorithm"]}{budget} | '
                     + ' | '.join(f'{r[n]:.3g}' for n in sizes)
                     + f' | {r[last] / r[first]:.2f} | {r[f"{big_unindexed} unindexed"]:.3g} |')
    if joint:
        sizes_j = [n for n in joint[0] if isinstance(n, int)]
        lines += ['', 'With a joint covariance (range_bearing, K = 30; only the local block is '
                  'read); arrival = the once-per-message check of the whole matrix (finite, '
                  'symmetric, non-negative diagonal), ms', '',
                  '| algorithm | ' + ' | '.join(f'N = {n:,}' for n in sizes_j)
                  + f' | N = {sizes_j[-1]:,} / N = {sizes_j[0]:,} | arrival check '
                  f'N = {sizes_j[-1]:,} |',
                  '|---|' + '---|' * (len(sizes_j) + 2)]
        for r in joint:
            lines.append(f'| {r["algorithm"]} | ' + ' | '.join(f'{r[n]:.3g}' for n in sizes_j)
                         + f' | {r[sizes_j[-1]] / r[sizes_j[0]]:.2f} | '
                         f'{r[f"{sizes_j[-1]} arrival"]:.0f} |')
    return '\n'.join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--sizes', default='100,1000,10000,100000',
                        help='map sizes N, comma-separated (default: %(default)s)')
    parser.add_argument('--ks', default='30,100', help='observations per scan K (default: '
                        '%(default)s)')
    parser.add_argument('--no-joint', action='store_true',
                        help='skip the joint-covariance table (it builds a 10003^2 matrix)')
    parser.add_argument('--crossover', action='store_true',
                        help='only the table of indexed versus unindexed with a new map per scan')
    args = parser.parse_args(argv)
    if args.crossover:
        print(crossover_table())
        return
    sizes = [int(s) for s in args.sizes.split(',')]
    rows = size_table(sizes, [int(k) for k in args.ks.split(',')])
    joint = [] if args.no_joint else joint_table()
    print(markdown(rows, joint, sizes))


if __name__ == '__main__':
    main()
