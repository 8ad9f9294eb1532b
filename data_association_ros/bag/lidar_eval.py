"""da_lidar_eval: the LiDAR object tracker (seed 003) on a LiDAR bag, or on generated scenes,
scored against the truth.

    da_lidar_eval [BAG] [--rows default,nearest,polar,...] [--first 0] [--repeat 1] [--live]
                  [--paced] [-p name=value ...]
    da_lidar_eval --scenes car_static,car_moving,f1tenth_static,f1tenth_moving,race
                  [--seeds 100-129] [--lidar 360_10hz] [--jobs 2] [--objects OUT.csv]
                  [-p name=value ...]

Runs the core tracker offline over /scan (sensor_msgs/LaserScan) with the bag's /odometry if any
(pipelines.lidar_tracking), once per row (a row = the default parameters with some changed), and
prints a Markdown table.  --live also sends the bag's odometry and scans to a lidar_tracker_node
over real DDS (loopback, own domain; each scan once the previous one's `tracks` arrived) and
scores those `tracks` (the same numbers as offline, or a bug); --paced plays them at the bag's
own rate and reports the node's step times and the scans it tracked.  --scenes: generated
scenes (bag.lidar_random_scene) of each kind over the seeds, summarised per kind
(bag.lidar_seeds: median and worst object); --objects writes every object's scores to a CSV
file; --jobs runs the seeds on several processes.

Scores, per object (the truth on /ground_truth/objects, in the tracks' frame, matched to a scan
by header stamp): in each scan from --first on, the reported tracks are paired with the true
objects by the Hungarian method on centre distance (pairs farther than 2.5 m, or 0.55 of the
object's length when the truth gives it, are not pairs); over the scans where the object is
visible (at least MIN_VISIBLE_BEAMS beams hit it, when the truth says): position RMSE [m] of the
rectangle centre, heading RMSE [deg] (yaw error wrapped to (-180, 180]), velocity RMSE [m/s]
(norm of the vector error), over those scans where the object has a pair; coverage = the share
of those scans with a pair; id switches = the times the paired track id changes.  Time per
scan: the tracking step only (clustering, association, update), median and 95th percentile
[ms], one core.
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Iterable, Optional, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..core.errors import InvalidInputError
from ..core.lidar import TrackerConfig
from ..pipelines.lidar_tracking import LidarTracking
from .reader import BagError, BagReader

BAG = Path(__file__).resolve().parents[2] / 'bags' / 'lidar_two_cars'
SCAN, OBJECTS, ODOMETRY = '/scan', '/ground_truth/objects', '/odometry'
PAIR_DISTANCE = 2.5
"""Largest centre distance [m] of a (track, true object) pair when the truth has no length."""
PAIR_SHARE = 0.55
"""... else this share of the object's length (2.5 m for a 4.5 m car, 0.3 m for an F1Tenth
car)."""
MIN_VISIBLE_BEAMS = 5
"""An object is visible in a scan when at least this many beams hit it (truth `visible`)."""
ROWS = {
    'default': ('jcbb_points, cartesian jNIS, point_to_line', {}),
    'nearest': ('nearest (cut-off 0.3 m), point_to_line', {'fine': 'nearest'}),
    'polar': ('jcbb_points, polar jNIS, point_to_line', {'jnis': 'polar'}),
    'kabsch': ('jcbb_points, cartesian jNIS, kabsch', {'transform': 'kabsch'}),
    'nearest_kabsch': ('nearest (cut-off 0.3 m), kabsch', {'fine': 'nearest',
                                                           'transform': 'kabsch'}),
    'polar_kabsch': ('jcbb_points, polar jNIS, kabsch', {'jnis': 'polar', 'transform': 'kabsch'}),
    'ransac': ('jcbb_points, cartesian jNIS, ransac', {'transform': 'ransac'}),
    'velocity': ('jcbb_points, cartesian jNIS, point_to_line, velocity measured (seed)',
                 {'velocity_measurement': True}),
    'seed': ('jcbb_points, cartesian jNIS, kabsch, velocity measured (seed)',
             {'transform': 'kabsch', 'velocity_measurement': True}),
}
"""Row name -> (label, parameters changed from the defaults)."""


@dataclass
class Scan:
    """One scan: time [s] (its header stamp), points (K, 2) in the sensor frame, truth
    (structured: id, x, y, yaw, vx, vy, ... [, visible]), time between beams [s], the odometry
    (time [s], pose (3,), frame) that arrived since the previous scan, the scan's frame, the
    sensor's range_max [m] (None: unknown), whether it is a 360 deg scan (msg_adapters.lidar.
    full_turn_of)."""

    time: float
    points: np.ndarray
    truth: np.ndarray
    time_increment: float = 0.0
    odometry: list = field(default_factory=list)
    frame: str = 'laser'
    max_range: Optional[float] = None
    full_turn: bool = False


@dataclass
class Estimate:
    """The reported tracks of one scan: ids (n,), states (n, 6)."""

    ids: np.ndarray
    states: np.ndarray


@dataclass
class ObjectScore:
    """Scores of one true object over the scans where it is visible."""

    position_rmse: float
    heading_rmse_deg: float
    velocity_rmse: float
    coverage: float
    id_switches: int
    track_ids: list = field(default_factory=list)
    scans: int = 0


def scan_points(ranges: np.ndarray, angle_min: float, angle_increment: float) -> np.ndarray:
    """(K, 2) points of a scan's ranges; non-finite ranges give non-finite points."""
    ranges = np.asarray(ranges, dtype=float)
    angles = angle_min + angle_increment * np.arange(len(ranges))
    with np.errstate(invalid='ignore'):
        return np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])


