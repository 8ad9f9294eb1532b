"""Free space along the beams (core/lidar/free_space.py): beam directions of a scan without
returns, the rectangle cut back where beams pass through it, and what it does to a tracked car
shorter than the size prior (issue 21's largest group of full-size failures)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from data_association_ros.bag.lidar_motion import Pieces
from data_association_ros.bag.lidar_random_scene import (CAR_LIDAR, F1TENTH_LIDAR, Scene,
                                                         SceneObject)
from data_association_ros.bag.lidar_seeds import configuration
from data_association_ros.core.lidar import LidarObjectTracker, TrackerConfig, object_tracker
from data_association_ros.core.lidar.clustering import FACE_SLOPE, FACE_STEPS
from data_association_ros.core.lidar.free_space import (RANGE_SHARE, _line_run, beam_directions,
                                                        beams, blocked_share, carve,
                                                        face_end_limit)
from data_association_ros.core.lidar.shape import fit_at
from data_association_ros.bag.lidar_eval import run_offline, scans_from_messages, score

NO_WALLS = np.zeros((0, 2, 2))


def test_beam_directions_fill_the_beams_without_a_return():
    angles = -1.0 + 0.01 * np.arange(9)
    points = 5.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    points[[0, 4, 8]] = np.nan
    directions = beam_directions(points)
    assert np.allclose(directions, np.column_stack([np.cos(angles), np.sin(angles)]))
    uneven = points.copy()
    uneven[5] = 5.0 * np.array([np.cos(0.3), np.sin(0.3)])  # not a scan's even spacing
    assert np.all(np.isnan(beam_directions(uneven)[[0, 4, 8]]))
    assert np.all(np.isnan(beam_directions(np.full((3, 2), np.nan))))


def test_beams_free_up_to_the_return_or_the_farthest_one():
    points = np.array([[3.0, 0.0], [np.nan, np.nan], [0.0, 5.0]])
    directions, free, returned = beams(points, np.zeros(2), np.array(
        [[1.0, 0.0], [np.sqrt(0.5), np.sqrt(0.5)], [0.0, 1.0]]), 0.1)
    assert np.allclose(free, [2.9, 4.9, 4.9]) and returned.tolist() == [True, False, True]
    assert np.allclose(directions[1], [np.sqrt(0.5), np.sqrt(0.5)])
    # with the sensor's range_max: a beam without a return is free to RANGE_SHARE of it
    _, free, _ = beams(points, np.zeros(2), None, 0.1, max_range=30.0)
    assert np.allclose(free, [2.9, 30.0 * RANGE_SHARE - 0.1, 4.9])
    _, free, _ = beams(points, np.zeros(2), None, 0.1, max_range=4.0)  # never below the returns
    assert np.allclose(free, [2.9, 4.9, 4.9])


SIDE = np.column_stack([[-2.0, -1.2, -0.4, 0.4, 1.2], np.full(5, -0.83)])
"""A car's -v side seen at a grazing angle, rear to front (the end: u = 1.2)."""


def beam_to(target, origin=(-20.0, -3.0)):
    origin = np.asarray(origin, float)
    direction = np.asarray(target, float) - origin
    return origin, direction / np.hypot(*direction)


def slack(origin, target, tolerance=0.1):
    """1 std of the crossing along the face for SIDE's exact returns: their std is the floor
    0.2 x tolerance; the line's std across at distance d from their centre (u = -0.4) is
    that x sqrt(1/5 + d^2 / 6.4) (6.4 = the sum of squared offsets 1.6, 0.8, 0, 0.8, 1.6);
    over the sine of the beam's angle to the face."""
    direction = np.subtract(target, origin)
    sine = abs(direction[1]) / np.hypot(*direction) if abs(direction[1]) < abs(direction[0]) \
        else abs(direction[0]) / np.hypot(*direction)
    d = max(abs(target[0] + 0.4), abs(target[1] + 0.4)) if abs(direction[1]) < abs(
        direction[0]) else abs(target[1] - 0.4)
    return 0.2 * tolerance * np.sqrt(0.2 + d ** 2 / 6.4) / sine


