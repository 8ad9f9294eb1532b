"""The data set converters (data_association_ros.bag.datasets) against their source files.

Counts are recomputed here from the files (plain text parsing, or loadmat without squeezing),
not copied from the converters; consistency checks use the data sets' own truth.  The data is
at <repo>/../shared/data.
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from data_association_ros.bag.datasets import (CLUTTER, DEFAULT_DATA_DIRECTORY, SEQUENCES,
                                               SlamSequence)
from data_association_ros.bag.datasets import acfr_car_park, mrclam, ttk4250

REPOSITORY = Path(__file__).resolve().parents[1]
DATA = REPOSITORY.parent / 'shared' / 'data'


def wrap(angle):
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def compose_path(start: np.ndarray, increments: np.ndarray) -> np.ndarray:
    """Poses (N + 1, 3) from start (3,) moved by increments (N, 3), heading unwrapped; a plain
    loop, independent of the package's `compose`."""
    x, y, yaw = (float(v) for v in start)
    path = [(x, y, yaw)]
    for dx, dy, dyaw in increments:
        c, s = math.cos(yaw), math.sin(yaw)
        x, y, yaw = x + c * dx - s * dy, y + s * dx + c * dy, yaw + dyaw
        path.append((x, y, yaw))
    return np.array(path)


def exact_arcs(times: list, commands: list, queries: list) -> tuple[list, list]:
    """Independent dead reckoning, a plain loop: exact arcs, sample i's (v, w) of `commands`
    held from times[i] until times[i + 1] (the last one until the last query), from the zero
    pose at times[0]; the poses (x, y, yaw unwrapped) and distances travelled at `queries`
    (sorted, ms)."""
    x = y = yaw = distance = 0.0
    poses, travelled, q = [], [], 0
    for i, (v, w) in enumerate(commands):
        start = times[i]
        end = times[i + 1] if i + 1 < len(times) else max(queries[-1], start)
        while True:
            stop = min(end, queries[q]) if q < len(queries) else end
            dt = (stop - start) * 1e-3
            if abs(w) > 1e-12:
                x += v / w * (math.sin(yaw + w * dt) - math.sin(yaw))
                y -= v / w * (math.cos(yaw + w * dt) - math.cos(yaw))
            else:
                x += v * dt * math.cos(yaw)
                y += v * dt * math.sin(yaw)
            yaw += w * dt
            distance += abs(v) * dt
            start = stop
            if q < len(queries) and stop == queries[q]:
                poses.append((x, y, yaw))
                travelled.append(distance)
                q += 1
                continue
            break
    return poses, travelled


def same_pose(a: np.ndarray, b: np.ndarray, atol: float) -> bool:
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    d[..., 2] = wrap(d[..., 2])
    return bool(np.all(np.abs(d) <= atol))


@pytest.fixture(scope='module')
def sequences():
    """name -> SlamSequence, each loaded once for this module."""
    cache: dict[str, SlamSequence] = {}

    def get(name: str) -> SlamSequence:
        if name not in cache:
            cache[name] = SEQUENCES[name](DATA)
        return cache[name]
    return get


def flat(sequence: SlamSequence, attribute: str) -> np.ndarray:
    return np.concatenate([getattr(step, attribute) for step in sequence.steps])


# ---------------------------------------------------------------- registry and common form

def test_registry_and_default_directory():
    assert set(SEQUENCES) == {'ttk4250_simulated', 'ttk4250_simulated_clutter5',
                              'ttk4250_simulated_clutter20', 'dlr_spatial_cognition',
                              'mrclam_robot1', 'mrclam_robot2', 'victoria_park',
                              'acfr_car_park'}
    assert DEFAULT_DATA_DIRECTORY == DATA
    assert DEFAULT_DATA_DIRECTORY.is_dir()


