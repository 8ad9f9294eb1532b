"""The benchmark script runs (quick mode) and its comparisons hold: fast jcbb gives the reference
JCBB's answers, the compiled kernels those of numpy and the pure-Python search, the time budget
cuts a long search short.  Timings are not asserted."""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'benchmarks'))

import run_benchmarks  # noqa: E402


def rows_of(text: str, title: str) -> list[list[str]]:
    """The data rows of the markdown table under `title`."""
    block = text[text.index(title):].split('\n\n')[1]
    return [[c.strip() for c in line.strip('|').split('|')] for line in block.splitlines()[2:]]


def test_quick_benchmarks_agree_with_the_reference(tmp_path):
    assert run_benchmarks.main(['--quick', '--sections', 'jcbb,compiled,seed,budget',
                                '--out', str(tmp_path)]) == 0
    text = (tmp_path / 'benchmarks.md').read_text()
    assert re.search(r'\d+ cores', text)
    jcbb = rows_of(text, 'jcbb versus the reference JCBB')
    assert [r[0] for r in jcbb] == ['clutter_range_bearing', 'dense random']
    for row in jcbb:
        same, total = row[3].split('/')
        assert same == total == row[1]
    from data_association_ros.core.associators import jcbb_compiled
    if jcbb_compiled.available():
        compiled = rows_of(text, 'jcbb: compiled kernels (numba) versus numpy and the pure-Python')
        assert [r[0] for r in compiled] == ['clutter_range_bearing', 'dense random',
                                            'node_latency K=50 N=200']
        for row in compiled:
            same, total = row[3].split('/')
            assert same == total == row[1]
    budget_rows = rows_of(text, 'jcbb time_budget_ms')
    assert len(budget_rows) == 4
    for row in budget_rows:
        cut, repeats = row[3].split('/')
        assert cut == repeats


def test_node_latency_benchmark_answers_every_message_of_every_server():
    """benchmarks/node_latency.py (the servers run together, taking turns) on a few messages:
    the echo and association_node answer all of them (this run's domain, loopback)."""
    import os
    import subprocess
    environment = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
                   'PYTHONPATH': os.pathsep.join([str(ROOT), os.environ.get('PYTHONPATH', '')])}
    output = subprocess.run(
        [sys.executable, str(ROOT / 'benchmarks' / 'node_latency.py'), '--messages', '6',
         '--warmup', '1', '--algorithms', 'mahalanobis_nn'], env=environment,
        capture_output=True, text=True, timeout=180, check=True).stdout
    rows = {line[:26].strip(): line[26:].split() for line in output.splitlines()[2:]}
    assert set(rows) == {'bare rclpy echo', 'mahalanobis_nn'}, output
    assert all(row[0] == '6' for row in rows.values()), output


def test_mrclam_benchmark_removes_exactly_the_other_robots_sightings():
    """benchmarks/mrclam_other_robots.without_clutter on robot 1's first 300 scans: every scan
    keeps its header and its landmark sightings, in order, with every truth field, and loses
    every robot sighting."""
    import numpy as np
    from mrclam_other_robots import without_clutter
    from msg_adapters import cloud_to_array
    from data_association_ros.bag import topics
    from data_association_ros.bag.datasets.sequence import CLUTTER
    from data_association_ros.bag.slam_run import read_inputs
    messages = read_inputs(ROOT / 'bags' / 'mrclam_robot1', 300)
    kept = without_clutter(messages)
    assert [topic for topic, _ in kept] == [topic for topic, _ in messages]
    removed = scans = 0
    truth_of = {}
    for (topic, before), (_, after) in zip(messages, kept):
        if topic in (topics.GROUND_TRUTH, topics.SENSOR_OBSERVATIONS):
            assert after.header == before.header
        if topic == topics.GROUND_TRUTH:
            old = cloud_to_array(before)
            truth_of[(before.header.stamp.sec, before.header.stamp.nanosec)] = old['landmark']
            new = cloud_to_array(after)
            wanted = old[old['landmark'] != CLUTTER]
            assert new.dtype == old.dtype
            assert list(new['observation']) == list(range(len(new)))
            for name in old.dtype.names:
                if name != 'observation':
                    assert np.array_equal(new[name], wanted[name], equal_nan=True), name
            removed += int((old['landmark'] == CLUTTER).sum())
    for (topic, before), (_, after) in zip(messages, kept):
        if topic == topics.SENSOR_OBSERVATIONS:
            scans += 1
            labels = truth_of[(before.header.stamp.sec, before.header.stamp.nanosec)]
            old, new = cloud_to_array(before), cloud_to_array(after)
            assert new.dtype == old.dtype
            assert np.array_equal(new, old[labels != CLUTTER])
    assert scans == 300 and removed > 0