@settings(max_examples=300, deadline=None)
@given(st.integers(3, 5), st.floats(-np.pi, np.pi), st.floats(0.01, 0.3),
       st.floats(0.0, 0.05), st.integers(0, 2 ** 32 - 1))
def test_face_line_fit_is_the_least_squares_line_of_svd(count, heading, step, noise, seed):
    """face_end_limit's run test (_line_run, in plain floats) against numpy: returns along a
    line at `heading`, `step` [m] apart with `noise` across; its direction is the centred
    run's first right singular vector (up to sign), its residuals the returns' distances
    across it, and it refuses the run exactly when a residual exceeds the tolerance, a step
    turns more than FACE_SLOPE off the line or a step is not FACE_STEPS x the one before."""
    rng = np.random.default_rng(seed)
    axis = np.array([np.cos(heading), np.sin(heading)])
    run = np.cumsum(step * rng.uniform(0.6, 1.6, count))[:, None] * axis \
        + rng.normal(0.0, noise, count)[:, None] * [-axis[1], axis[0]]
    tolerance = 0.02
    fit = _line_run(run[:, 0].tolist(), run[:, 1].tolist(), tolerance)
    centre = run.mean(axis=0)
    along, normal = np.linalg.svd(run - centre)[2]
    residuals = (run - centre) @ normal
    steps = np.diff(run, axis=0)
    lengths = np.hypot(*steps.T)
    ratios = lengths[1:] / lengths[:-1]
    margins = np.concatenate([tolerance - np.abs(residuals),
                              FACE_SLOPE * np.abs(steps @ along) - np.abs(steps @ normal),
                              ratios - FACE_STEPS[0], FACE_STEPS[1] - ratios])
    if np.min(np.abs(margins)) < 1e-9:
        return  # on a limit: either answer is right
    assert (fit is None) == bool(np.any(margins < 0))
    if fit is not None:
        np.testing.assert_allclose(fit[0], centre, atol=1e-12)
        assert abs(abs(np.dot(fit[1], along)) - 1.0) < 1e-9
        sign = np.sign(np.dot(fit[2], normal))
        np.testing.assert_allclose(sign * np.array(fit[3]), residuals, atol=1e-9)


def test_face_end_limit_by_hand():
    """The beam past the face's end crosses its line (v = -0.83) at u = 1.8: the length ends
    there (axis 0, the high side), plus one std of that crossing (0.2 m at 6 deg to the face;
    a heading a degree off would move it 0.16 m)."""
    origin, direction = beam_to([1.8, -0.83])
    expected = 1.8 + slack((-20.0, -3.0), (1.8, -0.83))
    assert 0.15 < expected - 1.8 < 0.25
    assert np.allclose(face_end_limit(SIDE, origin, direction, 40.0, 0.1), (0, 1, expected))
    # the other way round: the end at the low side, the beam past u = -2.6
    origin, direction = beam_to([-2.6, -0.83], origin=(25.0, -3.0))
    assert np.allclose(face_end_limit(SIDE[::-1], origin, direction, 40.0, 0.1),
                       (0, 0, -2.6 - slack((25.0, -3.0), (-2.6, -0.83))))
    # a face along v bounds the width
    face = SIDE[:, ::-1] * [1, -1]  # u = -0.83, v from 2.0 down to -1.2 (centre 0.4)
    origin, direction = beam_to([-0.83, -1.5], origin=(-3.0, -20.0))
    assert np.allclose(face_end_limit(face, origin, direction, 40.0, 0.1),
                       (1, 0, -1.5 - slack((-3.0, -20.0), (-0.83, -1.5))))