def stamp_seconds(msg) -> float:
    """A message's header stamp [s]."""
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def stamp_ns(msg) -> int:
    """A message's header stamp [ns]."""
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def scans_from_messages(messages: Iterable[tuple[str, object, int]]) -> list[Scan]:
    """Scans with the truth of the same header stamp (scans without one are left out), and the
    odometry between them, from (topic, message, log time ns) in log-time order."""
    from msg_adapters import cloud_to_array, pose_from_odometry
    scans: dict[int, Scan] = {}
    truths: dict[int, np.ndarray] = {}
    odometry: list = []
    for topic, msg, _ in messages:
        if topic == SCAN:
            from msg_adapters.lidar import full_turn_of, points_from_scan, range_max_of
            scans[stamp_ns(msg)] = Scan(stamp_seconds(msg), points_from_scan(msg), None,
                                        float(msg.time_increment), odometry,
                                        msg.header.frame_id, range_max_of(msg),
                                        full_turn_of(msg))
            odometry = []
        elif topic == OBJECTS:
            truths[stamp_ns(msg)] = cloud_to_array(msg)
        elif topic == ODOMETRY:
            odometry.append((stamp_seconds(msg), pose_from_odometry(msg).mean,
                             msg.header.frame_id))
    result, carried = [], []
    for stamp in sorted(scans):
        scan = scans[stamp]
        scan.odometry = carried + scan.odometry
        if stamp in truths:
            scan.truth, carried = truths[stamp], []
            result.append(scan)
        else:
            carried = scan.odometry
    return result


def read_scans(bag: Path) -> list[Scan]:
    """The bag's scans with the truth of the same header stamp (scans_from_messages)."""
    reader = BagReader(bag)
    reader.require([SCAN, OBJECTS])
    topics = [SCAN, OBJECTS] + ([ODOMETRY] if ODOMETRY in reader.topics else [])
    return scans_from_messages((m.topic, m.msg, m.log_time_ns)
                               for m in reader.messages(topics))


def run_offline(scans: Sequence[Scan], config: TrackerConfig) -> tuple[list[Estimate], np.ndarray]:
    """(reported tracks per scan, time per scan [ms]) of the core tracker with the scans'
    odometry (pipelines.lidar_tracking); the time covers the tracking step only."""
    tracking = LidarTracking(config)
    estimates, elapsed = [], []
    for scan in scans:
        for time_s, pose, frame in scan.odometry:
            tracking.add_odometry(time_s, pose, frame)
        started = time.perf_counter()
        reported = tracking.step(scan.points, scan.time, scan.time_increment, scan.frame,
                                 scan.max_range, scan.full_turn)
        elapsed.append((time.perf_counter() - started) * 1000.0)
        estimates.append(Estimate(np.array([t.id for t in reported], dtype=int),
                                  np.array([t.filter.x for t in reported]).reshape(-1, 6)))
    return estimates, np.array(elapsed)