def _mrclam_rows(robot, kind):
    import numpy as np
    from data_association_ros.bag.datasets import DEFAULT_DATA_DIRECTORY
    folder = DEFAULT_DATA_DIRECTORY / f'utias_mrclam_ds1_robot{robot}'
    return np.loadtxt(folder / f'Robot{robot}_{kind}.dat', comments='#', ndmin=2).tolist()


def _mrclam_subjects(robot):
    from data_association_ros.bag.datasets import DEFAULT_DATA_DIRECTORY
    folder = DEFAULT_DATA_DIRECTORY / f'utias_mrclam_ds1_robot{robot}'
    pairs = [line.split() for line in (folder / 'Barcodes.dat').read_text().splitlines()
             if line.strip() and not line.startswith('#')]
    return {int(barcode): int(subject) for subject, barcode in pairs}


def test_mrclam_benchmark_motion_when_seen_against_a_loop_over_the_rows():
    """moving_when_seen for robots 1 and 2 against a plain loop: for each sighting, the seen
    robot's last odometry row at or before it (bisect) moving at 0.01 m/s or rad/s."""
    from bisect import bisect_right
    from mrclam_other_robots import MOVING, moving_when_seen
    for seer, seen in ((1, 2), (2, 1)):
        barcode = {s: b for b, s in _mrclam_subjects(seer).items()}[seen]
        odometry = _mrclam_rows(seen, 'Odometry')
        times = [row[0] for row in odometry]
        count = moving = 0
        for time, code, _, _ in _mrclam_rows(seer, 'Measurement'):
            if int(code) != barcode:
                continue
            count += 1
            _, v, w = odometry[max(bisect_right(times, time) - 1, 0)]
            moving += abs(v) >= MOVING or abs(w) >= MOVING
        assert moving_when_seen(seer, seen) == (count, moving)
        assert count > 200 and moving < count


def test_mrclam_benchmark_bursts_against_a_loop_over_the_sightings():
    """sighting_bursts for robots 1 and 2 (1 s pauses, sightings over 5 s into a burst) against a
    plain loop over each robot's sorted sightings; with no pause allowed every sighting is a
    burst of duration 0, with any pause allowed each robot seen is one burst."""
    import numpy as np
    from mrclam_other_robots import sighting_bursts
    for robot in (1, 2):
        subjects = _mrclam_subjects(robot)
        rows = _mrclam_rows(robot, 'Measurement')
        sightings = bursts = late = 0
        durations = []
        for seen in range(1, 6):
            times = sorted(r[0] for r in rows if subjects[int(r[1])] == seen)
            sightings += len(times)
            first = previous = None
            for time in times:
                if previous is None or time - previous > 1.0:
                    if first is not None:
                        durations.append(previous - first)
                    bursts += 1
                    first = time
                late += time - first > 5.0
                previous = time
            if first is not None:
                durations.append(previous - first)
        found = sighting_bursts(robot, 1.0, 5.0)
        assert found[:2] == (sightings, bursts) and found[3] == len(rows) and found[4] == late
        assert np.allclose(sorted(found[2]), sorted(durations))
        assert 0 < late < sightings - bursts
    sightings, bursts, durations, observations, _ = sighting_bursts(1, -1.0)
    assert (sightings, bursts, observations) == (952, 952, 5723)
    assert not durations.any()
    assert sighting_bursts(1, 1e9)[1] == 4 and sighting_bursts(2, 1e9)[1] == 4