def test_face_end_limit_needs_a_beam_that_passes_the_line():
    origin, direction = beam_to([1.8, -0.83])
    crossing = np.hypot(*(np.array([1.8, -0.83]) - origin))
    assert face_end_limit(SIDE, origin, direction, crossing - 0.01, 0.1) is None  # stopped
    assert face_end_limit(SIDE, origin, direction, np.nan, 0.1) is None
    assert face_end_limit(SIDE, origin, [1.0, 0.0], 40.0, 0.1) is None   # parallel
    assert face_end_limit(SIDE, origin, -direction, 40.0, 0.1) is None   # behind the origin
    assert face_end_limit(SIDE[-2:], origin, direction, 40.0, 0.1) is None  # two returns
    turned = SIDE @ np.array([[np.cos(0.6), np.sin(0.6)], [-np.sin(0.6), np.cos(0.6)]])
    assert face_end_limit(turned, origin, direction, 40.0, 0.1) is None  # 34 deg off both axes
    # car_static seed 303 object 1, scan 59: the rear face's returns, then the side's first
    # (a run over the corner, 18 deg off the length axis): cut the 4.3 m length to 0.35 m
    corner = np.array([[-2.184, 0.636], [-2.186, 0.678], [-2.197, 0.721], [-2.136, 0.763],
                       [-1.971, 0.807]])
    assert face_end_limit(corner, np.array([-11.87, 0.74]), np.array([1.0, 0.011]) / np.hypot(
        1.0, 0.011), 11.58, 0.05) is None
    # f1tenth_moving seed 103 object 1, scan 97: the same at 1/10 scale, 10 deg off the axis
    # (the kink: steps of 3.6 cm then 11.5 cm), cut the 0.61 m length to 0.28 m
    small = np.array([[-0.302, -0.087], [-0.31, -0.107], [-0.316, -0.127], [-0.284, -0.144],
                      [-0.17, -0.155]])
    assert face_end_limit(small, np.array([-4.74, -0.48]), np.array([0.998, 0.066]) / np.hypot(
        0.998, 0.066), 9.7, 0.05) is None


def test_face_end_limit_fits_the_returns_next_to_the_end():
    """A corner among the first returns: the line is fitted to the run at the end only."""
    face = SIDE.copy()
    face[:2, 1] = [-0.2, -0.5]   # the rear face's returns before the corner
    origin, direction = beam_to([1.8, -0.83])
    # the last three returns (centre u = 0.4, offsets -0.8, 0, 0.8), the std floor 0.01 m
    expected = 1.8 + 0.01 * np.sqrt(1 / 3 + 1.4 ** 2 / 1.28) / direction[1]
    assert np.allclose(face_end_limit(face, origin, direction, 40.0, 0.05), (0, 1, expected))
    noisy = SIDE + [0.0, 0.02] * np.array([1, -1, 1, -1, 1])[:, None]
    found = face_end_limit(noisy, origin, direction, 40.0, 0.05)  # 2 cm across: a wider std
    assert found is not None and expected < found[2] < 1.8 + 0.4, found


BOX = (np.array([-2.25, -0.9]), np.array([2.25, 0.9]))
SEEN = (np.array([-2.2, 0.85]), np.array([1.5, 0.9]))  # the +v side face, rear to u = 1.5


def cut(origins, directions, free, returned=None, **options):
    return carve(*BOX, *SEEN, np.atleast_2d(origins), np.atleast_2d(directions),
                 np.atleast_1d(free), returned=returned, **options)


def test_a_beam_past_the_front_cuts_the_length_back_to_it():
    """The sensor on the +v side (the seen face); a beam straight down at u = 1.8 passes
    through the prior's front: high_u becomes 1.8 exactly."""
    low, high = cut([1.8, 20.0], [0.0, -1.0], 40.0)
    assert np.allclose(low, BOX[0]) and np.allclose(high, [1.8, 0.9])