@pytest.mark.parametrize('name', sorted(SEQUENCES))
def test_common_form(sequences, name):
    sequence = sequences(name)
    assert sequence.name == name
    assert sequence.model in ('range_bearing', 'point_robot')
    assert sequence.initial_pose.shape == (3,) and sequence.initial_covariance.shape == (3, 3)
    times = [step.time_ns for step in sequence.steps]
    assert all(isinstance(t, int) for t in times)
    assert np.all(np.diff(times) > 0)
    for step in sequence.steps:
        count = len(step.truth)
        assert step.increment.shape == (3,) and step.increment_covariance.shape == (3, 3)
        assert abs(step.increment[2]) <= np.pi
        assert step.values.shape == (count, 2) and step.covariances.shape == (count, 2, 2)
        assert step.truth.dtype.kind == 'i' and step.truth_certain.dtype == bool
        assert step.truth_certain.shape == (count,)
        assert np.all((step.truth >= 0) | (step.truth == CLUTTER))
        assert np.all(np.isfinite(step.values))
    covariances = flat(sequence, 'covariances')
    assert np.allclose(covariances, covariances.transpose(0, 2, 1))
    assert np.linalg.eigvalsh(covariances).min() > 0
    increments = np.array([step.increment_covariance for step in sequence.steps])
    assert np.allclose(increments, increments.transpose(0, 2, 1))
    assert np.linalg.eigvalsh(increments).min() >= -1e-15
    if sequence.model == 'range_bearing':
        values = flat(sequence, 'values')
        assert np.all(values[:, 0] > 0) and np.all(np.abs(values[:, 1]) <= np.pi)


# ---------------------------------------------------------------- TTK4250 simulated

@lru_cache(maxsize=None)
def ttk_source():
    folder = DATA / 'ttk4250_simulated_slam'
    mat = scipy.io.loadmat(folder / 'simulatedSLAM.mat')                # not squeezed
    rows = [line.split(',') for line in (folder / 'derived_gt_association.csv').read_text()
            .splitlines() if line and not line.startswith('#')][1:]
    return mat, [[int(field) for field in row[:4]] for row in rows]


def test_ttk4250_counts(sequences):
    mat, rows = ttk_source()
    sequence = sequences('ttk4250_simulated')
    scans = mat['z'].ravel()
    assert len(sequence.steps) == len(scans) == 1000
    assert [len(step.truth) for step in sequence.steps] == [cell.shape[1] for cell in scans]
    assert sequence.observation_count == len(rows)
    truth, certain = flat(sequence, 'truth'), flat(sequence, 'truth_certain')
    assert np.sum(truth == CLUTTER) == sum(row[2] == -1 for row in rows)
    assert np.sum(~certain) == sum(row[2] == -1 or row[3] == 1 for row in rows)
    for step, index, landmark, ambiguous in rows[::97]:
        assert sequence.steps[step].truth[index] == (landmark if landmark >= 0 else CLUTTER)
    assert len(sequence.true_landmarks) == mat['landmarks'].shape[1]
    assert sequence.parameters == {'gate_probability': 0.999, 'joint_gate_probability': 0.99999}


def test_ttk4250_dead_reckoning_and_truth(sequences):
    mat, _ = ttk_source()
    sequence = sequences('ttk4250_simulated')
    poses, odometry = mat['poseGT'].T, mat['odometry'].T
    assert same_pose(sequence.initial_pose, poses[0], 1e-12)
    assert np.all(sequence.steps[0].increment == 0)
    assert np.all(sequence.steps[0].increment_covariance == 0)
    path = compose_path(sequence.initial_pose, [step.increment for step in sequence.steps])
    expected = compose_path(poses[0], odometry[:len(sequence.steps) - 1])
    assert same_pose(path[1:], expected, 1e-9)            # step k ends at odometry path pose k
    for k, step in enumerate(sequence.steps):
        assert same_pose(step.true_pose, poses[k], 1e-12)
    # measurements predicted from the true pose and the true landmark match the values
    residuals, shifted = [], []
    for k, step in enumerate(sequence.steps):
        for value, landmark, certain in zip(step.values, step.truth, step.truth_certain):
            if not certain:
                continue
            for pose, out in ((poses[k], residuals), (poses[k + 1], shifted)):
                d = sequence.true_landmarks[landmark] - pose[:2]
                bearing = np.arctan2(d[1], d[0]) - pose[2]
                out.append((value[0] - np.hypot(*d), wrap(value[1] - bearing)))
    residuals, shifted = np.array(residuals), np.array(shifted)
    assert 0.04 < residuals[:, 0].std() < 0.06
    assert np.deg2rad(0.8) < residuals[:, 1].std() < np.deg2rad(1.2)
    assert shifted[:, 0].std() > 5 * residuals[:, 0].std()       # the other alignment is wrong
    # increments match the true motion to the simulated odometry noise
    true_increments = np.array([[*(np.array([[math.cos(a[2]), math.sin(a[2])],
                                             [-math.sin(a[2]), math.cos(a[2])]]) @ (b[:2] - a[:2])),
                                 wrap(b[2] - a[2])] for a, b in zip(poses[:-1], poses[1:])])
    errors = np.array([step.increment for step in sequence.steps[1:]]) - true_increments[:999]
    errors[:, 2] = wrap(errors[:, 2])
    assert np.all(errors[:, :2].std(axis=0) < 0.06) and errors[:, 2].std() < np.deg2rad(1.2)