def test_mrclam_benchmark_groups_wrong_pairs_into_bursts_by_hand():
    """wrong_bursts: scans with wrong pairs at most BURST_SCANS apart are one burst; after_gap:
    the time since the last gap's end (inf before the first)."""
    import math
    import numpy as np
    from mrclam_other_robots import BURST_SCANS, after_gap, wrong_bursts
    second = 1_000_000_000
    outcomes = {k * second: (0, 0) for k in range(100)}
    outcomes[3 * second] = (1, 0)
    outcomes[(3 + BURST_SCANS) * second] = (2, 1)
    outcomes[(4 + 2 * BURST_SCANS) * second] = (5, 0)
    bursts = wrong_bursts(outcomes)
    assert bursts == [(3, 3.0, 3), (4 + 2 * BURST_SCANS, 4.0 + 2 * BURST_SCANS, 5)]
    timed = after_gap(bursts, np.array([[10.0, 20.0]]))   # a gap from 10 s to 30 s
    assert math.isinf(timed[0][3]) and timed[1][3] == 4.0 + 2 * BURST_SCANS - 30.0


def test_mrclam_benchmark_places_paired_sightings_and_fits_their_drift_by_hand():
    """paired_positions: p + r (cos(yaw + b), sin(yaw + b)) per paired sighting, NEW and
    unassociated ones and scans without a pose left out; drift_speed: the slope of a straight
    line through exact linear motion, None below DRIFT_MIN_SIGHTINGS or DRIFT_MIN_SPAN_S."""
    import math
    import numpy as np
    from mrclam_other_robots import (DRIFT_MIN_SIGHTINGS, DRIFT_MIN_SPAN_S, drift_speed,
                                     paired_positions)
    from msg_adapters.pointcloud import array_to_cloud
    from std_msgs.msg import Header
    from builtin_interfaces.msg import Time
    from data_association_ros.bag import topics
    second = 1_000_000_000

    def scan(sec, ranges, bearings):
        cloud = array_to_cloud({'range': np.array(ranges, np.float32),
                                'bearing': np.array(bearings, np.float32)},
                               Header(stamp=Time(sec=sec), frame_id='base_link'))
        return topics.SENSOR_OBSERVATIONS, cloud
    messages = [scan(1, [2.0, 1.0, 3.0], [0.0, math.pi / 2, 0.5]), ('/odometry', None),
                scan(2, [4.0], [-math.pi / 2]), scan(3, [1.0], [0.0]), scan(4, [1.0], [0.0])]
    answers = {1 * second: np.array([7, -1, -2]), 2 * second: np.array([7]),
               3 * second: np.array([7])}      # scan 3 has no pose, scan 4 no answer
    poses = {1 * second: np.array([1.0, 2.0, math.pi / 2]), 2 * second: np.array([0.0, 0.0, 0.0]),
             4 * second: np.array([0.0, 0.0, 0.0])}
    found = paired_positions(messages, answers, poses)
    assert set(found) == {7}
    assert np.allclose(found[7], [[1.0, 1.0, 4.0], [2.0, 0.0, -4.0]], atol=1e-6)

    times = np.arange(DRIFT_MIN_SIGHTINGS + 1, dtype=float) * DRIFT_MIN_SPAN_S / DRIFT_MIN_SIGHTINGS
    track = np.c_[times + 100.0, 3.0 + 0.03 * times, -1.0 - 0.04 * times]
    assert math.isclose(drift_speed(track, 100.0, 1e9), 0.05)
    few = track[np.linspace(0, len(track) - 1, DRIFT_MIN_SIGHTINGS - 1).astype(int)]
    assert np.ptp(few[:, 0]) >= DRIFT_MIN_SPAN_S                             # spans enough
    assert drift_speed(few, 100.0, 1e9) is None                              # but too few
    dense = np.c_[100.0 + np.linspace(0.0, DRIFT_MIN_SPAN_S / 2, 2 * DRIFT_MIN_SIGHTINGS),
                  np.zeros(2 * DRIFT_MIN_SIGHTINGS), np.zeros(2 * DRIFT_MIN_SIGHTINGS)]
    assert drift_speed(dense, 100.0, 1e9) is None                            # too short a span
    assert drift_speed(track, 200.0, 1e9) is None                            # none in the window