def test_beams_that_cannot_cut_leave_the_box():
    # through the seen face: it would have to cut into the points
    assert np.allclose(cut([1.0, 20.0], [0.0, -1.0], 40.0), BOX)
    # ends before the box
    assert np.allclose(cut([1.8, 20.0], [0.0, -1.0], 18.0), BOX)
    # returned from inside the box (grown by the margin): it hit the object
    assert np.allclose(cut([1.8, 20.0], [0.0, -1.0], 19.5, np.array([True]), margin=0.1), BOX)
    # the same beam without a return is free space
    assert not np.allclose(cut([1.8, 20.0], [0.0, -1.0], 19.5, np.array([False]),
                               margin=0.1), BOX)
    # grazing: nearly parallel to u, entering the top face at u = 1.6 (past the seen span) and
    # 6 cm into the width: a heading error, not free space.  Without the rules it cuts to 1.6.
    direction = np.array([1.0, -0.01]) / np.hypot(1.0, 0.01)
    grazing = ([-10.0, 0.9 + 0.01 * 11.6], direction, 30.0)
    assert np.allclose(cut(*grazing)[1], [1.6, 0.9], atol=1e-3)
    assert np.allclose(cut(*grazing, min_depth=0.1, share=0.1), BOX)
    assert np.allclose(cut(*grazing, min_sine=np.sin(np.deg2rad(20.0))), BOX)


def test_the_cheaper_side_is_cut():
    """Seen: the -v face up to u = 1.5 and v up to -0.5.  A beam down through the corner
    region could be cleared by cutting the length to 2.0 (0.25 m) or the width to -0.35
    (1.25 m): the length is cut."""
    direction = np.array([0.2, -1.0]) / np.hypot(0.2, 1.0)
    origin = np.array([2.0, 0.9]) - 10 * direction
    low, high = carve(*BOX, np.array([-2.2, -0.9]), np.array([1.5, -0.5]), origin[None],
                      direction[None], np.array([20.0]))
    assert np.allclose(high, [2.0, 0.9]) and np.allclose(low, BOX[0])


def test_fit_at_keeps_a_known_direction():
    points = np.column_stack([np.linspace(4.0, 8.0, 20), np.full(20, 3.0)])  # a face, y = 3
    _, yaw, _, _ = fit_at(points, np.pi, 4.5, 1.8)  # pointing back at the sensor: turned
    assert abs(np.cos(yaw) - 1.0) < 1e-9
    _, yaw, _, _ = fit_at(points, np.pi, 4.5, 1.8, directed=True)
    assert abs(np.cos(yaw) + 1.0) < 1e-9


def short_car_scene(start, heading, speed, length=3.85, width=1.7, duration=3.0):
    return Scene([SceneObject(1, length, width, Pieces((*start, heading),
                                                       ((duration + 1, speed, 0.0),)))],
                 None, NO_WALLS, CAR_LIDAR, duration, 0)


@pytest.mark.parametrize('start, heading', [((-6.0, 10.0), 0.3), ((8.0, -12.0), 0.6)])
def test_a_short_car_seen_from_the_side_gets_its_length(start, heading):
    """A 3.85 m car (the 4.5 m prior is 0.65 m too long) passing the sensor seen side-on:
    beams past its front cut the prior back.  Measured: position RMSE 0.05 / 0.08 m, final
    length 3.85 / 3.88 m; without the cut (CARVE_SHARE = 1e6) 0.32 / 0.33 m and 4.5 m, above
    issue 21's 0.3 m."""
    scene = short_car_scene(start, heading, 6.0)
    scans = scans_from_messages(scene.messages())
    result = score(scans, run_offline(scans, TrackerConfig())[0])[1]
    assert result.position_rmse < 0.15 and result.id_switches == 0, result
    tracker = LidarObjectTracker()
    for scan in scans:
        tracks = tracker.step(scan.points, scan.time)
    assert len(tracks) == 1 and abs(tracks[0].length - 3.85) < 0.15, tracks[0].length


@pytest.mark.parametrize('offset', [0.17, -0.2])
def test_a_short_car_driving_away_at_a_grazing_angle_gets_its_length(offset):
    """A 3.85 m car driving away 10-12 deg off the line of sight: its side's returns are
    0.5-0.9 m apart and the beams past its front cross the prior's end at 10 deg (too grazing
    for the carve's evidence); the beam past the side's last return crosses the side's line
    short of the prior's end (face_end_limit).  Measured: position RMSE 0.09 / 0.04 m, final
    length 4.02 / 3.92 m; before face_end_limit (commit 4220100) 0.33 / 0.33 m and 4.5 m."""
    bearing = np.arctan2(2.0, 12.0)
    scene = short_car_scene((12.0, 2.0), bearing + offset, 5.0)
    scans = scans_from_messages(scene.messages())
    result = score(scans, run_offline(scans, TrackerConfig())[0])[1]
    assert result.position_rmse < 0.15 and result.id_switches == 0, result
    tracker = LidarObjectTracker()
    for scan in scans:
        tracks = tracker.step(scan.points, scan.time, max_range=scan.max_range)
    assert len(tracks) == 1 and abs(tracks[0].length - 3.85) < 0.25, tracks[0].length


