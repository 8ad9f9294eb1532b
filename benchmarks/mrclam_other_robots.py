"""MRCLAM's sightings of the other robots: whether those robots were moving when seen, and the
closed loop a perfect rejection of them would give (docs/slam.md, "What MRCLAM needs").

    python benchmarks/mrclam_other_robots.py

1. Motion.  The data set has two robots' odometry (1 and 2), so each one's sightings of the other
   are checked against the seen robot's own odometry (MRCLAM logs the commanded velocities): its
   forward speed |v| and turn rate |w| at the sighting (the odometry row at or before it), and
   how far each robot gets in 10 s and 30 s (net displacement of its dead reckoning, over every
   window starting on a whole second).
   Bursts: one robot's sightings with no pause over BURST_GAPS_S s between them.  A front end that
   pairs every sighting of a burst after its first caps correct % at 100 (1 - in-burst
   sightings / observations).
2. Upper bound.  bags/mrclam_robot<n> run in the closed loop (`jcbb`, offline, the bag's
   parameters, then also without dropping) with every sighting of another robot (truth CLUTTER)
   removed from its scan: what the node pair gives if no robot ever became a landmark.  "all"
   scores the removed sightings as right (not paired), over all the bag's observations.  Where
   a run goes off: its bursts of wrong pairs (BURST_SCANS), the share of the wrong pairs in
   bursts that start within AFTER_GAP_S of the end of a gap of over GAP_S between landmark
   sightings, and the largest bursts (scan index, s after the first scan, wrong pairs, s since
   the last such gap ended).
3. Today's robot pairs.  The bag as it is (`jcbb`, closed loop, the bag's parameters): the other
   robots' sightings paired, how many with a landmark started from a robot sighting, and how
   long after that landmark's start those come.
4. Drift.  In that run, each landmark's paired sightings placed in the map frame with the
   filter's pose of their scan; the speed [m/s] of a least-squares line through their positions
   over the landmark's first DRIFT_WINDOWS_S (landmarks with DRIFT_MIN_SIGHTINGS sightings
   spanning DRIFT_MIN_SPAN_S s), for landmarks started from a robot and from a true landmark,
   with the pairs each gets after the window: whether a rule that removes a landmark shown to
   move could tell the two apart (DRIFT_CUT_MPS).
"""
from __future__ import annotations

import os
import random
import sys
from functools import lru_cache
from pathlib import Path
from typing import Optional

import numpy as np

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(60, 69)))

from msg_adapters import cloud_to_array  # noqa: E402
from msg_adapters.pointcloud import array_to_cloud  # noqa: E402
from data_association_ros.bag import topics  # noqa: E402
from data_association_ros.bag.datasets import DEFAULT_DATA_DIRECTORY  # noqa: E402
from data_association_ros.bag.datasets.dead_reckoning import (integrate_hold,  # noqa: E402
                                                             milliseconds)
from data_association_ros.bag.datasets.mrclam import (FIRST_LANDMARK_SUBJECT,  # noqa: E402
                                                      subjects_of)
from data_association_ros.bag.datasets.sequence import CLUTTER  # noqa: E402
from data_association_ros.bag.replay import bag_parameters  # noqa: E402
from data_association_ros.bag.slam_eval import (RMSE_EXCLUDE, read_slam_truth,  # noqa: E402
                                                slam_truth)
from data_association_ros.bag.slam_run import (bag_slam_parameters, read_inputs,  # noqa: E402
                                               run_offline)
from data_association_ros.bag.slam_scoring import (answer_identities, scan_outcomes,  # noqa: E402
                                                   score_run)
from data_association_ros.core.models import MODELS  # noqa: E402
from data_association_ros.pipelines.association import stamp_ns  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MOVING = 0.01
"""|v| [m/s] or |w| [rad/s] at or above this: the robot's odometry says it was moving."""
WINDOWS_S = (10, 30)
BURST_GAPS_S = (1.0, 2.0, 10.0)
EARLY_S = 5.0
"""The cap if only a burst's sightings in its first EARLY_S [s] were paired is printed too."""
GAP_S = 10.0
"""A gap [s] between two sightings longer than this is printed."""
AFTER_GAP_S = 5.0
"""A burst of wrong pairs starting at most this long [s] after a gap's end is counted as the
gap's."""
BURST_SCANS = 20
"""Wrong pairs at most this many scans apart are one burst."""
DRIFT_WINDOWS_S = (10.0, 5.0)
DRIFT_MIN_SIGHTINGS, DRIFT_MIN_SPAN_S = 4, 4.0
DRIFT_CUT_MPS = 0.03
RANGE_BEARING = MODELS['range_bearing']