def test_mrclam_benchmark_drift_splits_by_origin_and_counts_later_pairs(monkeypatch):
    """drift: a landmark started from a CLUTTER (robot) sighting goes to 'robot', one from a true
    landmark to 'landmark'; its speed over [origin, origin + window] and the pairs after it;
    landmarks with too few sightings or no identity are left out."""
    import math
    from types import SimpleNamespace
    import numpy as np
    import mrclam_other_robots as bench
    from data_association_ros.bag.datasets.sequence import CLUTTER
    second = 1_000_000_000
    tracks = {
        1: np.array([[10.0 + t, 0.1 * t, 0.0] for t in range(6)] + [[30.0, 9.0, 9.0]]),
        2: np.array([[10.0 + t, 0.0, 0.0] for t in range(6)] + [[40.0, 0.0, 0.0]] * 3),
        3: np.array([[10.0, 0.0, 0.0]]),
        4: np.array([[10.0 + t, 0.0, 0.0] for t in range(6)]),
    }
    identity = {1: (CLUTTER, 9 * second), 2: (5, 9 * second), 3: (6, 9 * second)}
    monkeypatch.setattr(bench, 'closed_loop', lambda robot: ([], SimpleNamespace(
        answers={}, poses={}), None))
    monkeypatch.setattr(bench, 'answer_identities', lambda run, truth: identity)
    monkeypatch.setattr(bench, 'paired_positions', lambda messages, answers, poses: tracks)
    found = bench.drift(1, 10.0)
    assert len(found['robot']) == 1 and len(found['landmark']) == 1
    speed, later = found['robot'][0]
    assert math.isclose(speed, 0.1) and later == 1
    speed, later = found['landmark'][0]
    assert speed == 0.0 and later == 3


def test_stop_and_go_benchmark_motions_and_speed_filter_by_hand():
    """benchmarks/lidar_stop_and_go: parked stands still; pulling_away stands for straight / 2
    and then reaches the speed drawn; braking drives at it for straight / 2 and then stops;
    at_speed leaves only the objects at or over the speed visible."""
    import numpy as np
    from lidar_stop_and_go import MOTIONS, at_speed
    from data_association_ros.bag.lidar_eval import Scan
    from data_association_ros.bag.lidar_random_scene import OBJECT_DTYPE
    start, speed, straight, turn = (1.0, 2.0, 0.5), 4.0, 2.0, 0.2
    speeds = {}
    for name, motion in MOTIONS.items():
        path = motion(np.random.default_rng(0), start, speed, straight, turn, 4.0)
        state = path.state(np.array([0.5, 0.9, 8.0]))
        speeds[name] = np.hypot(state[:, 3], state[:, 4])
        assert np.allclose(path.poses(np.array([0.0]))[0], start)
    assert np.allclose(speeds['parked'], 0.0)
    assert np.allclose(speeds['pulling_away'], [0.0, 0.0, speed])
    assert np.allclose(speeds['braking'], [speed, speed, 0.0])
    truth = np.zeros(3, dtype=OBJECT_DTYPE)
    truth['vx'], truth['vy'], truth['visible'] = [0.1, 3.0, 0.0], [0.0, 0.0, -2.0], 20
    kept = at_speed(Scan(0.0, np.zeros((0, 2)), truth), 2.0).truth['visible']
    assert kept.tolist() == [0, 20, 20] and truth['visible'].tolist() == [20, 20, 20]


OBJECT_HEADER = ('kind,lidar,seed,object,scans,coverage,position_rmse_m,heading_rmse_deg,'
                 'velocity_rmse_mps,id_switches,within_position,within_heading,within_velocity,'
                 'passes\n')


def object_csv(path: Path, rows: list[str]) -> Path:
    """A --objects CSV of `rows` ('kind,lidar,seed,object,position,passes': the rest filled)."""
    lines = []
    for row in rows:
        kind, lidar, seed, number, position, passes = row.split(',')
        lines.append(f'{kind},{lidar},{seed},{number},50,0.9,{position},1.0,0.2,0,1,1,1,{passes}')
    path.write_text(OBJECT_HEADER + '\n'.join(lines) + '\n')
    return path