def test_a_car_seen_only_from_behind_keeps_its_length():
    """Driving straight away from the sensor: its sides are parallel to the beams, so no beam
    tells its length (a grazing beam crosses the box only through the heading error); the
    prior stays."""
    scene = short_car_scene((8.0, 0.0), 0.0, 4.0, length=4.5, width=1.8, duration=2.0)
    scans = scans_from_messages(scene.messages())
    tracker = LidarObjectTracker()
    for scan in scans:
        tracks = tracker.step(scan.points, scan.time)
    assert len(tracks) == 1 and abs(tracks[0].length - 4.5) < 0.1, tracks[0].length


def passing_behind_a_parked_car(speed=3.5):
    """A car (4.5 m, 3.5 m/s along +y at x = 16 m) passes behind a parked one (at x = 8 m, its
    length along y) that hides it (fewer than 5 beams) for about 1.6 s, longer than max_age
    (1 s)."""
    parked = SceneObject(1, 4.5, 1.8, Pieces((8.0, 0.0, np.pi / 2), ((7.0, 0.0, 0.0),)))
    moving = SceneObject(2, 4.5, 1.8, Pieces((16.0, -10.0, np.pi / 2), ((7.0, speed, 0.0),)))
    return Scene([parked, moving], None, NO_WALLS, CAR_LIDAR, 6.0, 0)


def test_a_car_hidden_longer_than_max_age_keeps_its_id():
    """Hidden (every beam towards its predicted rectangle returns from the parked car in
    front) it is kept up to max_hidden_age: one id over the run.  With max_hidden_age =
    max_age it is dropped while hidden and found again as a new track.  Measured: hidden
    1.6 s; ids [1] (position RMSE 0.02 m), with max_hidden_age 1.0 ids [1, 3]."""
    scans = scans_from_messages(passing_behind_a_parked_car().messages())
    hidden = [scan.truth['visible'][1] < 5 for scan in scans]
    assert sum(hidden) / CAR_LIDAR.rate_hz > 1.2  # hidden longer than max_age
    kept = score(scans, run_offline(scans, TrackerConfig())[0])[2]
    dropped = score(scans, run_offline(scans, TrackerConfig(max_hidden_age=1.0))[0])[2]
    assert kept.id_switches == 0 and len(kept.track_ids) == 1, kept
    assert dropped.id_switches >= 1, dropped
    assert kept.position_rmse < 0.3, kept


def test_hidden_is_told_by_the_beams_towards_the_rectangle():
    """A 4.5 x 1.8 m rectangle 10 m ahead (about 10 deg wide) seen through a scan of 240 beams
    over +-30 deg: hidden behind a wall at 5 m, not through a hole in it (beams without a
    return pass), not when the beams return from its own near face, hidden behind the
    sensor (no beam points there)."""
    tracker = LidarObjectTracker()
    angles = np.deg2rad(np.arange(-30.0, 30.0, 0.25))
    track = tracker._start(np.array([[9.0, -0.5], [9.0, 0.0], [9.0, 0.5]]), np.zeros(2), 0.0)
    track.filter.x[:3], track.length, track.width = [11.0, 0.0, 0.0], 4.5, 1.8

    def hidden(ranges):
        points = np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])
        tracker._rays = beams(points, np.zeros(2), None, 0.1)
        tracker._origins = np.zeros(points.shape)
        return tracker._hidden(track)
    wall = 5.0 / np.cos(angles)
    assert hidden(wall)
    holed = np.where(np.abs(angles) < np.deg2rad(8.0), np.nan, wall)
    assert not hidden(holed)
    face = np.where(np.abs(angles) < np.deg2rad(6.0), 8.75 / np.cos(angles), wall)
    assert not hidden(face)  # its own returns do not hide it
    track.filter.x[:3] = [-11.0, 0.0, 0.0]
    assert hidden(wall)
    track.filter.x[:3] = [11.0, 0.0, 0.0]
    tracker._range_known = True  # range_max known: the hole's beams end at 0.95 x range_max
    tracker._rays = beams(np.column_stack([holed * np.cos(angles), holed * np.sin(angles)]),
                          np.zeros(2), None, 0.1, max_range=8.0)
    assert tracker._hidden(track)  # 7.6 m < 8.75 m: out of range
    tracker._rays = beams(np.column_stack([holed * np.cos(angles), holed * np.sin(angles)]),
                          np.zeros(2), None, 0.1, max_range=30.0)
    assert not tracker._hidden(track)  # they reach through it: it is not there