def _folder(robot: int) -> Path:
    return DEFAULT_DATA_DIRECTORY / f'utias_mrclam_ds1_robot{robot}'


@lru_cache(maxsize=None)
def _rows(robot: int, kind: str) -> np.ndarray:
    """Robot<robot>_<kind>.dat's rows (read once; not to be modified)."""
    return np.loadtxt(_folder(robot) / f'Robot{robot}_{kind}.dat', comments='#', ndmin=2)


@lru_cache(maxsize=None)
def _subjects(robot: int) -> np.ndarray:
    """The subject of each of robot `robot`'s measurements (mrclam.subjects_of)."""
    return subjects_of(_folder(robot), _rows(robot, 'Measurement')[:, 1])


def moving_when_seen(seer: int, seen: int) -> tuple[int, int]:
    """(sightings of robot `seen` by robot `seer`, those at which `seen`'s odometry moves)."""
    times = seen_times(seer, seen)
    odometry = _rows(seen, 'Odometry')
    row = np.clip(np.searchsorted(odometry[:, 0], times, side='right') - 1, 0, None)
    moving = (np.abs(odometry[row, 1]) >= MOVING) | (np.abs(odometry[row, 2]) >= MOVING)
    return len(times), int(moving.sum())


def sighting_bursts(robot: int, pause_s: float, late_s: float = np.inf
                    ) -> tuple[int, int, np.ndarray, int, int]:
    """(robot sightings, bursts of them (module doc), burst durations [s], all observations,
    sightings more than late_s after their burst's first) of robot `robot`'s sightings of the
    other four robots."""
    measurements, subjects = _rows(robot, 'Measurement'), _subjects(robot)
    sightings, durations, late = 0, [], 0
    for subject in range(1, FIRST_LANDMARK_SUBJECT):
        times = np.sort(measurements[subjects == subject, 0])
        if not len(times):
            continue
        sightings += len(times)
        breaks = np.flatnonzero(np.diff(times) > pause_s)
        starts = np.concatenate([[0], breaks + 1])
        ends = np.concatenate([breaks, [len(times) - 1]])
        durations.extend(times[ends] - times[starts])
        late += int((times - np.repeat(times[starts], ends - starts + 1) > late_s).sum())
    return sightings, len(durations), np.array(durations), len(measurements), late


def seen_times(seer: int, seen: int) -> np.ndarray:
    """Times [s] of robot `seer`'s sightings of robot `seen`."""
    return _rows(seer, 'Measurement')[_subjects(seer) == seen, 0]


def mean_speed(robot: int) -> float:
    """Time-weighted mean |v| [m/s] of the robot's odometry (each row held until the next)."""
    odometry = _rows(robot, 'Odometry')
    return float(np.average(np.abs(odometry[:-1, 1]), weights=np.diff(odometry[:, 0])))


def displacements(robot: int, window_s: int) -> np.ndarray:
    """Net displacement [m] of the robot's dead reckoning (dead_reckoning.integrate_hold, as the
    bags' converter) over each `window_s` [whole s] window starting on a whole second."""
    odometry = _rows(robot, 'Odometry')
    odometry_ms = milliseconds(odometry[:, 0])
    seconds = np.arange(odometry_ms[0], odometry_ms[-1] + 1, 1000)
    positions = integrate_hold(odometry_ms, odometry[:, 1], odometry[:, 2], seconds)[0][:, :2]
    return np.hypot(*(positions[window_s:] - positions[:-window_s]).T)