@pytest.mark.parametrize('per_scan', [5, 20])
def test_ttk4250_clutter(sequences, per_scan):
    base = sequences('ttk4250_simulated')
    sequence = sequences(f'ttk4250_simulated_clutter{per_scan}')
    assert len(sequence.steps) == len(base.steps)
    assert sequence.observation_count == base.observation_count + per_scan * len(base.steps)
    truth, certain = flat(sequence, 'truth'), flat(sequence, 'truth_certain')
    assert np.sum(truth == CLUTTER) == np.sum(flat(base, 'truth') == CLUTTER) + per_scan * 1000
    assert np.sum(~certain) == np.sum(~flat(base, 'truth_certain'))
    base_values = flat(base, 'values')
    positions = []
    for step, original in zip(sequence.steps, base.steps):
        # the original measurements are there, in their order, with the rest clutter
        kept = np.array([np.any(np.all(v == original.values, axis=1)) for v in step.values])
        assert kept.sum() == len(original.truth)
        assert np.array_equal(step.values[kept], original.values)
        assert np.array_equal(step.truth[kept], original.truth)
        assert np.all(step.truth[~kept] == CLUTTER) and np.all(step.truth_certain[~kept])
        assert np.allclose(step.covariances[~kept], ttk4250.MEASUREMENT_COVARIANCE)
        assert np.array_equal(step.increment, original.increment)
        positions.extend(np.flatnonzero(~kept) / len(step.truth))
    clutter = np.concatenate([s.values[s.truth == CLUTTER] for s in sequence.steps])
    assert clutter[:, 0].min() >= 1.0 and clutter[:, 0].max() <= base_values[:, 0].max()
    assert base_values[:, 1].min() <= clutter[:, 1].min()
    assert clutter[:, 1].max() <= base_values[:, 1].max()
    assert 0.4 < np.mean(positions) < 0.6                 # spread through the scans
    again = ttk4250.with_clutter(base, per_scan, 4250 + per_scan)
    assert all(np.array_equal(a.values, b.values) for a, b in zip(again.steps, sequence.steps))
    other = ttk4250.with_clutter(base, per_scan, 1)
    assert not np.array_equal(flat(other, 'values'), flat(sequence, 'values'))
    assert base.observation_count == 9797                 # the input is not changed


# ---------------------------------------------------------------- DLR

@lru_cache(maxsize=None)
def dlr_source():
    folder = DATA / 'dlr_spatial_cognition'
    landmark = scipy.io.loadmat(folder / 'landmark.mat')['landmark']    # not squeezed
    ids = [landmark[0, k]['ID'].ravel().astype(int) for k in range(landmark.shape[1])]
    poses = scipy.io.loadmat(folder / 'truth.mat')['truth'][0, 0]['x'].T
    return ids, poses