def test_blocked_share_by_hand():
    """Beams along +x from y = -0.5, 0, 0.5 (and 2: past the box) towards the box [9, 11] x
    [-1, 1], margin 0.1: blocked = ending more than 0.2 m before x = 9 (a return, or the known
    range's end); a return within [9 - 0.2, 11] is the object itself and counts neither way."""
    origins = np.array([[0.0, -0.5], [0.0, 0.0], [0.0, 0.5], [0.0, 2.0]])
    directions = np.tile([1.0, 0.0], (4, 1))
    low, high = np.array([9.0, -1.0]), np.array([11.0, 1.0])

    def share(free, returned, known=False):
        return blocked_share(origins, directions, np.array(free, float),
                             np.array(returned, bool), known, low, high, 0.1)
    assert share([5, 5, 5, 5], [1, 1, 1, 1]) == 1.0  # a wall at 5 m
    assert share([5, 8.9, 20, 5], [1, 1, 1, 1]) == 0.5  # blocked, its own face, through it
    assert share([5, 8.7, 20, 5], [1, 1, 1, 1]) == pytest.approx(2 / 3)  # 8.7 + 0.2 < 9
    assert share([9.5, 9.5, 9.5, 9.5], [0, 0, 0, 0], known=True) == 0.0  # range reaches it
    assert share([8.5, 8.5, 8.5, 8.5], [0, 0, 0, 0], known=True) == 1.0  # out of range
    assert share([8.5, 8.5, 8.5, 8.5], [0, 0, 0, 0], known=False) == 0.0  # range unknown
    assert share([5, 9.5, 9.2, 5], [0, 1, 1, 1], known=True) == 1.0  # part of it seen
    assert share([9.5, 9.5, 9.2, 5], [1, 1, 1, 1]) == 0.0  # only its own returns: in sight
    assert blocked_share(origins, -directions, np.full(4, 5.0), np.ones(4, bool), True, low,
                         high, 0.1) is None  # no beam points at it


@pytest.mark.parametrize('centre, speed, start', [(8.0, 2.0, -110.0), (7.5, 2.5, -100.0),
                                                  (8.5, 2.5, -110.0)])
def test_an_f1tenth_car_out_of_range_for_a_while_keeps_its_id(centre, speed, start):
    """An F1Tenth car on a circle of radius 3 m about (centre, 0), seen by a static 10 m LiDAR,
    goes out of range for 1.25-2.6 s and comes back.  Its beams, without a return, end at
    0.95 x range_max, short of its predicted rectangle: it is hidden, kept up to
    max_hidden_age instead of max_age (1 s), also while the first returns of it come back.
    Measured before: ids [1, 2] in all three (as f1tenth_moving seed 303 object 5, 10.0-10.6 m
    away for 1.2 s).  Of six such circles tried, before / after: 1 / 4 kept their id (the two
    left: the coasting prediction 0.1 m nearer than the car when it comes back, whose returns
    then pass behind the predicted rectangle)."""
    radius, start = 3.0, np.deg2rad(start)
    pose = (centre + radius * np.cos(start), radius * np.sin(start), start + np.pi / 2)
    scene = Scene([SceneObject(1, 0.55, 0.30, Pieces(pose, ((6.0, speed, speed / radius),)))],
                  None, NO_WALLS, F1TENTH_LIDAR, 5.0, 0, size='f1tenth')
    scans = scans_from_messages(scene.messages())
    out = [scan.truth['visible'][0] < 3 for scan in scans]
    assert sum(out) / F1TENTH_LIDAR.rate_hz > 1.2  # out of range longer than max_age
    result = score(scans, run_offline(scans, configuration('f1tenth_static',
                                                           TrackerConfig()))[0])[1]
    assert result.id_switches == 0 and result.track_ids == [1], result
    assert result.position_rmse < 0.02 and result.heading_rmse_deg < 3.0, result