def without_clutter(messages: list) -> list:
    """The bag's messages with every observation whose true label is CLUTTER removed from its
    scan and from the scan's truth (re-numbered)."""
    keep_of = {}
    for topic, msg in messages:
        if topic == topics.GROUND_TRUTH:
            keep_of[stamp_ns(msg.header)] = cloud_to_array(msg)['landmark'] != CLUTTER
    out = []
    for topic, msg in messages:
        if topic in (topics.SENSOR_OBSERVATIONS, topics.GROUND_TRUTH):
            points = cloud_to_array(msg)[keep_of[stamp_ns(msg.header)]].copy()
            if topic == topics.GROUND_TRUTH:
                points['observation'] = np.arange(len(points))
            msg = array_to_cloud(points, msg.header)
        out.append((topic, msg))
    return out


def gaps(times: np.ndarray) -> np.ndarray:
    """(start, length) [s] of the gaps over GAP_S between the sighting times (n,) [s]."""
    times = np.unique(times)
    step = np.diff(times)
    long = step > GAP_S
    return np.column_stack([times[:-1][long], step[long]])


def sighting_times(robot: int, landmarks_only: bool) -> np.ndarray:
    """Times [s after the first measurement] of robot `robot`'s sightings (of landmarks only)."""
    measurements = _rows(robot, 'Measurement')
    times = measurements[:, 0] - measurements[0, 0]
    return times[_subjects(robot) >= FIRST_LANDMARK_SUBJECT] if landmarks_only else times


def wrong_bursts(outcomes: dict[int, tuple[int, int]]) -> list[tuple[int, float, int]]:
    """(scan index, s after the first scan, wrong pairs) of each burst of scans with wrong
    pairs (BURST_SCANS)."""
    stamps = sorted(outcomes)
    bursts: list[list] = []
    for index, stamp in enumerate(stamps):
        wrong = outcomes[stamp][0]
        if not wrong:
            continue
        if bursts and index - bursts[-1][3] <= BURST_SCANS:
            bursts[-1][2] += wrong
            bursts[-1][3] = index
        else:
            bursts.append([index, (stamp - stamps[0]) / 1e9, wrong, index])
    return [(index, seconds, wrong) for index, seconds, wrong, _ in bursts]


def after_gap(bursts: list[tuple[int, float, int]], gap_list: np.ndarray
              ) -> list[tuple[int, float, int, float]]:
    """The bursts with the time [s] since the end of the last gap (gaps: (start, length) in
    the bursts' time; inf before the first)."""
    ends = gap_list[:, 0] + gap_list[:, 1] if len(gap_list) else np.zeros(0)
    out = []
    for index, seconds, wrong in bursts:
        before = ends[ends <= seconds + 1e-6]
        out.append((index, seconds, wrong,
                    max(0.0, seconds - before[-1]) if len(before) else np.inf))
    return out


def upper_bound(robot: int, slam_overrides: dict) -> tuple[dict, float, list]:
    """(score row without the other robots' sightings, correct % over all observations, the
    bursts of wrong pairs with the time since the last gap between landmark sightings)."""
    bag = ROOT / 'bags' / f'mrclam_robot{robot}'
    messages = read_inputs(bag)
    observations = sum(int(c.sum()) for c in slam_truth(messages).certain.values())
    kept = without_clutter(messages)
    run = run_offline(kept, 'jcbb', 'node', bag_parameters(bag),
                      {**bag_slam_parameters(bag), **slam_overrides})
    truth = slam_truth(kept)
    row = score_run(run, truth, RMSE_EXCLUDE.get(bag.name, ()))
    scored = sum(int(c.sum()) for c in truth.certain.values())
    correct_all = (row['correct_percent'] * scored / 100 + observations - scored) / observations
    bursts = wrong_bursts(scan_outcomes(run, truth))
    return row, 100 * correct_all, after_gap(bursts, gaps(sighting_times(robot, True)))


@lru_cache(maxsize=None)
def closed_loop(robot: int) -> tuple:
    """(messages, run, truth) of the bag's closed loop (`jcbb`, offline, the bag's set; cached:
    not to be modified)."""
    bag = ROOT / 'bags' / f'mrclam_robot{robot}'
    messages = read_inputs(bag)
    run = run_offline(messages, 'jcbb', 'node', bag_parameters(bag), bag_slam_parameters(bag))
    return messages, run, read_slam_truth(bag)


