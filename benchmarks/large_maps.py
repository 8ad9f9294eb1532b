"""Per-scan cost on large maps: associate() at N = 100 ... 100,000 landmarks, and with a joint
covariance of N = 5,000 (issue: cost grows with what the sensor sees, not with the map).

    python benchmarks/large_maps.py [--sizes 100,1000,10000,100000] [--markdown]

Scenes: landmarks uniform at one per 16 m^2 (a square of side 4 sqrt(N) m) around the robot,
sigma 0.1 m; pose sigma (0.05 m, 0.05 m, 0.02 rad); K observations: 90 % of them the K nearest
landmarks (point_robot: sigma 0.05 m; range_bearing: 0.05 m, 0.01 rad), 10 % clutter within
the same range.  Each map is built once (the index is built at the first call, untimed, as for
a prior map); times are medians of repeated associate() calls on the same scan.  Ratios are of
times measured in this run.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time

os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from timing import median_p95_ms, time_calls  # noqa: E402

from data_association_ros import Landmarks, Observations, RobotPose, associate  # noqa: E402
from data_association_ros.core.models import MODELS  # noqa: E402
from data_association_ros.core.validation import check_covariance_matrix  # noqa: E402

ALGORITHMS = ('mahalanobis_nn', 'gnn', 'jcbb')
MODELS_TIMED = ('point_robot', 'range_bearing')
POSE_COVARIANCE = np.diag([0.05 ** 2, 0.05 ** 2, 0.02 ** 2])
NOISE = {'point_robot': np.diag([0.05 ** 2, 0.05 ** 2]),
         'range_bearing': np.diag([0.05 ** 2, 0.01 ** 2])}


def landmark_map(n: int, seed: int = 0) -> tuple[Landmarks, np.ndarray]:
    """(Landmarks: N uniform at one per 16 m^2 around the origin, sigma 0.1 m; true positions)."""
    rng = np.random.default_rng(seed)
    half = 2.0 * np.sqrt(n)
    true = rng.uniform(-half, half, (n, 2))
    means = true + rng.normal(0.0, 0.1, (n, 2))
    return Landmarks(np.arange(n), means, np.tile(np.eye(2) * 0.1 ** 2, (n, 1, 1))), true


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


def time_scan(landmarks, observations, pose, algorithm, state_covariance=None,
              spatial_index=None) -> float:
    """Median ms of associate() on one scan (the first call, which builds the index, untimed)."""
    times = time_calls(lambda: associate(landmarks, observations, algorithm, pose=pose,
                                         state_covariance=state_covariance,
                                         spatial_index=spatial_index),
                       min_repeats=7, max_repeats=60, min_seconds=0.25)
    return median_p95_ms(times)[0]


def size_table(sizes: list[int], ks: list[int]) -> list[dict]:
    """Median ms per (K, model, algorithm, N), indexed, and unindexed where N <= 10,000."""
    rows = []
    maps = {n: landmark_map(n) for n in sizes}
    for k in ks:
        for model in MODELS_TIMED:
            for algorithm in ALGORITHMS:
                row = {'k': k, 'model': model, 'algorithm': algorithm}
                for n in sizes:
                    landmarks, true = maps[n]
                    observations, pose = scan(true, k, model)
                    row[n] = time_scan(landmarks, observations, pose, algorithm)
                    if n <= 10_000:
                        row[f'{n} unindexed'] = time_scan(landmarks, observations, pose,
                                                          algorithm, spatial_index=False)
                rows.append(row)
                print(row, flush=True)
    return rows


def joint_table(sizes: tuple[int, ...] = (100, 5000), k: int = 30) -> list[dict]:
    """Median ms with a joint covariance, range_bearing, per algorithm; and the arrival check
    (finite, symmetric, non-negative diagonal) of the matrix once per message."""
    rows = []
    prepared = {}
    for n in sizes:
        landmarks, true = landmark_map(n)
        raw = joint_covariance(landmarks)
        started = time.perf_counter()
        checked = check_covariance_matrix(raw, 'state_covariance')
        prepared[n] = (landmarks, true, checked, (time.perf_counter() - started) * 1e3)
    for algorithm in ALGORITHMS:
        row = {'algorithm': algorithm}
        for n in sizes:
            landmarks, true, checked, arrival = prepared[n]
            observations, pose = scan(true, k, 'range_bearing')
            row[n] = time_scan(landmarks, observations, pose, algorithm, checked)
            row[f'{n} arrival'] = arrival
        rows.append(row)
        print(row, flush=True)
    return rows


def markdown(rows: list[dict], joint: list[dict], sizes: list[int]) -> str:
    first, last = 1000 if 1000 in sizes else sizes[0], sizes[-1]
    lines = [f'`python benchmarks/large_maps.py` ({time.strftime("%Y-%m-%d")}, '
             f'{os.cpu_count()} cores ({platform.machine()}), Python {platform.python_version()}'
             f', numpy {np.__version__}); median ms per associate() call, index built once '
             'per map', '',
             '| K | model | algorithm | ' + ' | '.join(f'N = {n:,}' for n in sizes)
             + f' | N = {last:,} / N = {first:,} | unindexed N = {max(n for n in sizes if n <= 10_000):,} |',
             '|---|---|---|' + '---|' * (len(sizes) + 2)]
    big_unindexed = max(n for n in sizes if n <= 10_000)
    for r in rows:
        lines.append(f'| {r["k"]} | {r["model"]} | {r["algorithm"]} | '
                     + ' | '.join(f'{r[n]:.3g}' for n in sizes)
                     + f' | {r[last] / r[first]:.2f} | {r[f"{big_unindexed} unindexed"]:.3g} |')
    if joint:
        sizes_j = [n for n in joint[0] if isinstance(n, int)]
        lines += ['', 'With a joint covariance (range_bearing, K = 30; only the local block is '
                  'read); arrival = the once-per-message check of the whole matrix (finite, '
                  'symmetric, non-negative diagonal), ms', '',
                  '| algorithm | ' + ' | '.join(f'N = {n:,}' for n in sizes_j)
                  + f' | N = {sizes_j[-1]:,} / N = {sizes_j[0]:,} | arrival check N = {sizes_j[-1]:,} |',
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
    args = parser.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(',')]
    rows = size_table(sizes, [int(k) for k in args.ks.split(',')])
    joint = [] if args.no_joint else joint_table()
    print(markdown(rows, joint, sizes))


if __name__ == '__main__':
    main()