@pytest.mark.parametrize('radius, speed, start', [(1.0, 0.8, 90.0), (1.0, 0.8, 100.0),
                                                  (2.0, 1.6, 90.0), (3.0, 1.6, 100.0)])
def test_an_f1tenth_car_back_from_behind_the_sensor_keeps_its_id(radius, speed, start):
    """An F1Tenth car on a circle about a static 270-deg LiDAR, starting at bearing `start`
    [deg], drives through the 90 deg behind the sensor that no beam covers (hidden 1.2-2.7 s,
    less than max_hidden_age) and comes back at the edge of the field of view.  Its coasting
    prediction is there (0.13 m off for radius 2, speed 1.6, start 90) but its position std
    has grown to metres and its first returns are too few to correct it: before, the track was
    dropped at that scan (more than max_age without an update, and the beams along the edge
    pass through part of its predicted rectangle, so not hidden) and the car came back under a
    new id, ids [1, 2] in all four.  Now a confirmed track that took a cluster in the coarse
    association is kept (up to max_hidden_age) and hands its id to the track started from
    that cluster."""
    scans = _circle_through_the_blind_sector(radius, speed, start)
    unseen = sum(scan.truth['visible'][0] < 3 for scan in scans) / F1TENTH_LIDAR.rate_hz
    assert 1.0 < unseen < 3.0
    result = score(scans, run_offline(scans, configuration('f1tenth_static',
                                                           TrackerConfig()))[0])[1]
    assert result.id_switches == 0 and result.track_ids == [1], result
    assert result.position_rmse < 0.05 and result.heading_rmse_deg < 5.0, result


def _circle_through_the_blind_sector(radius, speed, start):
    """Scans of an F1Tenth car on a circle of `radius` [m] about a static 270-deg LiDAR at
    `speed` [m/s], starting at bearing `start` [deg] (through the 90 deg behind the sensor)."""
    s = np.deg2rad(start)
    pose = (radius * np.cos(s), radius * np.sin(s), s + np.pi / 2)
    scene = Scene([SceneObject(1, 0.55, 0.30, Pieces(pose, ((6.0, speed, speed / radius),)))],
                  None, NO_WALLS, F1TENTH_LIDAR, 6.0, 0, size='f1tenth')
    return scans_from_messages(scene.messages())


@pytest.mark.parametrize('radius, speed, start', [(1.5, 0.8, 90.0), (3.0, 1.6, 100.0)])
def test_an_extent_cut_along_a_wrong_heading_is_fitted_anew(radius, speed, start, monkeypatch):
    """The car of the test above comes back at the edge of the field of view, and its new
    track's first rectangle is fitted to 5 returns with the heading off the car's axis (35 deg
    for radius 1.5; 131 deg, 49 off the axis, for radius 3.0, whose width is then cut back
    along it to 0.06 m and, as the sensor at the circle's centre only ever sees the car's inner
    side, never grows again).  Fitted anew once the corrections have turned the heading by
    more than EXTENT_SWING (20 deg): position RMSE 0.04-0.17 -> 0.006-0.021 m and 0.093 ->
    0.007 m (without the refit: EXTENT_SWING infinite; for radius 1.5 the ranges are over the
    machines' floating-point kernels: an earlier machine, OpenBLAS' Sandybridge and Haswell
    kernels on an AMD EPYC; docs/lidar.md "Results that depend on the CPU").  Since the F1Tenth
    preset ties heading and velocity (slip_sigma 0.3, 2026-12-07) the velocity also turns the
    radius 3.0 box back (0.003 m without the refit), so the rule is checked without it too."""
    scans = _circle_through_the_blind_sector(radius, speed, start)
    config = configuration('f1tenth_static', TrackerConfig())
    plain = config.with_values(slip_sigma=0.0)
    for each in (config, plain):
        result = score(scans, run_offline(scans, each)[0])[1]
        assert result.track_ids == [1] and result.position_rmse < 0.025, result
    monkeypatch.setattr(object_tracker, 'EXTENT_SWING', np.inf)
    kept = score(scans, run_offline(scans, plain)[0])[1]
    assert kept.position_rmse > 0.03, kept