def test_dlr_counts(sequences):
    ids, poses = dlr_source()
    sequence = sequences('dlr_spatial_cognition')
    assert len(sequence.steps) == len(ids) == len(poses) - 1
    assert sequence.observation_count == sum(len(i) for i in ids)
    every = np.concatenate(ids)
    truth, certain = flat(sequence, 'truth'), flat(sequence, 'truth_certain')
    assert np.array_equal(truth, every)
    assert np.sum(~certain) == np.sum(every == 23001) and np.all(truth[~certain] == 23001)
    assert np.sum(truth == CLUTTER) == 0
    assert sum(len(step.truth) == 0 for step in sequence.steps) == sum(len(i) == 0 for i in ids)
    assert sequence.true_landmarks is None


def project(values: np.ndarray, pose: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return values @ np.array([[c, s], [-s, c]]) + pose[:2]


def test_dlr_alignment_with_truth(sequences):
    _, poses = dlr_source()
    sequence = sequences('dlr_spatial_cognition')
    assert same_pose(sequence.initial_pose, poses[0], 1e-12)
    for k, step in enumerate(sequence.steps):
        assert same_pose(step.true_pose, poses[k + 1], 1e-9)
    truth = flat(sequence, 'truth')

    def spread(pose_of_step) -> np.ndarray:
        world = np.concatenate([project(step.values, pose_of_step(k))
                                for k, step in enumerate(sequence.steps)])
        distances = []
        for landmark in np.unique(truth):
            cluster = world[truth == landmark]
            distances.append(np.linalg.norm(cluster - np.median(cluster, axis=0), axis=1))
        return np.concatenate(distances)

    after = spread(lambda k: sequence.steps[k].true_pose)
    before = spread(lambda k: poses[k])
    assert np.median(after) < 0.06 and np.percentile(after, 99) < 0.5
    assert np.median(before) > 2 * np.median(after)
    # increment k = the truth's motion from pose k to k+1, to odometry accuracy (mm, sub-degree)
    for k in range(0, len(sequence.steps), 7):
        one = compose_path(poses[k], [sequence.steps[k].increment])[-1]
        assert same_pose(one, poses[k + 1], 0.08)
    errors = np.array([compose_path(poses[k], [step.increment])[-1] - poses[k + 1]
                       for k, step in enumerate(sequence.steps)])
    errors[:, 2] = wrap(errors[:, 2])
    assert np.all(errors.std(axis=0) < [0.01, 0.01, np.deg2rad(1.0)])


# ---------------------------------------------------------------- MRCLAM

def read_table(path: Path) -> list[list[str]]:
    return [line.split() for line in path.read_text().splitlines()
            if line.strip() and not line.lstrip().startswith('#')]


@lru_cache(maxsize=None)
def mrclam_source(robot: int = 1):
    folder = DATA / f'utias_mrclam_ds1_robot{robot}'
    subject = {int(b): int(s) for s, b in read_table(folder / 'Barcodes.dat')}
    measurements = read_table(folder / f'Robot{robot}_Measurement.dat')
    odometry = read_table(folder / f'Robot{robot}_Odometry.dat')
    ground = read_table(folder / 'Landmark_Groundtruth.dat')
    return subject, measurements, odometry, ground


def milliseconds(text: str) -> int:
    whole, _, fraction = text.partition('.')
    return int(whole) * 1000 + int((fraction + '000')[:3])


@pytest.mark.parametrize('robot', [1, 2])
def test_mrclam_counts(sequences, robot):
    subject, measurements, _, ground = mrclam_source(robot)
    sequence = sequences(f'mrclam_robot{robot}')
    stamps = sorted({milliseconds(row[0]) for row in measurements})
    assert len(sequence.steps) == len(stamps)
    assert [step.time_ns for step in sequence.steps] == [t * 1_000_000 for t in stamps]
    assert sequence.observation_count == len(measurements)
    subjects = [subject[int(row[1])] for row in measurements]
    truth = flat(sequence, 'truth')
    assert np.sum(truth == CLUTTER) == sum(1 <= s <= 5 for s in subjects)
    assert np.sum(truth >= 0) == sum(6 <= s <= 20 for s in subjects)
    for landmark in range(6, 21):
        assert np.sum(truth == landmark) == subjects.count(landmark)
    assert np.all(flat(sequence, 'truth_certain'))
    assert np.allclose(flat(sequence, 'values'), [[float(r[2]), float(r[3])] for r in measurements])
    assert sorted(sequence.true_landmarks) == [int(row[0]) for row in ground]
    for row in ground:                                     # rows as they are (11/17 not swapped)
        assert np.allclose(sequence.true_landmarks[int(row[0])], [float(row[1]), float(row[2])])
    assert np.all(sequence.initial_pose == 0) and np.all(sequence.initial_covariance == 0)


@pytest.mark.parametrize('robot', [1, 2])
def test_mrclam_increments_reproduce_dead_reckoning(sequences, robot):
    _, measurements, odometry, _ = mrclam_source(robot)
    sequence = sequences(f'mrclam_robot{robot}')
    scans = sorted({milliseconds(row[0]) for row in measurements})
    times = [milliseconds(row[0]) for row in odometry]
    commands = [(float(row[1]), float(row[2])) for row in odometry]
    # rows sharing a stamp hold for no time (robot 2 has 9): the last one of a stamp counts
    keep = [i for i in range(len(times)) if i + 1 == len(times) or times[i + 1] != times[i]]
    times, commands = [times[i] for i in keep], [commands[i] for i in keep]
    expected, travelled = exact_arcs(times, commands, scans)
    assert len(expected) == len(scans)
    path = compose_path(sequence.initial_pose, [step.increment for step in sequence.steps])
    assert same_pose(path[1:], np.array(expected), 1e-6)
    variances = np.array([step.increment_covariance[0, 0] for step in sequence.steps])
    assert np.isclose(variances.sum(), len(variances) * mrclam.POSITION_FLOOR
                      + mrclam.POSITION_PER_METRE * travelled[-1])


# ---------------------------------------------------------------- Victoria Park

@lru_cache(maxsize=None)
def victoria_source():
    records = read_table(DATA / 'victoria_park' / 'victoria_park_gtsam.txt')
    odometry = [(int(r[1]), int(r[2]), np.array(r[3:6], dtype=float),
                 np.array(r[6:12], dtype=float)) for r in records if r[0] == 'ODOMETRY']
    landmarks = [(int(r[1]), int(r[2]), np.array(r[3:5], dtype=float),
                  np.array(r[5:8], dtype=float)) for r in records if r[0] == 'LANDMARK']
    assert len(odometry) + len(landmarks) == len(records)
    return odometry, landmarks


def test_victoria_park_counts(sequences):
    odometry, landmarks = victoria_source()
    sequence = sequences('victoria_park')
    nodes = sorted({node for node, *_ in landmarks})
    assert len(sequence.steps) == len(nodes)
    assert sequence.observation_count == len(landmarks)
    truth = flat(sequence, 'truth')
    assert np.array_equal(truth, [landmark for _, landmark, *_ in landmarks])
    assert len(np.unique(truth)) == len({landmark for _, landmark, *_ in landmarks})
    assert np.all(flat(sequence, 'truth_certain')) and sequence.truth_is_reference
    assert np.allclose(flat(sequence, 'values'), [xy for _, _, xy, _ in landmarks])
    assert np.allclose(flat(sequence, 'covariances'), [[[c[0], c[1]], [c[1], c[2]]]
                                                       for *_, c in landmarks])
    assert sequence.true_landmarks is None


def test_victoria_park_increments_reproduce_odometry(sequences):
    odometry, landmarks = victoria_source()
    sequence = sequences('victoria_park')
    chain = [0] + [j for _, j, _, _ in odometry]
    assert [i for i, *_ in odometry] == chain[:-1]          # one chain, as the converter assumes
    raw = compose_path(np.zeros(3), [u for _, _, u, _ in odometry])
    pose_of = dict(zip(chain, raw))
    position = {node: k for k, node in enumerate(chain)}
    nodes = sorted({node for node, *_ in landmarks}, key=position.get)
    path = compose_path(sequence.initial_pose, [step.increment for step in sequence.steps])
    assert same_pose(path[1:], np.array([pose_of[n] for n in nodes]), 1e-6)
    assert [step.time_ns for step in sequence.steps] == [10**9 + position[n] * 10**8 for n in nodes]
    # first-order covariance of the longest step against a numerical Jacobian of the chain
    spans = np.diff([0] + [position[n] for n in nodes])
    k = int(np.argmax(spans))
    first = position[nodes[k]] - spans[k]
    records = odometry[first:first + spans[k]]
    increments = np.array([u for _, _, u, _ in records])

    def end(flat_increments):
        return compose_path(np.zeros(3), flat_increments.reshape(-1, 3))[-1]

    jacobian = np.empty((3, increments.size))
    for column in range(increments.size):
        delta = np.zeros(increments.size)
        delta[column] = 1e-6
        difference = end(increments.ravel() + delta) - end(increments.ravel() - delta)
        jacobian[:, column] = difference / 2e-6
    noise = np.zeros((increments.size, increments.size))
    for r, (*_, upper) in enumerate(records):
        xx, xy, xt, yy, yt, tt = upper
        noise[3 * r:3 * r + 3, 3 * r:3 * r + 3] = [[xx, xy, xt], [xy, yy, yt], [xt, yt, tt]]
    assert spans[k] > 3
    assert np.allclose(sequence.steps[k].increment_covariance, jacobian @ noise @ jacobian.T,
                       rtol=1e-5, atol=1e-12)


# ---------------------------------------------------------------- ACFR car park

@lru_cache(maxsize=None)
def acfr_source():
    folder = DATA / 'acfr_car_park'
    return scipy.io.loadmat(folder / 'data_set.mat'), scipy.io.loadmat(folder / 'beac_juan3.mat')


def test_acfr_beacon_detections_by_hand():
    """Reflective returns joined while consecutive ones are within 0.5 m, no-return ranges
    (81.9 m) ignored, dark returns ignored; mean range and bearing (beam i at i/2 - 90 deg)."""
    ranges = np.full(361, 30.0)
    intensities = np.zeros(361, dtype=np.uint16)
    ranges[[100, 101, 102, 106, 107]] = 5.0      # 4 beams = 2 deg = 0.17 m: one beacon
    intensities[[100, 101, 102, 106, 107]] = 8192
    ranges[[200, 201]] = [10.0, 10.2]            # 13.5 m further round: another one
    intensities[[200, 201]] = 16384
    ranges[300], intensities[300] = 81.9, 8192   # reflective but no return
    ranges[[180, 181]] = 20.0                    # a dark object
    found = acfr_car_park.beacon_detections(ranges, intensities)
    np.testing.assert_allclose(found, [[5.0, np.deg2rad(103.2 / 2 - 90)],
                                       [10.1, np.deg2rad(200.5 / 2 - 90)]])
    ranges[[106, 107]] = 5.6                     # 0.6 m behind: a second beacon
    found = acfr_car_park.beacon_detections(ranges, intensities)
    np.testing.assert_allclose(found[:2], [[5.0, np.deg2rad(50.5 - 90)],
                                           [5.6, np.deg2rad(53.25 - 90)]])
    assert acfr_car_park.beacon_detections(np.full(361, 81.9), np.ones(361)).shape == (0, 2)


def test_acfr_counts_and_truth(sequences):
    data, beacons = acfr_source()
    sequence = sequences('acfr_car_park')
    reflective = (data['Intensity'] > 0) & (data['Laser'] < 80)
    seen = reflective.any(axis=1)
    scan_ms = np.round(data['TimeLaser'][0] * 1000).astype(np.int64)[seen]
    assert [step.time_ns for step in sequence.steps] == [int(t) * 1_000_000 for t in scan_ms]
    assert len(sequence.steps) == int(seen.sum()) == 506
    counts = [len(step.truth) for step in sequence.steps]
    assert all(1 <= c <= n for c, n in zip(counts, reflective[seen].sum(axis=1)))
    truth, certain = flat(sequence, 'truth'), flat(sequence, 'truth_certain')
    assert sequence.true_landmarks.keys() == set(range(1, 16))
    for landmark, row in zip(range(1, 16), beacons['estbeac']):
        assert np.array_equal(sequence.true_landmarks[landmark], row)
    # nearly every detection lies on a surveyed beacon; a few are clutter or uncertain
    assert np.sum(certain & (truth > 0)) >= 0.99 * len(truth)
    assert np.sum(truth == CLUTTER) <= 5 and np.sum(~certain) <= 5
    # and no scan sees one beacon twice (a near beacon's runs are joined)
    for step in sequence.steps:
        labels = step.truth[step.truth > 0]
        assert len(labels) == len(set(labels.tolist()))


def test_acfr_increments_reproduce_the_car_model(sequences):
    """A plain loop over the 40 Hz samples: the rear axle's centre moves at v / (1 - tan(s) H
    / L) and turns at that over L times tan(s), exact arcs; the laser rides at (3.78, 0.5) m."""
    data, _ = acfr_source()
    sequence = sequences('acfr_car_park')
    times = [int(round(t * 1000)) for t in data['Time_VS'][0]]
    length, offset = 2.83, 0.76
    commands = []
    for v, s in zip(data['Velocity'][0], data['Steering'][0]):
        v_c = v / (1 - math.tan(s) * offset / length)
        commands.append((v_c, v_c * math.tan(s) / length))
    queries = [times[0]] + [step.time_ns // 1_000_000 for step in sequence.steps]
    axle, _ = exact_arcs(times, commands, queries)
    laser = [(x + 3.78 * math.cos(yaw) - 0.5 * math.sin(yaw),
              y + 3.78 * math.sin(yaw) + 0.5 * math.cos(yaw), yaw) for x, y, yaw in axle]
    assert len(laser) == len(queries)
    path = compose_path(sequence.initial_pose, [step.increment for step in sequence.steps])
    for k in range(1, len(laser)):
        assert same_pose(_between(path[0], path[k]), _between(laser[0], laser[k]), 1e-6), k


def _between(a, b) -> np.ndarray:
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]])