def pair_distances(truth: np.ndarray) -> np.ndarray:
    """Largest centre distance [m] of a pair per true object: PAIR_DISTANCE, or PAIR_SHARE of
    its length when the truth gives lengths (small objects)."""
    if 'length' in (truth.dtype.names or ()):
        return PAIR_SHARE * truth['length'].astype(float)
    return np.full(len(truth), PAIR_DISTANCE)


def visible(truth: np.ndarray) -> np.ndarray:
    """(n,) bool: the objects seen by at least MIN_VISIBLE_BEAMS beams of the scan (all of them
    when the truth does not say)."""
    if 'visible' in (truth.dtype.names or ()):
        return truth['visible'] >= MIN_VISIBLE_BEAMS
    return np.ones(len(truth), dtype=bool)


def score(scans: Sequence[Scan], estimates: Sequence[Estimate],
          first: int = 0) -> dict[int, ObjectScore]:
    """Per true object id, its ObjectScore over the scans of scans[first:] where it is visible
    (module docstring)."""
    errors: dict[int, list] = {}
    ids: dict[int, list] = {}
    counted: dict[int, int] = {}
    for scan, estimate in list(zip(scans, estimates))[first:]:
        truth = scan.truth
        seen = visible(truth)
        for object_id in truth['id'][seen]:
            errors.setdefault(int(object_id), [])
            ids.setdefault(int(object_id), [])
            counted[int(object_id)] = counted.get(int(object_id), 0) + 1
        if not len(estimate.ids) or not len(truth):
            continue
        true_xy = np.column_stack([truth['x'], truth['y']]).astype(float)
        difference = true_xy[:, None, :] - estimate.states[None, :, :2]
        distance = np.hypot(difference[..., 0], difference[..., 1])
        limit = pair_distances(truth)[:, None]
        rows, columns = linear_sum_assignment(np.where(distance <= limit, distance, 1e6))
        for row, column in zip(rows, columns):
            if distance[row, column] > limit[row, 0] or not seen[row]:
                continue
            state, true = estimate.states[column], truth[row]
            heading = np.angle(np.exp(1j * (state[2] - float(true['yaw']))))
            velocity = np.hypot(state[3] - float(true['vx']), state[4] - float(true['vy']))
            errors[int(true['id'])].append((distance[row, column], heading, velocity))
            ids[int(true['id'])].append(int(estimate.ids[column]))
    result = {}
    for object_id, rows in errors.items():
        array = np.array(rows).reshape(-1, 3)
        rmse = np.sqrt(np.mean(array ** 2, axis=0)) if len(array) else np.full(3, np.nan)
        track_ids = ids[object_id]
        switches = int(sum(a != b for a, b in zip(track_ids, track_ids[1:])))
        result[object_id] = ObjectScore(float(rmse[0]), float(np.degrees(rmse[1])),
                                        float(rmse[2]), len(array) / max(counted[object_id], 1),
                                        switches, sorted(set(track_ids)), counted[object_id])
    return result


def estimate_from_tracks(msg) -> Estimate:
    """An Estimate from a `tracks` PointCloud2 (msg_adapters.lidar.TRACK_DTYPE)."""
    from msg_adapters import cloud_to_array
    array = cloud_to_array(msg)
    states = np.column_stack([array[name].astype(float) for name in
                              ('x', 'y', 'yaw', 'vx', 'vy', 'yaw_rate')]).reshape(-1, 6)
    return Estimate(array['id'].astype(int), states)


@dataclass
class LiveRun:
    """A bag through lidar_tracker_node: reported tracks per scan of the bag (matched by stamp;
    none for a scan the node dropped), the node's step times [ms], scans it tracked and dropped,
    the tracks' frame."""

    estimates: list
    replies: int
    step_ms: np.ndarray
    scans: int
    dropped: int
    frame: str