def test_lidar_objects_counts_passes_per_set_of_seeds(tmp_path, capsys):
    """Seeds 100-105 in sets of 3: 100-102 has 3 of 4 objects passing (75 %, under 95 %),
    103-105 2 of 2; another LiDAR's rows are their own group."""
    import lidar_objects
    path = object_csv(tmp_path / 'a.csv', [
        'car_static,,100,1,0.1,1', 'car_static,,100,2,0.4,0', 'car_static,,102,1,0.1,1',
        'car_static,,102,3,0.1,1', 'car_static,,103,1,0.1,1', 'car_static,,105,2,0.1,1',
        'car_static,270_25hz,100,1,0.1,1'])
    sets = lidar_objects.seed_sets(lidar_objects.read_objects(path), 3)
    assert sets == {('car_static', ''): [(100, 102, 3, 4), (103, 105, 2, 2)],
                    ('car_static', '270_25hz'): [(100, 102, 1, 1)]}
    assert lidar_objects.main(['sets', str(path), '--size', '3']) == 0
    out = capsys.readouterr().out
    assert 'car_static: 5 / 6 (83.3 %), 1 of 2 sets of 3 seeds under 95 %' in out
    assert 'seeds 100-102: 3 / 4 (75.0 %)  <- under' in out


def test_lidar_objects_compares_two_runs_object_by_object(tmp_path):
    """Object 100/2 fixed, 101/1 broken, 101/2 failing and scored in the first run only
    (neither fixed nor broken, but moved), 100/1 the same: 3 moved of 4, passes 2 -> 2."""
    import lidar_objects
    before = lidar_objects.read_objects(object_csv(tmp_path / 'b.csv', [
        'car_moving,,100,1,0.1,1', 'car_moving,,100,2,0.4,0', 'car_moving,,101,1,0.1,1',
        'car_moving,,101,2,0.1,0']))
    after = lidar_objects.read_objects(object_csv(tmp_path / 'c.csv', [
        'car_moving,,100,1,0.1,1', 'car_moving,,100,2,0.2,1', 'car_moving,,101,1,0.35,0']))
    lines, moved, totals = lidar_objects.compare(before, after)
    assert [line.split(':')[0] for line in lines] == [
        'FIXED car_moving seed 100 object 2', 'BROKEN car_moving seed 101 object 1']
    backwards = lidar_objects.compare(after, before)[0]  # 101/2 scored in the second run only
    assert [line.split(':')[0] for line in backwards] == [
        'BROKEN car_moving seed 100 object 2', 'FIXED car_moving seed 101 object 1']
    new = lidar_objects.read_objects(object_csv(tmp_path / 'd.csv', ['race,,3,1,0.01,1']))
    only_new = lidar_objects.compare({}, new)  # scored and passing in one run only
    assert only_new == (['FIXED race seed 3 object 1: not scored -> position 0.010 m, heading '
                         '1.0 deg, velocity 0.20 m/s, id switches 0'], 1,
                        {('race', ''): [0, 1, 1]})
    assert lines[0].endswith('position 0.400 m, heading 1.0 deg, velocity 0.20 m/s, id '
                             'switches 0 -> position 0.200 m, heading 1.0 deg, velocity 0.20 '
                             'm/s, id switches 0')
    assert moved == 3
    assert totals == {('car_moving', ''): [2, 2, 4]}


def test_lidar_objects_refuses_a_file_that_is_no_objects_csv(tmp_path, capsys):
    """A missing file and a CSV without the --objects columns: one line, exit code 2."""
    import pytest

    import lidar_objects
    other = tmp_path / 'other.csv'
    other.write_text('kind,seed\ncar_static,1\n')
    short = object_csv(tmp_path / 'short.csv', ['car_static,,100,1,0.1,1'])
    short.write_text(short.read_text() + 'car_static,,101\n')
    twice = object_csv(tmp_path / 'twice.csv', ['race,,7,2,0.01,1', 'race,,7,2,0.01,1'])
    for arguments in (['sets', str(tmp_path / 'missing.csv')],
                      ['compare', str(other), str(other)], ['sets', str(short)],
                      ['compare', str(twice), str(short)]):
        with pytest.raises(SystemExit) as stopped:
            lidar_objects.main(arguments)
        assert stopped.value.code == 2
    errors = capsys.readouterr().err.splitlines()
    assert 'missing.csv' in errors[0] and 'No such file' in errors[0]
    assert errors[1].endswith('no column lidar, object, passes, position_rmse_m, '
                              'heading_rmse_deg, velocity_rmse_mps, id_switches (not a '
                              'da_lidar_eval --objects file)')
    assert 'short.csv, line 3: not a complete row of numbers' in errors[2]
    assert errors[3].endswith('twice.csv, line 3: seed 7 object 2 of race listed twice')