def test_acfr_true_heading_follows_the_gps_track_on_straights(sequences):
    """The true heading (odometry turned onto the GPS fixes) against the direction the GPS
    antenna moves while the car drives straight (|steering| < 0.02 rad, > 1 m/s)."""
    data, _ = acfr_source()
    sequence = sequences('acfr_car_park')
    gps_t = data['TimeGPS'][0]
    gps = np.column_stack([data['GPSLon'][0], data['GPSLat'][0]])
    checked = 0
    for step in sequence.steps:
        t = step.time_ns * 1e-9
        i = np.searchsorted(gps_t, t)
        if i < 1 or i + 1 >= len(gps_t):
            continue
        window = (data['Time_VS'][0] > t - 0.5) & (data['Time_VS'][0] < t + 0.5)
        if np.abs(data['Steering'][0][window]).max() > 0.02 or \
                data['Velocity'][0][window].min() < 1.0:
            continue
        direction = gps[i + 1] - gps[i - 1]
        error = wrap(math.atan2(direction[1], direction[0]) - step.true_pose[2])
        assert abs(error) < np.deg2rad(5), (t, np.rad2deg(error))
        checked += 1
    assert checked >= 10   # 14 such scans


@pytest.mark.parametrize('name', sorted(SEQUENCES))
def test_committed_bag_carries_the_sequence_truth(sequences, name):
    """The committed bag's /ground_truth/correspondences hold every step's labels and
    certainty (so its counts are the source files' counts checked above)."""
    from data_association_ros.bag.slam_eval import read_slam_truth
    sequence = sequences(name)
    truth = read_slam_truth(Path(__file__).resolve().parents[1] / 'bags' / name)
    assert len(truth.labels) == len(sequence.steps)
    stamps = sorted(truth.labels)
    assert stamps == [step.time_ns for step in sequence.steps]
    np.testing.assert_array_equal(np.concatenate([truth.labels[s] for s in stamps]),
                                  flat(sequence, 'truth'))
    np.testing.assert_array_equal(np.concatenate([truth.certain[s] for s in stamps]),
                                  flat(sequence, 'truth_certain'))
    assert len(truth.poses) == sum(step.true_pose is not None for step in sequence.steps)
    assert set(truth.landmarks) == set(sequence.true_landmarks or {})