def run_live(bag: Path, config: TrackerConfig, timeout: float = 10.0,
             paced: bool = False) -> LiveRun:
    """The bag's /odometry and /scan through a lidar_tracker_node (parameters = config) over
    DDS.  Lock-step (default): each scan once the previous one's `tracks` arrived.  paced: every
    message at its log time (real time, as a sensor would), then all replies awaited.
    RuntimeError when a reply does not come."""
    from nav_msgs.msg import Odometry
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import LaserScan, PointCloud2

    from ..nodes.lidar_tracker_node import LidarTrackerNode
    from .ros_environment import close_graph, open_graph
    context, player, executor = open_graph('da_lidar_eval')
    reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    overrides = [Parameter(name, value=getattr(config, name)) for name in
                 config.__dataclass_fields__] + [Parameter('input_qos', value='reliable')]
    node = LidarTrackerNode(context=context, parameter_overrides=overrides)
    executor.add_node(node)
    try:
        reader = BagReader(bag)
        topics = [SCAN] + ([ODOMETRY] if ODOMETRY in reader.topics else [])
        publishers = {SCAN: player.create_publisher(LaserScan, 'scan', reliable),
                      ODOMETRY: player.create_publisher(Odometry, 'odometry', reliable)}
        replies: list = []
        player.create_subscription(PointCloud2, 'tracks', replies.append, reliable)

        def spin_until(condition, limit: float = timeout) -> None:
            deadline = time.monotonic() + limit
            while not condition():
                if time.monotonic() > deadline:
                    raise RuntimeError('lidar_tracker_node did not answer in time')
                executor.spin_once(timeout_sec=0.001)
        spin_until(lambda: publishers[SCAN].get_subscription_count() > 0
                   and player.count_publishers('tracks') > 0)
        messages = list(reader.messages(topics))
        sent = odometry = 0
        start_wall, start_log = time.monotonic(), messages[0].log_time_ns if messages else 0
        for message in messages:
            if paced:
                due = start_wall + (message.log_time_ns - start_log) * 1e-9
                while time.monotonic() < due:
                    executor.spin_once(timeout_sec=max(0.0, min(0.001, due - time.monotonic())))
            publishers[message.topic].publish(message.msg)
            if message.topic == SCAN:
                sent += 1
                if not paced:  # answered, or kept until the odometry of its time came
                    spin_until(lambda: len(replies) + node.invalid + len(node.waiting) >= sent)
            elif not paced:  # lock-step: the node has each pose before the next scan
                odometry += 1
                spin_until(lambda: node.odometry_count + node.invalid_odometry >= odometry)
        spin_until(lambda: len(replies) + node.invalid >= sent, limit=timeout + sent * 0.1)
        by_stamp = {stamp_ns(msg): estimate_from_tracks(msg) for msg in replies}
        empty = Estimate(np.zeros(0, dtype=int), np.zeros((0, 6)))
        estimates = [by_stamp.get(stamp_ns(m.msg), empty) for m in messages if m.topic == SCAN]
        return LiveRun(estimates, len(replies), np.array(node.step_ms), node.scans, node.invalid,
                       replies[-1].header.frame_id if replies else '')
    finally:
        executor.remove_node(node)
        node.destroy_node()
        close_graph(context, player, executor)


def number(value: float, digits: int) -> str:
    """`value` with `digits` decimals, '-' when NaN (nothing to score)."""
    return '-' if np.isnan(value) else f'{value:.{digits}f}'


def table_rows(label: str, scores: dict[int, ObjectScore], elapsed: Optional[np.ndarray]) -> str:
    """One Markdown table row ('-' where a value is NaN)."""
    cells = [label]
    for key in ('position_rmse', 'heading_rmse_deg', 'velocity_rmse'):
        digits = 1 if key == 'heading_rmse_deg' else 2
        cells.append(' / '.join(number(getattr(scores[i], key), digits) for i in sorted(scores)))
    cells.append(' / '.join(f'{100 * scores[i].coverage:.0f}' for i in sorted(scores)))
    cells.append(' / '.join(str(scores[i].id_switches) for i in sorted(scores)))
    if elapsed is None or not len(elapsed):
        cells.append('')
    else:
        cells.append(f'{np.median(elapsed):.1f} / {np.percentile(elapsed, 95):.1f}')
    return '| ' + ' | '.join(cells) + ' |'


HEADER = ('| fine association, jNIS, correction | position RMSE [m] | heading RMSE [deg] | '
          'velocity RMSE [m/s] | coverage [%] | id switches | ms per scan (median / p95) |\n'
          '|---|---|---|---|---|---|---|')