def test_on_face_by_hand():
    from data_association_ros.core.lidar.clustering import on_face
    end, outward = np.zeros(2), np.array([1.0, 0.0])
    assert on_face(end, outward, 0.3, np.array([0.3, 0.05]), 0.1)       # the next return
    assert not on_face(end, outward, 0.3, np.array([0.3, 0.2]), 0.1)    # off the line
    assert not on_face(end, outward, 0.3, np.array([1.0, 0.0]), 0.1)    # a gap: 3.3 spacings
    assert not on_face(end, outward, 0.3, np.array([0.1, 0.0]), 0.1)    # not beyond the end
    assert not on_face(end, outward, 0.3, np.array([np.nan, np.nan]), 0.1)


def test_a_grazing_face_going_on_past_a_cluster_end_is_no_edge():
    """A side face seen at 12 deg (returns 0.3 m apart, each 0.3 m farther: flagged as an edge
    by range alone) whose next return was left out of every cluster: no EdgePoint there (the
    correction would pull the rectangle's corner onto the middle of the face, car_moving seed
    200); the same end with the next return behind a corner stays an edge.  (cluster_gap
    0.31 m: the face's own returns are within it, as cluster_consecutive leaves them.)"""
    tracker = LidarObjectTracker(TrackerConfig().with_values(cluster_gap=0.31))
    face = np.array([12.0, 2.0]) + np.outer(np.arange(6) * 0.3, [np.cos(0.2), np.sin(0.2)])
    ends, edges = np.array([[1, 5]]), np.array([[False, True]])
    labels = np.array([-1, 0, 0, 0, 0, 0, -1])
    points = np.vstack([face[:1] - [0.3, 0.06], face[1:], face[5] + (face[5] - face[4])])
    # the last row: the next return on the same face, 0.3 m on: no edge
    assert tracker._edges(points, labels, [0], ends, edges) == []
    points[-1] = face[5] + (face[5] - face[4]) + [0.0, 1.0]   # behind the corner: an edge
    found = tracker._edges(points, labels, [0], ends, edges)
    assert len(found) == 1 and np.allclose(found[0].point, face[5])


def test_an_end_reached_across_a_face_gap_is_no_edge():
    """The far end of a side seen at a grazing angle (returns 0.6 m apart, kept in the cluster
    by the face rule) lies up to one spacing short of the corner, and an edge there pulled the
    prior-long rectangle back (lidar_two_cars car 2: 0.25 -> 0.6 m): no EdgePoint when the
    end's last step is longer than cluster_gap; the same side seen 0.1 m apart gives one."""
    tracker = LidarObjectTracker()
    for step, edges_expected in ((0.6, 0), (0.1, 1)):
        side = np.column_stack([10.0 + step * np.arange(5), np.full(5, -1.1)])
        points = np.vstack([side, [[np.nan, np.nan]]])
        labels = np.array([0, 0, 0, 0, 0, -1])
        ends, edges = np.array([[0, 4]]), np.array([[False, True]])
        found = tracker._edges(points, labels, [0], ends, edges)
        assert len(found) == edges_expected
        if found:
            assert np.allclose(found[0].point, side[-1])