def robot_pairs(robot: int) -> tuple[int, int, np.ndarray]:
    """(robot sightings paired, those paired with a landmark started from a robot sighting, the
    time [s] from that landmark's start to each of those pairs) of the bag's closed loop."""
    _, run, truth = closed_loop(robot)
    identity = answer_identities(run, truth)
    paired = robot_started = 0
    ages = []
    for stamp, labels in truth.labels.items():
        for answer, label in zip(run.answers[stamp], labels):
            if answer >= 0 and label == CLUTTER:
                origin_label, origin_stamp = identity[int(answer)]
                paired += 1
                if origin_label == CLUTTER:
                    robot_started += 1
                    ages.append((stamp - origin_stamp) / 1e9)
    return paired, robot_started, np.array(ages)


def paired_positions(messages: list, answers: dict[int, np.ndarray],
                     poses: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    """Landmark id -> (n, 3) [t s, x, y] of the range-bearing sightings paired with it, placed
    in the map frame with the pose (x, y, yaw) of their scan by the range-bearing model's
    inverse (p + r (cos(yaw + b), sin(yaw + b))).  Scans without an answer or a pose are left
    out."""
    found: dict[int, list] = {}
    for topic, msg in messages:
        if topic != topics.SENSOR_OBSERVATIONS:
            continue
        stamp = stamp_ns(msg.header)
        if stamp not in answers or stamp not in poses:
            continue
        points = cloud_to_array(msg)
        positions, _ = RANGE_BEARING.in_map(
            np.c_[points['range'], points['bearing']].astype(float), None, poses[stamp], None)
        for answer, (x, y) in zip(answers[stamp], positions):
            if answer >= 0:
                found.setdefault(int(answer), []).append((stamp / 1e9, x, y))
    return {landmark: np.array(rows) for landmark, rows in found.items()}


def drift_speed(track: np.ndarray, start_s: float, window_s: float) -> Optional[float]:
    """Speed [m/s] of the least-squares line x(t), y(t) through the rows [t, x, y] of `track`
    with start_s <= t <= start_s + window_s; None with fewer than DRIFT_MIN_SIGHTINGS rows or a
    span under DRIFT_MIN_SPAN_S."""
    rows = track[(track[:, 0] >= start_s) & (track[:, 0] <= start_s + window_s)]
    if len(rows) < DRIFT_MIN_SIGHTINGS or np.ptp(rows[:, 0]) < DRIFT_MIN_SPAN_S:
        return None
    slopes = np.polyfit(rows[:, 0] - rows[0, 0], rows[:, 1:], 1)[0]
    return float(np.hypot(*slopes))


def drift(robot: int, window_s: float) -> dict[str, list[tuple[float, int]]]:
    """'robot' / 'landmark' (what the landmark was started from: 'robot' for a CLUTTER
    origin, another robot's sighting or one the truth does not know) -> (drift speed over its
    first window_s, pairs after the window) per landmark of the bag's closed loop."""
    messages, run, truth = closed_loop(robot)
    identity = answer_identities(run, truth)
    out: dict[str, list[tuple[float, int]]] = {'robot': [], 'landmark': []}
    for landmark, track in paired_positions(messages, run.answers, run.poses).items():
        if landmark not in identity:
            continue
        label, origin = identity[landmark]
        speed = drift_speed(track, origin / 1e9, window_s)
        if speed is not None:
            later = int((track[:, 0] > origin / 1e9 + window_s).sum())
            out['robot' if label == CLUTTER else 'landmark'].append((speed, later))
    return out


def main() -> int:
    for seer, seen in ((1, 2), (2, 1)):
        count, moving = moving_when_seen(seer, seen)
        print(f'robot {seer} sees robot {seen} {count} times (median pause '
              f'{np.median(np.diff(np.unique(seen_times(seer, seen)))):.2f} s); robot {seen}\'s '
              f'odometry moves (|v| or |w| >= {MOVING}) at {moving} of them '
              f'({100 * moving / count:.1f} %)')
    for robot in (1, 2):
        for pause in BURST_GAPS_S:
            sightings, bursts, durations, observations, late = sighting_bursts(
                robot, pause, EARLY_S)
            cap = 100 * (1 - (sightings - bursts) / observations)
            early_cap = 100 * (1 - (sightings - bursts - late) / observations)
            print(f'robot {robot}: {sightings} sightings of other robots in {bursts} bursts '
                  f'(pauses <= {pause:.0f} s; duration median {np.median(durations):.1f} s, '
                  f'90 % {np.percentile(durations, 90):.1f} s, longest '
                  f'{durations.max():.1f} s); pairing all but the first of each burst caps '
                  f'correct at {cap:.1f} %, only those in its first {EARLY_S:.0f} s at '
                  f'{early_cap:.1f} %')
        print(f'robot {robot}: mean forward speed {mean_speed(robot):.3f} m/s')
        for window in WINDOWS_S:
            moved = displacements(robot, window)
            print(f'robot {robot} moves {np.median(moved):.2f} m (median; 10 %: '
                  f'{np.percentile(moved, 10):.2f} m) in {window} s')
        for landmarks_only, what in ((False, 'a sighting'), (True, 'a landmark sighting')):
            found = gaps(sighting_times(robot, landmarks_only))
            print(f'robot {robot}: {len(found)} gaps over {GAP_S:.0f} s without {what} '
                  '(start s, length s): '
                  + ', '.join(f'{start:.1f} {length:.1f}' for start, length in found))
    print('closed loop (jcbb) with the other robots\' sightings removed:')
    for robot in (1, 2):
        for label, overrides in (('the bag\'s set', {}), ('no dropping', {'drop_misses': 0})):
            row, correct_all, bursts = upper_bound(robot, overrides)
            print(f'  mrclam_robot{robot}, {label}: {row["correct_percent"]:.2f} % correct of '
                  f'the landmark sightings (wrong {row["wrong_percent"]:.2f}, missed '
                  f'{row["missed_percent"]:.2f}), all {correct_all:.2f} %; map '
                  f'{row["landmarks"]}, duplicates {row["landmarks_duplicate"]}, false '
                  f'{row["landmarks_false"]}')
            wrong = sum(w for _, _, w, _ in bursts)
            at_gaps = sum(w for _, _, w, since in bursts if since <= AFTER_GAP_S)
            largest = sorted(bursts, key=lambda b: -b[2])[:6]
            print(f'    {wrong} wrong pairs, {at_gaps} ({100 * at_gaps / max(wrong, 1):.0f} %) in '
                  f'bursts starting within {AFTER_GAP_S:.0f} s of a gap\'s end; largest bursts '
                  '(scan, s, pairs, s after a gap): '
                  + ', '.join(f'{i} {t:.1f} {w} {since:.1f}' for i, t, w, since in largest))
    for robot in (1, 2):
        paired, robot_started, ages = robot_pairs(robot)
        print(f'mrclam_robot{robot} as it is: {paired} robot sightings paired, '
              f'{robot_started} with a landmark started from a robot, those '
              f'{np.median(ages):.1f} s after that landmark\'s start (median; 90 %: '
              f'{np.percentile(ages, 90):.1f} s)')
    for robot in (1, 2):
        for window in DRIFT_WINDOWS_S:
            for kind, rows in drift(robot, window).items():
                if not rows:
                    print(f'mrclam_robot{robot}, landmarks started from a {kind}, first '
                          f'{window:.0f} s: none')
                    continue
                speeds = np.array([speed for speed, _ in rows])
                later = np.array([count for _, count in rows])
                fast = speeds > DRIFT_CUT_MPS
                print(f'mrclam_robot{robot}, landmarks started from a {kind}, first {window:.0f} '
                      f's: {len(rows)}, drift {np.median(speeds):.3f} m/s (median; 90 %: '
                      f'{np.percentile(speeds, 90):.3f}), {later.sum()} pairs after; over '
                      f'{DRIFT_CUT_MPS} m/s: {fast.sum()} with {later[fast].sum()} later pairs')
    return 0


if __name__ == '__main__':
    sys.exit(main())