def parse_values(pairs: Iterable[str]) -> dict:
    """name=value strings -> typed values (int, float, bool or str)."""
    values = {}
    for pair in pairs:
        name, _, text = pair.partition('=')
        for cast in (int, float):
            try:
                values[name] = cast(text)
                break
            except ValueError:
                continue
        else:
            values[name] = {'true': True, 'false': False}.get(text.lower(), text)
    return values


SCENE_KINDS = ('car_static', 'car_moving', 'f1tenth_static', 'f1tenth_moving',
               'pedestrian_static', 'pedestrian_moving', 'race', 'crossing')
"""The keys of lidar_random_scene.KINDS, for --help without importing the scene generator (and
its message packages)."""


SCENE_LIDARS = ('360_10hz', '270_25hz', '360_10hz_coarse', '270_40hz_coarse')
"""The keys of lidar_random_scene.OTHER_LIDARS (as SCENE_KINDS)."""


def scene_report(kinds: Sequence[str], seeds_text: str, parameters: Sequence[str],
                 lidar_name: str = '', jobs: int = 1, objects: Optional[Path] = None) -> int:
    """--scenes: the summary table over the seeds of each kind (lidar_seeds), seen by the
    LiDAR `lidar_name` of lidar_random_scene.OTHER_LIDARS when given, the seeds on `jobs`
    processes; every object's scores to the new CSV file `objects` when given."""
    from .lidar_random_scene import KINDS, OTHER_LIDARS
    from .lidar_seeds import OBJECT_COLUMNS, SUMMARY_HEADER, evaluate_kind, object_rows, \
        parse_seeds, summary_row, worst_objects
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        print(f'da_lidar_eval: unknown scene kind {unknown[0]!r} (valid: {", ".join(KINDS)})',
              file=sys.stderr)
        return 2
    if lidar_name and lidar_name not in OTHER_LIDARS:
        print(f'da_lidar_eval: unknown LiDAR {lidar_name!r} (valid: {", ".join(OTHER_LIDARS)})',
              file=sys.stderr)
        return 2
    try:
        seeds = parse_seeds(seeds_text)
        given = parse_values(parameters)
        TrackerConfig().with_values(**given)  # checked once, before any seed runs
    except (ValueError, InvalidInputError) as error:
        print(f'da_lidar_eval: {error}', file=sys.stderr)
        return 2
    try:  # exclusive: an earlier run's file is never overwritten
        table = open(objects, 'x', newline='') if objects is not None else None
    except OSError as error:
        print(f'da_lidar_eval: --objects {objects}: {error.strerror}', file=sys.stderr)
        return 2
    rows, notes = [], []
    try:
        # spawned, not forked: a caller with threads (rclpy's, a test runner's) forks safely
        with table or nullcontext(), ProcessPoolExecutor(
                jobs, mp_context=get_context('spawn')) if jobs > 1 else nullcontext() as pool:
            if table:
                writer = csv.writer(table, lineterminator='\n')
                writer.writerow(OBJECT_COLUMNS)
            for kind in kinds:
                result = evaluate_kind(  # -p values win over the kind's preset
                    kind, seeds, TrackerConfig(), lidar=OTHER_LIDARS.get(lidar_name),
                    pool=pool, given=given,
                    progress=lambda text: print(text, file=sys.stderr, flush=True))
                rows.append(summary_row(result, seeds))
                notes.extend(worst_objects(result))
                if table:
                    writer.writerows(object_rows(result, lidar_name))
    except BaseException:  # a run cut short leaves no partial file to refuse the next one
        if objects is not None:
            objects.unlink(missing_ok=True)
        raise
    print(SUMMARY_HEADER)
    print('\n'.join(rows))
    if notes:
        print('objects missing a limit or switching ids (worst position first):')
        print('\n'.join(notes))
    if objects is not None:
        print(f'every object: {objects}')
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog='da_lidar_eval',
                                     description=' '.join(__doc__.split('\n\n')[0].split()))
    parser.add_argument('bag', nargs='?', type=Path, default=BAG,
                        help=f'LiDAR bag with /scan and its truth (default: {BAG})')
    parser.add_argument('--rows', default='default,nearest,polar,polar_kabsch,kabsch,'
                        'nearest_kabsch,velocity,seed',
                        help=f'comma-separated rows (of {", ".join(ROWS)})')
    parser.add_argument('--first', type=int, default=0, help='first scan scored')
    parser.add_argument('--repeat', type=int, default=1,
                        help='runs per row; the timing is over all of them')
    parser.add_argument('-p', '--parameter', action='append', default=[],
                        help='name=value for every row (e.g. -p max_age=0.5)')
    parser.add_argument('--scenes', default='',
                        help='instead of a bag: generated scenes of these kinds (comma-separated, '
                        f'of {", ".join(SCENE_KINDS)}), default parameters with the preset of '
                        'the kind\'s size class (core.lidar.PRESETS; a -p value wins over it); '
                        'per kind the median and worst object')
    parser.add_argument('--seeds', default='100-129',
                        help='seeds of the generated scenes: A-B or a,b,c (default 100-129; the '
                        'tracker was tuned on 0-29)')
    parser.add_argument('--lidar', default='', choices=('',) + SCENE_LIDARS,
                        help='--scenes seen by another LiDAR than their own (40 Hz, 270 deg, '
                        '0.25 deg): 360_10hz (0.2 deg, 60 m), 270_25hz (0.5 deg, 20 m), '
                        '360_10hz_coarse (0.5 deg, 12 m), 270_40hz_coarse (0.5 deg, 10 m)')
    parser.add_argument('--jobs', type=int, default=1,
                        help='--scenes: run the seeds on this many processes (the same scores; '
                        'the ms per scan then share the cores)')
    parser.add_argument('--objects', type=Path,
                        help='--scenes: also write every scored object\'s scores to this new CSV '
                        'file (refused if it exists; removed if the run fails or is cut short)')
    parser.add_argument('--paced', action='store_true',
                        help='also play the bag through lidar_tracker_node at its own rate '
                        '(real time) and report the node\'s step times')
    parser.add_argument('--live', action='store_true',
                        help='also play the bag through lidar_tracker_node over DDS (default row)')
    args = parser.parse_args(argv)
    rows = [r for r in args.rows.split(',') if r]
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        parser.error(f'unknown row {unknown[0]!r} (valid: {", ".join(ROWS)})')
    if args.jobs < 1:
        parser.error(f'--jobs must be at least 1, not {args.jobs}')
    if args.scenes:
        return scene_report(args.scenes.split(','), args.seeds, args.parameter, args.lidar,
                            args.jobs, args.objects)
    if args.objects is not None or args.jobs != 1:
        parser.error('--objects and --jobs go with --scenes')
    try:
        scans = read_scans(args.bag)
        base = TrackerConfig().with_values(**parse_values(args.parameter))
    except (BagError, InvalidInputError) as error:
        print(f'da_lidar_eval: {error}', file=sys.stderr)
        return 2
    ids = sorted({int(i) for scan in scans for i in scan.truth['id']})
    print(f'{args.bag.name}: {len(scans)} scans, objects {", ".join(map(str, ids))} '
          f'(values: object {" / ".join(map(str, ids))}); scans {args.first}-{len(scans) - 1} '
          'scored')
    print(HEADER)
    for row in rows:
        label, changes = ROWS[row]
        if args.parameter:
            label += ' (' + ', '.join(args.parameter) + ')'
        config = base.with_values(**changes)
        elapsed = []
        for _ in range(max(args.repeat, 1)):
            estimates, times = run_offline(scans, config)
            elapsed.append(times)
        print(table_rows(label, score(scans, estimates, args.first), np.concatenate(elapsed)),
              flush=True)
    if args.live:
        live = run_live(args.bag, base)
        print(table_rows(f'{ROWS["default"][0]}, live: lidar_tracker_node over DDS',
                         score(scans, live.estimates, args.first), None))
    if args.paced:
        live = run_live(args.bag, base, paced=True)
        print(table_rows(f'{ROWS["default"][0]}, live at the bag\'s rate: lidar_tracker_node '
                         'over DDS', score(scans, live.estimates, args.first), live.step_ms))
        print(f'paced: {len(scans)} scans sent, {live.scans} tracked, {live.dropped} dropped, '
              f'{live.replies} tracks messages in frame {live.frame!r}; node step time '
              f'median {np.median(live.step_ms):.1f} ms, p95 '
              f'{np.percentile(live.step_ms, 95):.1f} ms, max {np.max(live.step_ms):.1f} ms')
    return 0


if __name__ == '__main__':
    sys.exit(main())
