"""LiDAR tracking beyond lidar_two_cars (issue 21): generated scenes, any heading, a moving sensor
with odometry, size classes, truth matched by header stamp."""
import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from data_association_ros.bag.lidar_eval import run_offline, scans_from_messages, score
from data_association_ros.bag.lidar_motion import Pieces, Stadium, ramp
from data_association_ros.bag.lidar_random_scene import (CAR_LIDAR, F1TENTH_LIDAR, KINDS,
                                                         OTHER_LIDARS, Scene, SceneObject,
                                                         race_scene, random_scene)
from data_association_ros.bag.lidar_seeds import configuration
from data_association_ros.core.lidar import (LidarObjectTracker, TrackerConfig, clustering,
                                             object_tracker)
from data_association_ros.core.lidar.measurement import lateral_velocity
from data_association_ros.core.lidar.object_tracker import (SETTLE_TIME, SLOW_VOTE, ObjectTrack,
                                                             FIT_SIGMA_PER_LENGTH, across_spread,
                                                             extent_covariance,
                                                             fused_start_velocity, heading_turn,
                                                             no_slip, plausible_turn, refit_along,
                                                             vague)
from data_association_ros.core.lidar.shape import rotation
from data_association_ros.core.tracking.kalman import KalmanFilter
from data_association_ros.pipelines.lidar_tracking import LidarTracking, PoseHistory, to_frame

NO_WALLS = np.zeros((0, 2, 2))


def one_car_scene(start, speed=8.0, sensor=None, duration=2.0, size=(4.5, 1.8), lidar=CAR_LIDAR,
                  turn=0.0):
    return Scene([SceneObject(1, *size, Pieces(start, ((duration + 1, speed, turn),)))], sensor,
                 NO_WALLS, lidar, duration, 0)


def scores_of(scene, config=TrackerConfig()):
    scans = scans_from_messages(scene.messages())
    estimates, _ = run_offline(scans, config)
    return score(scans, estimates)


def test_car_crossing_behind_the_sensors_side_has_the_right_heading():
    """Issue 21's failure: a car crossing at 90 deg to the sensor's x axis (x = -12 m, from
    y = 8 m, 8 m/s along +y), entering the 270 deg field of view at its edge, was tracked with
    its box turned by 90 deg the whole run: measured before the fix heading RMSE 89.9 deg,
    position 1.53 m; after: 0.16 deg, 0.02 m, coverage 95 % (reported once the velocity settled
    its heading)."""
    result = scores_of(one_car_scene((-12.0, 8.0, np.pi / 2)))[1]
    assert result.heading_rmse_deg < 3.0 and result.position_rmse < 0.1, result
    assert result.id_switches == 0 and result.coverage > 0.8, result


def test_oncoming_car_starts_pointing_the_right_way():
    """Seen head-on, a fit points away from the sensor; the velocity turns it round before the
    track is reported (reported tracks never point backwards here)."""
    scene = one_car_scene((20.0, 1.0, np.pi))
    scans = scans_from_messages(scene.messages())
    estimates, _ = run_offline(scans, TrackerConfig())
    errors = [abs(np.angle(np.exp(1j * (e.states[0, 2] - np.pi)))) for e in estimates
              if len(e.ids)]
    assert len(errors) > 60 and max(errors) < np.deg2rad(5)



@pytest.mark.parametrize('course', [2.0, 2.0 + np.pi, 0.3 + np.pi])
def test_slow_f1tenth_car_is_reported_pointing_the_way_it_drives(course):
    """An F1Tenth car at 0.8 m/s, 2 m from a sensor driving at 0.5 m/s: the velocity stays
    below 1 std of the filter (about 0.8 m/s here) long after SETTLE_TIME, so a track whose fit
    pointed backwards was reported so for the whole run (measured before DIRECTION_TIME: course
    2.0 + pi, every one of 40 reported headings 179-180 deg off; f1tenth_moving seeds 102 and
    108).  Every reported heading within 5 deg of the course."""
    sensor = Pieces((0.0, 0.0, 0.0), ((3.0, 0.5, 0.0),))
    scene = Scene([SceneObject(1, 0.55, 0.30, Pieces((1.5, 1.2, course), ((3.0, 0.8, 0.0),)))],
                  sensor, NO_WALLS, F1TENTH_LIDAR, 1.5, 0, size='f1tenth')
    scans = scans_from_messages(scene.messages())
    estimates, _ = run_offline(scans, configuration('f1tenth_moving', TrackerConfig()))
    errors = [abs(np.angle(np.exp(1j * (e.states[0, 2] - course)))) for e in estimates
              if len(e.ids)]
    assert len(errors) > 35 and max(errors) < np.deg2rad(5), np.degrees(max(errors))


@pytest.mark.parametrize('before, speed, target, accel', [
    (((1.0, 0.0, 0.0),), 0.0, 1.5, 1.0), (((0.5, 6.0, 0.0),), 6.0, 0.0, -4.0)])
def test_a_ramp_changes_the_speed_at_its_acceleration(before, speed, target, accel):
    """ramp's pieces by hand: after `before` the speed moves by |accel| per second to target,
    within one step's worth, and stays there; a curvature turns at a fixed radius."""
    pieces = ramp(before, speed, target, accel, curvature=0.1)
    start = before[0][0]
    for t in (0.25, 0.5, 0.8, 1.2, 2.0, 3.0):
        expected = speed + np.sign(target - speed) * min(abs(accel) * t, abs(target - speed))
        state = Pieces((0.0, 0.0, 0.0), pieces).state(np.array([start + t]))[0]
        assert abs(np.hypot(state[3], state[4]) - expected) <= abs(accel) * 0.05 + 1e-6, t
        assert state[5] == pytest.approx(0.1 * np.hypot(state[3], state[4]), abs=1e-6)
    assert ramp(before, target, target, 0.0)[len(before):] == ((1e6, target, 0.0),)
    with pytest.raises(ValueError):
        ramp(before, speed, target, 0.0)


@pytest.mark.parametrize('course_deg', [0, 150, 180, 250])
def test_a_parked_f1tenth_car_pulling_away_is_turned_round_as_soon_as_it_moves(course_deg):
    """An F1Tenth car parked for 1 s 2.5 m from the sensor, then pulling away at 1 m/s^2: while
    it stands its track is settled as too slow to tell, the heading the fit's (at courses 150,
    180 and 250 deg pointing backwards: nothing tells a parked box's front from its back).  Such
    a track needed its velocity past 1 std (about 0.7 m/s) to be turned round: measured before,
    180 deg off until 0.6-0.7 s after it started (0.6-0.7 m/s), now until 0.10-0.15 s
    (0.13-0.18 m/s).  Every reported heading within 5 deg once it drives at 0.3 m/s (twice its
    flip speed)."""
    course = np.deg2rad(course_deg)
    pose = (2.5 * np.cos(0.4), 2.5 * np.sin(0.4), course)
    car = Pieces(pose, ramp(((1.0, 0.0, 0.0),), 0.0, 1.5, 1.0))  # parked 1 s, then 1 m/s^2
    scene = Scene([SceneObject(1, 0.55, 0.30, car)], None, NO_WALLS, F1TENTH_LIDAR, 3.0, 0,
                  size='f1tenth')
    scans = scans_from_messages(scene.messages())
    estimates, _ = run_offline(scans, configuration('f1tenth_static', TrackerConfig()))
    errors = [abs(np.angle(np.exp(1j * (e.states[0, 2] - scan.truth[0]['yaw']))))
              for scan, e in zip(scans, estimates)
              if len(e.ids) and np.hypot(scan.truth[0]['vx'], scan.truth[0]['vy']) >= 0.3]
    assert len(errors) > 60 and max(errors) < np.deg2rad(5), np.degrees(max(errors))


@pytest.mark.parametrize('seed', [0, 2])
@pytest.mark.parametrize('start, yaw, speed', [((6.0, 0.5), 0.05, 0.8), ((5.5, -1.0), -0.1, 1.0)])
def test_two_motion_models_steady_a_far_f1tenth_cars_heading(seed, start, yaw, speed):
    """An F1Tenth car driving straight away from a static LiDAR, 6 -> 10 m, its rear face
    seen (f1tenth_static seed 301 object 1): the correction's yaw scatters, and the one agile
    model (yaw_accel_sigma 4) follows it; the preset's IMM with the calm model (0.5) does not.
    Measured, heading RMSE one model -> IMM [deg]: seed 0 3.15 -> 2.11 and 6.13 -> 5.41, seed
    2 15.09 -> 2.27 and 4.62 -> 3.41 (seeds 1 and 3 alike)."""
    scene = Scene([SceneObject(1, 0.55, 0.30, Pieces((*start, yaw), ((5.0, speed, 0.0),)))], None,
                  NO_WALLS, F1TENTH_LIDAR, 4.0, seed, size='f1tenth')
    scans = scans_from_messages(scene.messages())
    preset = configuration('f1tenth_static', TrackerConfig())
    assert preset.calm_yaw_accel_sigma > 0
    one, imm = (score(scans, run_offline(scans, config)[0])[1] for config in
                (preset.with_values(calm_yaw_accel_sigma=0.0), preset))
    assert imm.id_switches == 0 and imm.heading_rmse_deg < 0.9 * one.heading_rmse_deg, (one, imm)
    assert imm.heading_rmse_deg < 6.0, imm


def test_a_track_whose_velocity_votes_to_turn_it_waits_to_be_reported():
    """After SETTLE_TIME an unsettled track is reported with the heading it has, unless its
    velocity's last votes are for a turn (the heading is then known to be wrong: f1tenth_moving
    seed 325 object 2 was reported pointing backwards for the 2 scans before its third vote,
    heading RMSE 18 deg) or the shape has just cancelled a turn they voted for in full
    (disputed); too slow to tell, or no turn, it is reported."""
    tracker = LidarObjectTracker(TrackerConfig(min_hits=1))
    track = tracker._start(np.array([[5.0, -0.2], [5.0, 0.0], [5.0, 0.2]]), np.zeros(2), 0.0)
    tracker.time = SETTLE_TIME + 0.1
    for vote, votes, settled, expected in ((np.pi, 1, False, False), (np.pi / 2, 2, False, False),
                                           (np.pi, 0, False, True), (0.0, 2, False, True),
                                           (SLOW_VOTE, 2, False, True), (np.pi, 2, True, True)):
        track.vote, track.votes, track.settled = vote, votes, settled
        assert (tracker.reported() == [track]) == expected, (vote, votes, settled)
    # a turn voted in full and cancelled by the shape (disputed): held back, unless settled
    for disputed, settled, expected in ((True, False, False), (True, True, True),
                                        (False, False, True)):
        track.vote, track.votes, track.settled, track.disputed = np.pi / 2, 0, settled, disputed
        assert (tracker.reported() == [track]) == expected, (disputed, settled)
    track.vote, track.votes, track.settled = 0.0, 0, False
    tracker.time = SETTLE_TIME / 2
    assert tracker.reported() == []  # neither settled nor old enough


@settings(max_examples=40, deadline=None)
@given(st.floats(-np.pi, np.pi), st.floats(0.5, 3.0), st.floats(0.5, 3.0))
def test_heading_turn_is_the_nearest_quarter_to_the_velocity(heading, speed, direction):
    """Brute force: the turn is the multiple of pi/2 nearest to the velocity's angle from the
    heading, whenever the speed is well above its std and the flip speed."""
    course = heading + direction * (1 if speed > 1.5 else -1)
    state = np.array([0, 0, heading, 4 * speed * np.cos(course), 4 * speed * np.sin(course), 0])
    turn, settled = heading_turn(state, 0.01 * np.eye(2))
    quarters = np.arange(-2, 3) * np.pi / 2
    gap = np.abs(np.angle(np.exp(1j * (course - heading - quarters))))
    if np.sort(gap)[1] - np.sort(gap)[0] > 1e-6:  # not exactly between two quarters
        expected = quarters[np.argmin(gap)]
        assert settled
        assert np.isclose(np.angle(np.exp(1j * (turn - expected))), 0.0), (turn, expected)
    slow, known = heading_turn(np.array([0, 0, heading, 0.1, 0.0, 0]), 0.01 * np.eye(2))
    assert slow == 0.0 and known  # too slow to tell, and surely so: the shape decides


def test_too_slow_to_tell_only_when_speed_plus_its_std_is_below_the_flip_speed_by_hand():
    """Heading 0, flip speed 1.1 m/s, velocity std 0.7 m/s on both axes, 1 std: a velocity of
    0.6 m/s across is no turn (0.6 <= max(1.1, 0.7)) and not known to be slow (0.6 + 0.7 =
    1.3 >= 1.1): unsettled (the rule before settled it); (0.2, 0.1) m/s is (0.224 + 0.7 =
    0.924 < 1.1); with 0 stds (an unsettled track older than DIRECTION_TIME) 0.6 m/s is
    slow."""
    covariance = 0.49 * np.eye(2)
    across = np.array([0, 0, 0.0, 0.0, 0.6, 0])
    assert heading_turn(across, covariance, 1.1, 1.0) == (0.0, False)
    assert heading_turn(np.array([0, 0, 0.0, 0.2, 0.1, 0]), covariance, 1.1, 1.0) == (0.0, True)
    assert heading_turn(across, covariance, 1.1, 0.0) == (0.0, True)


def _slow_below_the_flip_speed(state, covariance, flip_speed=1.0, sigmas=3.0):
    """heading_turn with the rule before for "too slow to tell": speed below flip_speed and
    `sigmas` of each axis' std below it, each on its own."""
    turn, settled = heading_turn(state, covariance, flip_speed, sigmas)
    if turn == 0.0 and not settled:
        c, s = np.cos(state[2]), np.sin(state[2])
        stds = [np.sqrt(axis @ covariance @ axis) for axis in (np.array([c, s]),
                                                               np.array([-s, c]))]
        settled = bool(np.hypot(state[3], state[4]) < flip_speed
                       and sigmas * max(stds) < flip_speed)
    return turn, settled


def test_a_car_whose_velocity_is_still_rising_is_not_settled_as_too_slow(monkeypatch):
    """car_static seed 1126 object 1: a 2.8 m/s car fitted 90 deg off, its track started at
    rest.  On its 6th-8th updates the velocity was still rising (0.45, 0.68, 0.98 m/s, larger
    std 1.0), below the car's flip speed (1.1 m/s): taken as too slow to tell, the track settled
    with the fit's heading and was reported 90 deg off and 2.1 m from the car for 3 scans,
    until the velocity turned it (checked: position 0.43 m, heading 16 deg RMSE).  With the
    speed plus its std required below the flip speed it is reported once turned: within the
    limits."""
    scans = scans_from_messages(KINDS['car_static'](1126).messages())
    config = configuration('car_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[1]
    assert result.id_switches == 0 and result.position_rmse < 0.3, result
    assert result.heading_rmse_deg < 5.0 and result.velocity_rmse < 0.8, result
    monkeypatch.setattr(object_tracker, 'heading_turn', _slow_below_the_flip_speed)
    before = score(scans, run_offline(scans, config)[0])[1]
    assert before.position_rmse > 0.3 and before.heading_rmse_deg > 5.0, before


def test_pose_history_interpolates_and_refuses_to_guess_far():
    history = PoseHistory()
    history.add(1.0, [0.0, 0.0, np.pi - 0.1])
    history.add(2.0, [2.0, 4.0, -np.pi + 0.1])  # yaw crosses +-pi: +0.2 rad, not -6.08
    poses = history.at(np.array([1.5, 2.05]), 0.1)
    np.testing.assert_allclose(poses[0], [1.0, 2.0, np.pi], atol=1e-12)
    np.testing.assert_allclose(poses[1, :2], [2.1, 4.2], atol=1e-12)
    with pytest.raises(Exception, match='not covered'):
        history.at(np.array([2.5]), 0.1)
    np.testing.assert_allclose(to_frame(np.array([[1.0, 0.0]]), np.array([1.0, 2.0, np.pi / 2])),
                               [[1.0, 3.0]], atol=1e-12)


def test_moving_sensor_tracks_in_the_odometry_frame():
    """The sensor drives at 6 m/s along x, a car drives across in front of it: the tracks live
    in odom (the truth's frame) and match it as well as with a static sensor.  Without the
    within-scan compensation (time_increment ignored) the sensor moves 11 cm during a scan.
    Measured: position 0.017 m, heading 0.2 deg, velocity 0.16 m/s (position 0.071 m ignoring
    time_increment)."""
    sensor = Pieces((0.0, 0.0, 0.0), ((4.0, 6.0, 0.0),))
    scene = one_car_scene((14.0, -10.0, np.pi / 2), speed=6.0, sensor=sensor, duration=2.5)
    scans = scans_from_messages(scene.messages())
    assert scans[0].odometry and scans[0].time_increment > 0
    estimates, _ = run_offline(scans, TrackerConfig())
    result = score(scans, estimates)[1]
    assert result.position_rmse < 0.04 and result.heading_rmse_deg < 3.0, result
    assert result.velocity_rmse < 0.5 and result.id_switches == 0, result
    for scan in scans:
        scan.time_increment = 0.0
    uncompensated = score(scans, run_offline(scans, TrackerConfig())[0])[1]
    assert uncompensated.position_rmse > 2 * result.position_rmse


def test_size_class_priors_and_extent_converging_to_what_is_seen():
    """An F1Tenth car (0.58 m x 0.29 m) seen side-on and then from behind as it passes: the
    estimate starts from the f1tenth prior (0.55 x 0.30) and ends within 2 cm of its size."""
    assert TrackerConfig(size_class='pedestrian').priors() == (0.6, 0.6)
    assert TrackerConfig(size_class='custom', prior_length=2.0, prior_width=1.0).priors() == \
        (2.0, 1.0)
    scene = Scene([SceneObject(1, 0.58, 0.29, Pieces((0.8, -2.0, np.pi / 2),
                                                     ((3.0, 1.5, 0.0),)))],
                  None, NO_WALLS, F1TENTH_LIDAR, 2.0, 0, 'f1tenth')
    scans = scans_from_messages(scene.messages())
    tracker = LidarObjectTracker(configuration('f1tenth_static', TrackerConfig()))
    for scan in scans:
        tracks = tracker.step(scan.points, scan.time)
    assert len(tracks) == 1
    assert abs(tracks[0].length - 0.58) < 0.02 and abs(tracks[0].width - 0.29) < 0.02


def assert_kept_apart(objects, times: np.ndarray) -> None:
    """No two objects' circumscribed circles overlap at `times` [s]."""
    for i, first in enumerate(objects):
        for second in objects[i + 1:]:
            gap = np.hypot(*(first.motion.poses(times)[:, :2]
                             - second.motion.poses(times)[:, :2]).T)
            assert gap.min() > (np.hypot(first.length, first.width)
                                + np.hypot(second.length, second.width)) / 2


def test_generated_scenes_are_reproducible_and_keep_objects_apart():
    a, b = random_scene(3, 'car', moving=True), random_scene(3, 'car', moving=True)
    assert [o.length for o in a.objects] == [o.length for o in b.objects]
    assert 1 <= len(a.objects) <= 5 and a.frame == 'odom' and random_scene(3).frame == 'laser'
    assert_kept_apart(a.objects, np.arange(0.0, a.duration, 0.05))
    track = Stadium(14.0, 4.0)
    s = np.linspace(0, track.perimeter, 200, endpoint=False)
    steps = np.hypot(*np.diff(track.point(s, np.zeros_like(s)), axis=0).T)
    np.testing.assert_allclose(steps, track.perimeter / 200, rtol=1e-3)  # unit speed


def test_seen_lengths_of_a_car_driving_away_end_on_and_of_one_crossing_side_on():
    """Scene.seen_lengths, by geometry: a 4 m x 1.8 m car driving away along the sensor's x
    axis shows only its rear face (no extent along its axis); one crossing 10 m ahead at 90 deg
    shows its whole side (its length, to the beam spacing: 0.25 deg at 10 m is 4.4 cm); a scan
    where the car is out of the field of view gives 0.  The same with the sensor standing at
    (5, 5) facing +y (the beams' origins and angles in the world frame)."""
    away = SceneObject(1, 4.0, 1.8, Pieces((12.0, 0.0, 0.0), ((1.0, 5.0, 0.0),)))
    crossing = SceneObject(2, 4.0, 1.8, Pieces((10.0, -1.0, np.pi / 2), ((1.0, 2.0, 0.0),)))
    behind = SceneObject(3, 4.0, 1.8, Pieces((-10.0, 0.0, 0.0), ((1.0, 0.0, 0.0),)))
    for item, low, high in ((away, 0.0, 1e-6), (crossing, 4.0 - 0.1, 4.0 + 1e-6),
                            (behind, 0.0, 0.0)):
        scene = Scene([item], None, np.zeros((0, 2, 2)), CAR_LIDAR, 0.1, 0, 'car')
        seen = scene.seen_lengths(0)
        assert seen.shape == (4,)
        assert np.all((seen >= low) & (seen <= high)), (item.id, seen)
    sensor = Pieces((5.0, 5.0, np.pi / 2), ((1.0, 0.0, 0.0),))
    away = SceneObject(1, 4.0, 1.8, Pieces((5.0, 17.0, np.pi / 2), ((1.0, 5.0, 0.0),)))
    crossing = SceneObject(2, 4.0, 1.8, Pieces((6.0, 15.0, np.pi), ((1.0, 2.0, 0.0),)))
    behind = SceneObject(3, 4.0, 1.8, Pieces((5.0, -5.0, 0.0), ((1.0, 0.0, 0.0),)))
    for item, low, high in ((away, 0.0, 1e-6), (crossing, 4.0 - 0.1, 4.0 + 1e-6),
                            (behind, 0.0, 0.0)):
        scene = Scene([item], sensor, np.zeros((0, 2, 2)), CAR_LIDAR, 0.1, 0, 'car')
        seen = scene.seen_lengths(0)
        assert np.all((seen >= low) & (seen <= high)), ('moved sensor', item.id, seen)


@pytest.mark.parametrize('moving', [False, True], ids=['static sensor', 'moving sensor'])
def test_pedestrian_scenes_have_people_sized_walkers(moving):
    """random_scene's pedestrian class (SIZE_SETTINGS): 0.25-0.35 m x 0.45-0.60 m objects at
    0.27-1.8 m/s, 2.5-14 m out at the start, turning up to 1 rad/s, clear of the sensor and of
    each other's circles; the moving sensor at 0.54-1.44 m/s; the same seed, the same scene.
    Checked over 20 seeds against the trajectories themselves, the extremes near the bounds
    (a narrower range of speeds or turns fails too)."""
    times = np.arange(0.0, 4.0, 0.05)
    speeds, turns = [], []
    for seed in range(20):
        scene = random_scene(seed, 'pedestrian', moving)
        again = random_scene(seed, 'pedestrian', moving)
        assert [o.length for o in scene.objects] == [o.length for o in again.objects]
        assert scene.lidar == CAR_LIDAR and 1 <= len(scene.objects) <= 5
        origin = np.zeros((len(times), 2)) if scene.sensor is None else \
            scene.sensor.poses(times)[:, :2]
        if moving:
            step = np.hypot(*np.diff(origin, axis=0).T) / 0.05
            assert 0.54 <= step.min() and step.max() <= 1.44
        for item in scene.objects:
            assert 0.25 <= item.length <= 0.35 and 0.45 <= item.width <= 0.60
            poses = item.motion.poses(times)
            speed = np.hypot(*np.diff(poses[:, :2], axis=0).T) / 0.05
            assert 0.27 - 1e-9 <= speed.min() and speed.max() <= 1.8 + 1e-9
            turn = np.abs(np.diff(np.unwrap(poses[:, 2]))) / 0.05
            assert np.all(turn <= 1.0 + 1e-9)
            speeds.append(speed.mean())
            turns.append(turn.max())
            assert 2.5 <= np.hypot(*poses[0, :2]) <= 14.0
            radius = np.hypot(item.length, item.width) / 2
            assert np.hypot(*(poses[:, :2] - origin).T).min() > 1.25 * radius + 0.5
        assert_kept_apart(scene.objects, times)
    assert min(speeds) < 0.5 and max(speeds) > 1.5 and max(turns) > 0.8


def test_da_lidar_eval_lists_every_scene_kind():
    """--help's kinds (lidar_eval.SCENE_KINDS, kept without importing the generator) are
    lidar_random_scene.KINDS."""
    from data_association_ros.bag.lidar_eval import SCENE_KINDS, SCENE_LIDARS
    assert SCENE_KINDS == tuple(KINDS)
    assert SCENE_LIDARS == tuple(OTHER_LIDARS)


def test_a_pedestrian_near_the_sensor_is_tracked():
    """size_class pedestrian (the 0.6 m x 0.6 m prior), a 0.3 m x 0.5 m walker at 1.4 m/s,
    5-9.5 m from the sensor: walking straight along x from (3, 4) m (bearing 53 -> 25 deg), or
    turning at -0.4 rad/s from (2, -6) m: one id, position within 0.1 m, velocity within 0.5
    m/s, heading within 10 deg, reported on 90 % of the scans (measured: 0.014 / 0.037 m, 0.14
    / 0.23 m/s, 1.9 / 5.1 deg, 97 %).  Farther out pedestrians fare worse (docs/lidar.md,
    "Pedestrians")."""
    config = configuration('pedestrian_static', TrackerConfig())
    assert config.priors() == (0.6, 0.6)
    for start, turn in (((3.0, 4.0, 0.0), 0.0), ((2.0, -6.0, 1.0), -0.4)):
        scene = Scene([SceneObject(1, 0.3, 0.5, Pieces(start, ((5.0, 1.4, turn),)))], None,
                      NO_WALLS, CAR_LIDAR, 4.0, 0, 'pedestrian')
        result = scores_of(scene, config)[1]
        assert result.id_switches == 0 and result.coverage > 0.9, result
        assert result.position_rmse < 0.1 and result.velocity_rmse < 0.5, result
        assert result.heading_rmse_deg < 10.0, result


def test_race_scene_has_an_overtake_and_truth_by_header_stamp():
    """The committed race's scene: opponent 2 starts behind the ego and ends ahead of opponent
    1 (an overtake); truth and scans share their stamps; scans are logged after their sweep."""
    scene = race_scene(0, duration=5.0)
    ego, first, second = scene.sensor, scene.objects[0].motion, scene.objects[1].motion
    assert second.s0 < ego.s0 < first.s0
    assert second.s0 + second.speed * 5.0 > first.s0 + first.speed * 5.0
    messages = list(race_scene(0, duration=0.5).messages())
    stamps = {topic: [m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec
                      for t, m, _ in messages if t == topic]
              for topic in ('/scan', '/ground_truth/objects')}
    assert stamps['/scan'] == stamps['/ground_truth/objects'] and len(stamps['/scan']) == 20
    scan_logs = [(m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec, log)
                 for t, m, log in messages if t == '/scan']
    assert all(log > stamp for stamp, log in scan_logs)


@pytest.mark.parametrize('name', ['lidar_f1tenth_race', 'lidar_urban_random'])
def test_committed_scene_bags_regenerate(name):
    """bags/<name> = its generator's messages (deserialised, as test_bags does for the others);
    each under 2 MB."""
    from pathlib import Path

    from rclpy.serialization import deserialize_message, serialize_message

    from data_association_ros.bag.lidar_random_scene import scene_messages
    from data_association_ros.bag.reader import BagReader
    from test_bags import assert_same_message
    bag = Path(__file__).resolve().parents[1] / 'bags' / name
    assert sum(f.stat().st_size for f in bag.iterdir()) < 2e6
    committed = list(BagReader(bag).messages())
    fresh = list(scene_messages(name)())
    assert len(fresh) == len(committed)
    for (topic, msg, log_time), stored in zip(fresh, committed):
        assert (topic, log_time) == (stored.topic, stored.log_time_ns)
        msg = deserialize_message(serialize_message(msg), type(msg))  # float32 fields rounded
        assert_same_message(msg, stored.msg, f'{topic} at {log_time}')


def test_f1tenth_parameter_file_is_the_preset():
    import pathlib

    import yaml

    from data_association_ros.core.lidar.parameters import PRESETS
    path = pathlib.Path(__file__).resolve().parents[1] / 'config' / 'lidar_f1tenth.yaml'
    values = yaml.safe_load(path.read_text())['lidar_tracker_node']['ros__parameters']
    assert values == PRESETS['f1tenth']
    TrackerConfig().with_values(**values)


def test_start_velocity_by_hand():
    """Two fits 0.25 m apart 25 ms apart: 10 m/s.  Gate (gate_probability 0.99):
    chi2_2 = 9.21 times 2 x 0.3^2 + (10 m/s x 0.025 s)^2 = 0.2425 m^2: changes up to 1.49 m."""
    from data_association_ros.core.lidar.object_tracker import start_velocity
    np.testing.assert_allclose(start_velocity(np.zeros(2), np.array([0.25, 0.0]), 0.025, 0.99),
                               [10.0, 0.0])
    np.testing.assert_allclose(start_velocity(np.array([1.0, 1.0]), np.array([1.0, 2.4]), 0.025,
                                              0.99), [0.0, 56.0])
    assert start_velocity(np.zeros(2), np.array([0.0, 1.55]), 0.025, 0.99) is None
    assert start_velocity(np.zeros(2), np.array([0.1, 0.0]), 0.0, 0.99) is None


def test_fused_start_velocity_by_hand():
    """Two car fits (std 0.3 m) 25 ms apart: noise 2 x 0.09 / 0.025^2 = 288 m^2/s^2, with the
    at-rest prior's 100: gain 100 / 388, so 53 m/s -> 13.66 m/s, variance 100 x 288 / 388 =
    74.2; F1Tenth fits (std 0.3 x 0.55 / 4.5 = 0.0367 m): noise 4.30, gain 0.9588."""
    velocity, variance = fused_start_velocity(np.array([0.0, 53.0]), 0.025, 0.3, 10.0)
    np.testing.assert_allclose(velocity, [0.0, 53.0 * 100 / 388])
    assert np.isclose(variance, 100 * 288 / 388)
    fit = FIT_SIGMA_PER_LENGTH * 0.55
    assert np.isclose(fit, 0.3 * 0.55 / 4.5)
    velocity, variance = fused_start_velocity(np.array([7.0, 0.0]), 0.025, fit, 10.0)
    gain = 100 / (100 + 2 * fit ** 2 / 0.025 ** 2)
    assert np.isclose(gain, 0.9588, atol=1e-4)
    np.testing.assert_allclose(velocity, [7.0 * gain, 0.0])
    assert np.isclose(variance, (1 - gain) * 100)


def test_a_car_coming_out_from_behind_another_starts_near_its_speed():
    """car_static seed 112 object 4 (2.3 m/s) comes out from behind a car in front; two fits of
    its growing cluster 25 ms apart moved the centre by 0.29 m (11 m/s, before FACE_REACH) or 1.3
    m (53 m/s): taken as its velocity, the track was reported 9.8 m/s off (velocity RMSE 2.31
    m/s, coverage 92 %) or flew off and was dropped (the next track reported, coverage 78 %).
    Fused with the start at rest: the first track is reported, within the limits (0.33 m/s),
    coverage 86 %."""
    scans = scans_from_messages(KINDS['car_static'](112).messages())
    estimates, _ = run_offline(scans, configuration('car_static', TrackerConfig()))
    result = score(scans, estimates)[4]
    assert len(result.track_ids) == 1 and result.id_switches == 0, result
    assert result.velocity_rmse < 0.8 and result.position_rmse < 0.3, result
    assert result.coverage > 0.82, result


def test_no_two_point_start_from_a_fit_long_ago():
    """car_static seed 3009 object 1 (5.5 m/s, round the sensor) drives through the 90 deg
    behind it that no beam covers.  While it was hidden, a new track took over its coasting
    track's id and was not corrected for 0.9 s; when the car came back into view 21 m from that
    track's fit, the two-point start read the change as 22.8 m/s (velocity RMSE 5.10 m/s,
    position 0.57 m).  A two-point start now needs a fit on the scan before: measured 0.34 m/s
    and 0.19 m, no id switch."""
    scans = scans_from_messages(KINDS['car_static'](3009).messages())
    estimates, _ = run_offline(scans, configuration('car_static', TrackerConfig()))
    result = score(scans, estimates)[1]
    assert result.id_switches == 0, result
    assert result.velocity_rmse < 0.8 and result.position_rmse < 0.3, result
    visible = [bool(scan.truth[scan.truth['id'] == 1]['visible'].sum()) for scan in scans]
    assert visible[:22] == [True] * 22 and not any(visible[22:120]), visible  # the blind sector
    first_seen_again = 120
    assert visible[first_seen_again], visible
    for estimate in estimates[first_seen_again:first_seen_again + 40]:
        assert np.all(np.hypot(estimate.states[:, 3], estimate.states[:, 4]) < 12.0), estimate


def test_f1tenth_car_entering_at_speed_is_one_track_at_its_speed():
    """An F1Tenth car (0.55 m) overtaking the ego car (5 m/s, odometry) at 7 m/s, 0.8 m to its
    left, entering the 270 deg view from the blind sector behind: 17.5 cm a scan in the
    odometry frame, beyond the preset's 0.1 m nearest cut-off, so a track started at rest is
    not matched on the next scan.  Measured before the two-point start: the track was started
    anew 6 times (the one reported is the 7th), coverage 55 %; with it the first track is the
    one reported, coverage 81 %, velocity RMSE 0.09 m/s, position 3 mm; with the beam time in
    the measurement (beam_time_measurement; the car is seen 17.5-18.7 ms into the scan)
    coverage 83 %, velocity RMSE 0.15 m/s; when first reported its speed is 7.01 m/s for 7, its
    velocity across -0.64 m/s (-0.32 before; it jitters by 0.5 m/s either way on the scans
    before the report); with the two-point start read at the beams' time (2026-12-07)
    coverage 88 %, velocity RMSE 0.18 m/s, 7.13 m/s at the first report, -1.00 across."""
    car = SceneObject(1, 0.55, 0.3, Pieces((-1.5, 0.8, 0.0), ((3.0, 7.0, 0.0),)))
    ego = Pieces((0.0, 0.0, 0.0), ((3.0, 5.0, 0.0),))
    scene = Scene([car], ego, NO_WALLS, F1TENTH_LIDAR, 1.2, 0, 'f1tenth')
    scans = scans_from_messages(scene.messages())
    estimates, _ = run_offline(scans, configuration('f1tenth_static', TrackerConfig()))
    result = score(scans, estimates)[1]
    assert result.track_ids == [1] and result.id_switches == 0, result
    assert result.coverage > 0.7 and result.position_rmse < 0.02, result
    assert result.velocity_rmse < 0.25, result
    reported = [k for k, e in enumerate(estimates) if len(e.ids)]
    state, truth = estimates[reported[0]].states[0], scans[reported[0]].truth[0]
    assert abs(np.hypot(state[3], state[4]) - np.hypot(truth['vx'], truth['vy'])) < 0.3, state


def test_two_point_start_reads_its_fit_at_the_time_the_points_were_taken():
    """_restart from a cluster whose points were taken late = 0.05 s after the stamp (an
    object ahead in a 10 Hz 360 deg scan): the fit's centre c is where the object was then, so
    the state's position is c - late v and its covariance B^-1 diag(sigmas^2) B^-T (B =
    beam_time_measurement(late)): var(x) = var_fit + late^2 var(v), cov(x, vx) = -late var(v);
    the next two-point velocity is read from the fit's centre (track.fitted = c), last is the
    state at the stamp (as after an update)."""
    config = configuration('race', TrackerConfig())
    tracker = LidarObjectTracker(config)
    face = np.column_stack([np.full(9, 3.0), np.linspace(-0.15, 0.15, 9)])  # a rear face
    hidden = np.array([False, False])
    track = tracker._start(face, hidden, 0.0, 0.05)
    first = track.filter.x[:2].copy()
    moved = face + [0.6, 0.0]  # 6 m/s over the 0.1 s between the scans
    centre = tracker._fit(moved, hidden)[0]
    assert np.allclose(centre - first, [0.6, 0.0], atol=1e-9)
    tracker._restart(track, moved, hidden, 0.1, 0.05)
    variance = (1 - (100.0 / (100.0 + 2 * (FIT_SIGMA_PER_LENGTH * 0.55) ** 2 / 0.01))) * 100.0
    speed = 6.0 * (1 - variance / 100.0)  # the two-point 6 m/s fused with 0 +- 10 m/s
    assert np.allclose(track.filter.x[3:5], [speed, 0.0])
    assert np.allclose(track.filter.x[:2], centre - 0.05 * np.array([speed, 0.0]))
    assert np.allclose(track.fitted, centre) and np.allclose(track.last, track.filter.x[:3])
    p = track.filter.p
    assert np.isclose(p[0, 0], 0.3 ** 2 + 0.05 ** 2 * variance)
    assert np.isclose(p[0, 3], -0.05 * variance) and np.isclose(p[1, 4], -0.05 * variance)
    assert np.isclose(p[3, 3], variance) and np.isclose(p[2, 2], 0.2 ** 2)


def test_hand_over_leaves_last_at_the_stamp_so_the_next_velocity_is_read_right():
    """A coasting track at 6 m/s along x is found again by a track started from a rear face
    whose points were taken late = 0.05 s after the stamp t = 0.1 s: the handed state's
    position is the fit's centre c - late v (where the car was at the stamp), and last, which
    the next update's velocity measurement is read from (velocity_measurement), is that
    state.  A correction landing exactly on the car at t = 0.2 s then reads 6 m/s; with last
    left at c, as before, it read (0.6 - 0.3) / 0.1 = 3 m/s."""
    from data_association_ros.core.lidar.measurement import fictitious_measurement
    from data_association_ros.core.transforms import estimate_rigid_transform
    config = configuration('race', TrackerConfig(velocity_measurement=True))
    tracker = LidarObjectTracker(config)
    face = np.column_stack([np.full(9, 3.0), np.linspace(-0.15, 0.15, 9)])  # a rear face
    hidden = np.array([False, False])
    old = tracker._start(face, hidden, 0.0)
    old.filter.x[3:5] = [6.0, 0.0]
    new = tracker._start(face + [0.6, 0.0], hidden, 0.1, 0.05)
    centre = tracker._fit(face + [0.6, 0.0], hidden)[0]
    tracker._hand_over(old, new, 0.05)
    assert tracker.tracks == [new] and new.id == old.id
    np.testing.assert_allclose(new.filter.x[3:5], [6.0, 0.0], atol=1e-12)
    at_stamp = centre - 0.05 * np.array([6.0, 0.0])
    np.testing.assert_allclose(new.filter.x[:2], at_stamp, atol=1e-12)
    np.testing.assert_allclose(new.last, new.filter.x[:3], atol=1e-12)
    np.testing.assert_allclose(new.fitted, centre, atol=1e-12)
    predicted = new.filter.x[:2] + 0.1 * new.filter.x[3:5]
    truth = at_stamp + [0.6, 0.0]  # the car at t = 0.2 s
    shift = estimate_rigid_transform(np.array([predicted, predicted + [1.0, 0.0]]),
                                     np.array([truth, truth + [1.0, 0.0]]))
    z = fictitious_measurement(predicted, new.filter.x[2], new.last[:2], new.last[2], shift,
                               0.1)
    np.testing.assert_allclose(z[3:5], [6.0, 0.0], atol=1e-9)


def scans_seen_by(kind: str, seed: int, lidar: str) -> list:
    """The scans of a kind's scene of `seed` seen by OTHER_LIDARS[lidar]."""
    scene = dataclasses.replace(KINDS[kind](seed), lidar=OTHER_LIDARS[lidar])
    return scans_from_messages(scene.messages())


def coarse_10hz_scans(kind: str, seed: int) -> list:
    """The scans of a kind's scene of `seed` seen by 360_10hz_coarse (10 Hz, 0.5 deg, 2 cm)."""
    return scans_seen_by(kind, seed, '360_10hz_coarse')


def test_f1tenth_car_ahead_in_a_10hz_full_turn_is_tracked():
    """race seed 100 seen by a low-cost 360 deg LiDAR (360_10hz_coarse: 10 Hz, 0.5 deg):
    opponent 1, 3-4 m ahead at 5.76 m/s, is scanned 50 ms into each turn, 0.29 m ahead of
    where it is at the stamp.  Measured with the two-point start reading its fit at the stamp:
    the track was restarted on every scan (each prediction 0.27 m off the points moved back,
    beyond the 0.1 m nearest cut-off) and never reported, coverage 0 over 50 scans; now
    coverage 92 %, position RMSE 0.020 m, heading 4.8 deg, velocity 0.15 m/s, one id (with
    the calm model calm across the heading 0.020 m, 3.1 deg, 0.24 m/s).  With
    velocity_measurement (the update reads the velocity from the state at the last stamp) one
    id too: measured with last left at the fit's centre, 50 ms on, three ids.  (With
    velocity_measurement and calm_lateral_accel_sigma 1.0 together: two ids, docs/lidar.md
    "Twenty-seventh round"; the rule checked here is `last`'s, so the calm model is isotropic
    there.)"""
    scans = coarse_10hz_scans('race', 100)
    estimates, _ = run_offline(scans, configuration('race', TrackerConfig()))
    result = score(scans, estimates)[1]
    assert result.track_ids == [1] and result.coverage > 0.85, result
    assert result.position_rmse < 0.03 and result.velocity_rmse < 0.3, result
    config = configuration('race', TrackerConfig(velocity_measurement=True),
                           {'calm_lateral_accel_sigma': 0.0})
    result = score(scans, run_offline(scans, config)[0])[1]
    assert result.track_ids == [1] and result.coverage > 0.85, result


def test_an_f1tenth_car_seen_at_10hz_keeps_its_heading_by_its_velocity():
    """race seed 123 opponent 1 seen by a 10 Hz 360 deg LiDAR at 0.5 deg (360_10hz_coarse):
    entering the bend (scans 21-24) the returns of its rear face turned the box 17, 31, 47,
    60 deg the wrong way (heading RMSE 13.5 deg) while its velocity turned right.  The
    F1Tenth preset ties heading and velocity (no_slip, slip_sigma 0.3): at most 10 deg off
    there, heading RMSE 3.8 deg; position 0.033 -> 0.021 m.  Its calm model, calm across the
    heading since (calm_lateral_accel_sigma 1.0, with the gate of either model), steadies the
    velocity further: the preset 3.6 deg, 5.3 without the slip, 13.5 without either.  Since a
    settled track's points are turned back by its yaw rate (at_stamp_points: in the bend its
    rear face's returns, 0.05 s into the scan, were taken 4 deg further round, at 73 deg/s)
    3.2 deg, 3.5 without the slip, 12.3 without either: no longer a witness of the slip
    (test_slip_sigma_turns_a_cars_velocity_to_its_accurate_heading and the free-space tests
    are), still one of the calm model's lateral noise and the slip together."""
    scans = coarse_10hz_scans('race', 123)
    config = configuration('race', TrackerConfig())
    assert config.slip_sigma == 0.3
    result = score(scans, run_offline(scans, config)[0])[1]
    assert result.track_ids == [1] and result.heading_rmse_deg < 5.0, result
    assert result.position_rmse < 0.03 and result.velocity_rmse < 0.4, result
    before = score(scans, run_offline(scans, config.with_values(
        slip_sigma=0.0, calm_lateral_accel_sigma=0.0))[0])[1]
    assert before.heading_rmse_deg > 10.0, before
    no_slip = score(scans, run_offline(scans, config.with_values(slip_sigma=0.0))[0])[1]
    assert result.heading_rmse_deg <= no_slip.heading_rmse_deg < 5.0, (no_slip, result)


def test_f1tenth_cars_driving_away_seen_at_10hz_keep_their_heading():
    """f1tenth_static seed 111 seen by 360_10hz_coarse: cars 1 and 3 drive away 3-10 m from
    the sensor, only their 0.3 m rear faces seen (4-14 returns, 2 cm noise), which turn the box
    by +-10 deg a scan.  With the calm model's isotropic 4 m/s^2/sqrt(Hz) the velocity (and with
    slip_sigma the heading) followed them: heading 7.9 / 8.8 deg, position 0.042 / 0.074 m.  The
    preset's calm model, once the heading is settled, accelerates across it by 1 m/s^2/sqrt(Hz)
    only (along it by accel_sigma): 3.1 / 5.3 deg, 0.022 / 0.046 m (4.5 deg for car 3 with the
    lateral noise from its start on, which lets a box still 90 deg off hold the velocity back:
    f1tenth_static 213/1 at 40 Hz 0.7 -> 9.5 deg).  Since a settled track's points are also
    turned back by its yaw rate (at_stamp_points), most of that was the heading read at the
    beams' time: the preset 3.0 / 5.3 deg, 0.022 / 0.047 m, the isotropic calm model 3.1 / 5.7
    deg, 0.021 / 0.043 m (2026-12-07).  So this is no longer a witness of
    calm_lateral_accel_sigma (race seed 123 is, with the slip: 12.3 deg without either): it
    holds the preset to the limits here and to no worse than the isotropic model."""
    scans = coarse_10hz_scans('f1tenth_static', 111)
    config = configuration('f1tenth_static', TrackerConfig())
    assert config.calm_lateral_accel_sigma == 1.0 and config.calm_yaw_accel_sigma > 0
    calm, isotropic = (score(scans, run_offline(scans, c)[0]) for c in
                       (config, config.with_values(calm_lateral_accel_sigma=0.0)))
    for car in (1, 3):
        assert len(calm[car].track_ids) == 1 and calm[car].position_rmse < 0.05, calm[car]
        assert isotropic[car].position_rmse < 0.05, isotropic[car]
        assert calm[car].heading_rmse_deg < isotropic[car].heading_rmse_deg + 0.5, \
            (calm[car], isotropic[car])
    assert calm[1].heading_rmse_deg < 5.0 and isotropic[1].heading_rmse_deg < 5.0, \
        (calm, isotropic)
    assert calm[2].heading_rmse_deg < 5.0, calm


def test_a_heading_in_dispute_is_not_reported_at_settle_time():
    """f1tenth_static seed 5020 seen by 360_10hz_coarse: car 1 (2.3 m/s, 2.5-3 m from the
    sensor) is fitted a 0.47 x 0.43 m box 98 deg off its heading.  Its velocity voted to turn
    the box across three updates in a row; on the third, 0.5 s after the track started, the
    cluster's shape cancelled the turn (plausible_turn) and, no longer voting, the track was
    reported at SETTLE_TIME with that heading: 98 deg off on its first reported scan, heading
    RMSE 16.6 deg.  The heading is in dispute then (turning): the track is reported from the
    next scan, where the box is turned along the velocity: heading RMSE 1.1 deg, every scan
    within 10 deg, coverage 85 % (88 % before)."""
    scans = coarse_10hz_scans('f1tenth_static', 5020)
    config = configuration('f1tenth_static', TrackerConfig())
    estimates, _ = run_offline(scans, config)
    result = score(scans, estimates)[1]
    assert result.track_ids == [1] and result.heading_rmse_deg < 5.0, result
    assert result.coverage > 0.8, result
    errors = []
    for scan, estimate in zip(scans, estimates):
        row = scan.truth[scan.truth['id'] == 1]
        if len(row) and row['visible'][0] >= 5 and 1 in estimate.ids:
            state = estimate.states[list(estimate.ids).index(1)]
            errors.append(np.degrees(abs(np.angle(np.exp(1j * (state[2] - row['yaw'][0]))))))
    assert len(errors) > 25 and max(errors) < 10.0, errors


def test_a_track_wider_than_a_car_is_not_settled_as_too_slow():
    """car_static seed 6101 object 5: a 4.97 m car at 3.5 m/s coming out from behind something
    at 25 m, first fitted across its heading.  Its side grew into view as the box's width
    (1.80 -> 2.55 m in 0.3 s) instead of moving it, so the velocity read 0 +- 1.0 m/s and
    the track settled as too slow to tell, reported 90 deg off (heading RMSE 60 deg, position
    1.43 m on its first reported scans).  Returns spreading across the heading wider than
    WIDTH_SLACK x the prior width are no car's width: not known to be slow, the track is not
    settled and the shape turns it before SETTLE_TIME (heading RMSE 0.5 deg)."""
    scans = scans_from_messages(KINDS['car_static'](6101).messages())
    estimates, _ = run_offline(scans, configuration('car_static', TrackerConfig()))
    result = score(scans, estimates)[5]
    assert result.id_switches == 0 and result.heading_rmse_deg < 5.0, result
    assert result.position_rmse < 0.3 and result.coverage > 0.5, result


def test_car_found_again_off_its_coasting_prediction_keeps_its_id():
    """An F1Tenth car at 3 m/s, 3 m to the side, hidden behind a parked one (1.5 m from the
    sensor) while it turns left at 1 rad/s for 0.5 s: found again about 0.3 m off its
    straight coasting prediction, beyond the 0.1 m nearest cut-off.  Measured before the hand
    over: a new track, one id switch (track ids [2, 3]), heading RMSE 5.3 deg; with it the
    track that took the cluster in the coarse gate keeps its id (one id, no switch), heading
    0.6 deg, coverage 86 % (the new estimate is reported once its heading is settled)."""
    car = SceneObject(1, 0.55, 0.3, Pieces((-2.5, 3.0, 0.0), ((0.6, 3.0, 0.0), (0.5, 3.0, 1.0),
                                                              (3.0, 3.0, 0.0))))
    parked = SceneObject(2, 0.55, 0.3, Pieces((0.0, 1.5, 0.0), ((5.0, 0.0, 0.0),)))
    scene = Scene([car, parked], None, NO_WALLS, F1TENTH_LIDAR, 2.0, 0, 'f1tenth')
    scans = scans_from_messages(scene.messages())
    hidden = [k for k, s in enumerate(scans) if s.truth['visible'][0] < 5 and 10 < k < 60]
    assert len(hidden) >= 10  # hidden for at least 0.25 s
    estimates, _ = run_offline(scans, configuration('f1tenth_static', TrackerConfig()))
    result = score(scans, estimates)[1]
    assert len(result.track_ids) == 1 and result.id_switches == 0, result
    assert result.heading_rmse_deg < 3.0 and result.position_rmse < 0.03, result


def test_handed_velocity_keeps_the_speed_along_the_length_axis():
    """A coasting track's velocity (-5.5, -5.7) (7.92 m/s, turned 46 deg by its yaw rate while
    it coasted) handed to a rectangle fitted along yaw 0: (-7.92, 0), backwards along it."""
    from data_association_ros.core.lidar.object_tracker import handed_velocity
    np.testing.assert_allclose(handed_velocity(np.array([-5.5, -5.7]), 0.0),
                               [-np.hypot(5.5, 5.7), 0.0], atol=1e-12)
    np.testing.assert_allclose(handed_velocity(np.array([3.0, 4.0]), np.pi / 2), [0.0, 5.0],
                               atol=1e-12)
    np.testing.assert_allclose(handed_velocity(np.zeros(2), 1.0), [0.0, 0.0])


def _track(track_id, state, variances, hits, updated, born=0.0, length=0.55, width=0.3,
           anchor=(0.0, 0.0)):
    motion = KalmanFilter(np.asarray(state, float), np.diag(np.asarray(variances, float)),
                          np.eye(6), np.eye(6), np.eye(6), np.eye(6))
    return ObjectTrack(track_id, motion, length, width, np.array(anchor, float), hits=hits,
                       updated=updated, born=born)


@pytest.mark.parametrize('yaw, across, unsure', [(0.0, 4, (0.032, 0.2, 0.01 - 0.032 ** 2 * 1.25)),
                                                  (np.pi / 2, 3, (-0.04 / 1.1, 4 - 4 / 1.1,
                                                                  0.01 - 0.01 ** 2 / 1.1))])
def test_no_slip_by_hand(yaw, across, unsure):
    """Velocity (4, 1) m/s, P_v = I, sigma 0.3.  Yaw known (variance 0): the component across
    the heading (vy for yaw 0, -vx for yaw 90 deg) becomes 0.09 / 1.09 of itself, its variance
    0.09 / 1.09; the rest is unchanged.  Yaw variance 0.01 (an EKF update with H = [0, 0,
    -(cos yaw vx + sin yaw vy), -sin yaw, cos yaw, 0]): yaw 0: S = 16 0.01 + 1 + 0.09 = 1.25,
    innovation -1, gain (yaw, vy) = (-0.04, 1) / 1.25: yaw 0.032 rad, vy 0.2 m/s, var(yaw)
    0.01 - 0.032^2 1.25; yaw 90 deg: S = 0.01 + 1 + 0.09 = 1.1, innovation 4, gain (yaw, vx) =
    (-0.01, -1) / 1.1: yaw - 0.04 / 1.1, vx 4 - 4 / 1.1, var(yaw) 0.01 - 0.01^2 / 1.1; the
    position, the velocity along the heading and the yaw rate unchanged."""
    track = _track(1, [2.0, 3.0, yaw, 4.0, 1.0, 0.1], [0.1, 0.1, 0.0, 1.0, 1.0, 1.0], 5, 0.0)
    before = track.filter.x.copy()
    no_slip(track.filter, 0.3)
    x, p = track.filter.x, track.filter.p
    assert np.isclose(x[across], before[across] * 0.09 / 1.09)
    assert np.isclose(p[across, across], 0.09 / 1.09)
    kept = [k for k in range(6) if k != across]
    np.testing.assert_allclose(x[kept], before[kept])
    turned, velocity, variance = unsure
    track = _track(1, [2.0, 3.0, yaw, 4.0, 1.0, 0.1], [0.1, 0.1, 0.01, 1.0, 1.0, 1.0], 5, 0.0)
    no_slip(track.filter, 0.3)
    x, p = track.filter.x, track.filter.p
    assert np.isclose(x[2], yaw + turned) and np.isclose(x[across], velocity)
    assert np.isclose(p[2, 2], variance)
    kept = [k for k in range(6) if k not in (2, across)]
    np.testing.assert_allclose(x[kept], before[kept])


def test_slip_sigma_turns_a_cars_velocity_to_its_accurate_heading():
    """car_static seed 627, object 1: its heading is within 0.3 deg RMSE, but on its first
    scans its velocity points across it ((3.66, -2.44) for (4.19, -1.13) m/s): velocity RMSE
    0.98 m/s, over the 0.8 limit.  With slip_sigma 0.3 (no_slip after each settled update) it
    is 0.54 m/s; heading 0.65 deg (0.33 without), position 0.053 m (0.048)."""
    scans = scans_from_messages(KINDS['car_static'](627).messages())
    results = {}
    for slip in (0.0, 0.3):
        config = configuration('car_static', TrackerConfig(slip_sigma=slip))
        results[slip] = score(scans, run_offline(scans, config)[0])[1]
    assert results[0.0].velocity_rmse > 0.9 and results[0.3].velocity_rmse < 0.6, results
    for result in results.values():
        assert result.track_ids == [1] and result.heading_rmse_deg < 1.0, result
        assert result.position_rmse < 0.06, result


@given(st.floats(-np.pi, np.pi), st.floats(-20, 20), st.floats(-20, 20))
@settings(max_examples=50, deadline=None)
def test_lateral_velocity_is_the_velocity_across_the_heading(yaw, vx, vy):
    """The innovation is minus the velocity's component along the heading's left normal, and H
    its Jacobian (central differences)."""
    state = np.array([1.0, 2.0, yaw, vx, vy, 0.3])
    innovation, h = lateral_velocity(state)
    assert np.isclose(innovation[0], -np.array([-np.sin(yaw), np.cos(yaw)]) @ [vx, vy])
    step = 1e-6
    numeric = [(lateral_velocity(state - step * e)[0][0] - lateral_velocity(state + step * e)[0][0])
               / (2 * step) for e in np.eye(6)]
    np.testing.assert_allclose(h[0], numeric, atol=1e-6)


def test_same_object_gate_by_hand():
    """e = (0.6, -0.8, 1, 0) in (x, y, vx, vy), P_old + P_new = diag(0.5, 0.5, 1, 1) + diag(
    0.5, 0.5, 1, 1): d2 = 0.36 + 0.64 + 0.5 = 1.5, inside chi2(0.99, 4) = 13.28; 10x the
    offset: d2 = 100 + 0.5, outside (a coasting wall piece 10 m off does not hand its id)."""
    tracker = LidarObjectTracker(TrackerConfig(gate_probability=0.99))
    old = _track(1, [0, 0, 0, 2, 0, 0], [0.5, 0.5, 1, 1, 1, 1], 10, 0.0)
    new = _track(2, [0.6, -0.8, 0, 3, 0, 0], [0.5, 0.5, 1, 1, 1, 1], 1, 1.0)
    assert np.isclose(tracker._same_object(old, new), 1.5)
    far = _track(3, [6.0, -8.0, 0, 3, 0, 0], [0.5, 0.5, 1, 1, 1, 1], 1, 1.0)
    assert tracker._same_object(old, far) is None


def test_dropped_duplicate_gives_its_id_to_the_unconfirmed_track_only():
    """A confirmed track (id 1, not updated now) whose centre lies in the rectangle of a track
    updated now is dropped; the newer track takes id 1 when it is not confirmed yet (the same
    object found again), and keeps its own when it is (another object)."""
    for hits, expected in ((1, 1), (5, 7)):
        tracker = LidarObjectTracker(configuration('f1tenth_static', TrackerConfig()))
        old = _track(1, [0.1, 0.05, 0, 0, 0, 0], np.ones(6), 40, 0.5)
        newer = _track(7, [0, 0, 0, 0, 0, 0], np.ones(6), hits, 1.0, born=0.9)
        tracker.tracks = [old, newer]
        tracker._drop_duplicates(1.0)
        assert tracker.tracks == [newer] and newer.id == expected


def _coasting_and_young(hits, born):
    """(a published track coasting since 0.2 s, a track updated at 1.0 s with `hits` updates,
    born at `born`, within the coasting one's same-object gate)."""
    coasting = _track(2, [1.0, 1.0, 0, -7, 1, 0], [2, 5, 1, 9, 30, 1], 100, 0.2)
    coasting.published = True
    young = _track(9, [1.3, 0.4, 0, -6.5, -1, 0], [0.01, 0.01, 0.01, 1, 1, 1], hits, 1.0,
                   born=born)
    return coasting, young


def test_young_track_beside_a_coasting_one_continues_its_id():
    """A young track confirmed now (min_hits updates) within the same-object gate of a
    confirmed track that coasts (not updated now, born before it) takes its id and the coasting
    one is dropped; a track that was updated now, or one outside the gate, is left alone."""
    config = configuration('f1tenth_static', TrackerConfig())
    tracker = LidarObjectTracker(config)
    coasting, young = _coasting_and_young(config.min_hits, born=0.5)
    updated = _track(3, [1.2, 0.4, 0, -7, 0, 0], [0.01] * 6, 100, 1.0)
    far = _track(4, [9.0, -6.0, 0, -7, 0, 0], [0.01] * 6, 100, 0.3)
    for track in (updated, far):
        track.published = True
    tracker.tracks = [coasting, updated, far, young]
    tracker._continue_confirmed(1.0)
    assert young.id == 2 and young.continues
    assert [t.id for t in tracker.tracks] == [3, 4, 2]


def test_every_reported_track_is_published_and_no_other():
    """`step` marks the tracks it reports published, and only those: over a car scene, after
    each scan a track is published exactly when it has been reported at some scan so far."""
    scans = scans_from_messages(KINDS['car_static'](1098).messages())
    tracking = LidarTracking(configuration('car_static', TrackerConfig()))
    ever = set()
    for scan in scans:
        reported = tracking.step(scan.points, scan.time, scan.time_increment, scan.frame,
                                 scan.max_range)
        ever |= {id(track) for track in reported}
        assert all(track.published for track in reported)
        assert {id(t) for t in tracking.tracker.tracks if t.published} == \
            ever & {id(t) for t in tracking.tracker.tracks}
    assert ever


@pytest.mark.parametrize('published, settled, continues', [
    (False, True, True),     # first reported now: its id is still open
    (True, True, False),     # reported before: its id has been seen, it keeps it
    (False, False, False)])  # not reportable yet (heading voting, younger than SETTLE_TIME)
def test_a_track_past_min_hits_continues_an_id_only_at_its_first_report(published, settled,
                                                                        continues):
    """The young track of _coasting_and_young, but updated min_hits + 2 times (it was not
    reported at its min_hits-th update): it continues the coasting track's id when it is
    reported for the first time now (settled, never published), not when it has been reported
    before or is not reported now."""
    config = configuration('f1tenth_static', TrackerConfig())
    tracker = LidarObjectTracker(config)
    coasting, young = _coasting_and_young(config.min_hits + 2, born=0.8)
    young.published, young.settled = published, settled
    tracker.tracks = [coasting, young]
    tracker._continue_confirmed(1.0)
    assert (young.id, young.continues) == ((2, True) if continues else (9, False))
    assert [t.id for t in tracker.tracks] == ([2] if continues else [2, 9])


def test_a_new_track_is_found_again_as_the_nearest_gated_track():
    """A new track at the car (at rest, velocity std 10 m/s) is inside the same-object gate of
    the car's own track (updated 0.03 s before, 0.1 m off: d2 = 0.01 / 0.10 + 9.33^2 / 101 =
    0.96) and of a wide coasting track 7.1 m away (d2 = 7.1^2 / 20.09 + 0.1^2 / 120 = 2.51):
    it is the car's (car_static seed 518: the wide one, which took the car's cluster in the
    coarse association, handed its id before); a confirmed track updated now, or one not yet
    confirmed, is never found again, nor one coasting longer that did not take the cluster."""
    config = configuration('car_static', TrackerConfig())
    tracker = LidarObjectTracker(config)
    car = _track(1, [25.0, 7.8, 0, 9.33, 0, 0], [0.01, 0.01, 0.01, 1, 1, 1], 140, 4.47)
    wide = _track(2, [18.0, 7.8, 0, 0.1, 0, 0], [20, 20, 1, 20, 20, 1], 36, 2.9, length=17.7)
    new = _track(3, [25.1, 7.8, 0, 0, 0, 0], [0.09, 0.09, 0.04, 100, 100, 1], 1, 4.5, born=4.5)
    tracker.tracks = [wide, car, new]
    assert np.isclose(tracker._same_object(car, new), 0.01 / 0.1 + 9.33 ** 2 / 101)
    assert np.isclose(tracker._same_object(wide, new), 7.1 ** 2 / 20.09 + 0.1 ** 2 / 120)
    assert tracker._found_again(new, 4.5, 4.47, wide) is car
    assert tracker._found_again(new, 4.5, 4.47, None) is car
    car.updated = 4.5
    assert tracker._found_again(new, 4.5, 4.47, wide) is wide
    assert tracker._found_again(new, 4.5, 4.47, None) is None  # wide coasts since 2.9 s
    wide.hits = config.min_hits - 1
    assert tracker._found_again(new, 4.5, 4.47, wide) is None


def test_extent_covariance_by_hand():
    """R diag((L/2)^2, (W/2)^2) R^T for L = 4, W = 2: diag(4, 1) along x, diag(1, 4) along y,
    [[2.5, 1.5], [1.5, 2.5]] at 45 deg."""
    np.testing.assert_allclose(extent_covariance(0.0, 4.0, 2.0), np.diag([4.0, 1.0]))
    np.testing.assert_allclose(extent_covariance(np.pi / 2, 4.0, 2.0), np.diag([1.0, 4.0]),
                               atol=1e-12)
    np.testing.assert_allclose(extent_covariance(np.pi / 4, 4.0, 2.0),
                               [[2.5, 1.5], [1.5, 2.5]])


def test_the_far_end_of_a_car_goes_to_its_track_not_to_a_long_coasting_one():
    """A car (4.5 x 1.8 m at (10, 0), yaw 0, position variance 1 m^2) last seen at its near end
    (anchor (-1.5, 0): (8.5, 0)); now its far end shows, centroid (11.5, 0), 3 m on.  A track
    coasting for long (position variance 400 m^2) lies 30 m from it.  Without the extent the
    car's d2 is 9 / (1 + 0.5^2 + 0.05^2) = 7.19 (in the 99 % gate, 9.21) and the coasting
    track's 900 / 400.25 = 2.25: the coasting track took the cluster (car_static seed 203
    object 1: its id switched so).  With it the car's d2 is 9 / (1.2525 + 2.25^2) = 1.43."""
    car = _track(1, [10.0, 0, 0, 0, 0, 0], [1.0, 1.0, 0.01, 1.0, 1.0, 0.1], 10, 0.9,
                 length=4.5, width=1.8, anchor=(-1.5, 0.0))
    coasting = _track(2, [11.5, 30.0, 0, 0, 0, 0], [400.0, 400.0, 0.1, 100.0, 100.0, 1.0], 10,
                      0.0, length=4.5, width=1.8)
    tracker = LidarObjectTracker(configuration('car_static', TrackerConfig()))
    tracker.tracks = [car, coasting]
    points = np.array([[11.5, -0.5], [11.5, 0.5]])
    assert tracker._coarse(points, np.array([0, 0]), 1, None) == {0: [0]}  # one tier
    tracker.tracks = [coasting, car]  # the order does not decide it
    assert tracker._coarse(points, np.array([0, 0]), 1, None) == {1: [0]}


@pytest.mark.parametrize('occluders', [False, True])
def test_no_track_starts_from_a_cluster_hidden_at_both_ends(occluders):
    """A 0.64 m piece of wall 8 m away (beams -0.04..0.04 rad) starts a track when nothing
    hides its ends; between two small objects 4 m away (beams -0.08..-0.045 and 0.045..0.08 rad,
    both ends of the wall piece occluded) it starts none, the two objects each start one."""
    angles = np.arange(-0.3, 0.3001, 0.005)
    ranges = np.full(len(angles), np.nan)
    ranges[np.abs(angles) <= 0.04 + 1e-9] = 8.0
    if occluders:
        ranges[(np.abs(angles) > 0.04 + 1e-9) & (np.abs(angles) <= 0.08 + 1e-9)] = 4.0
    points = ranges[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])
    tracker = LidarObjectTracker(configuration('f1tenth_static', TrackerConfig()))
    tracker.step(points, 0.0, directions=np.column_stack([np.cos(angles), np.sin(angles)]))
    distances = sorted(float(np.hypot(*t.filter.x[:2])) for t in tracker.tracks)
    if occluders:
        assert len(distances) == 2 and max(distances) < 5.0, distances
    else:
        assert len(distances) == 1 and 7.5 < distances[0] < 9.0, distances


@pytest.mark.parametrize('seed', [
    106,  # a table seed: opponent 2 hidden behind opponent 1 on the curve for about 1 s; before
    # the same-object gate and the id continuation its track drifted on with the curve's yaw
    # rate, was dropped, and the car came back as a new track (ids [1, 12])
    521,  # a check seed: the piece of wall between the two opponents' shadows slid with them and
    # was tracked as a car at 6.8 m/s 0.75 m beside opponent 2, whose id it later took (ids
    # [2, 8]) before a cluster occluded at both ends stopped starting tracks
])
def test_race_hidden_opponent_keeps_its_id(seed):
    """Race seeds whose opponent 2 switched ids (see each seed's comment): now one id, within
    the F1Tenth limits."""
    scans = scans_from_messages(KINDS['race'](seed).messages())
    estimates, _ = run_offline(scans, configuration('race', TrackerConfig()))
    result = score(scans, estimates)[2]
    assert result.id_switches == 0 and len(result.track_ids) == 1, result
    assert result.position_rmse < 0.05 and result.heading_rmse_deg < 5.0, result


def test_across_spread_by_hand():
    """A 3 m x 0.5 m block of points: 0.5 m across heading 0, 3 m across heading pi/2."""
    points = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 0.5], [1.0, 0.2]])
    assert np.isclose(across_spread(points, 0.0), 0.5)
    assert np.isclose(across_spread(points, np.pi / 2), 3.0)
    assert np.isclose(across_spread(points, np.pi), 0.5)


CAR = (4.5, 1.8)
SIDE = np.column_stack([np.linspace(20.0, 23.6, 30), np.full(30, -3.0)])  # 3.6 m along x
END = np.column_stack([np.full(15, 20.0), np.linspace(-3.0, -1.3, 15)])  # 1.7 m along y


def test_plausible_turn_cancels_a_turn_that_would_make_a_side_a_width():
    """3.6 m of a car's side along its heading 0: a velocity vote across (+-pi/2) would make it
    a 3.6 m width (limit 1.25 x 1.8 = 2.25 m): cancelled, unless the heading was settled.  1.7 m
    of an end face seen across heading 0 (a width of 1.7 m: plausible): the vote stands, and so
    does a turn round (pi)."""
    for turn in (np.pi / 2, -np.pi / 2):
        assert plausible_turn(SIDE, 0.0, np.array([0.0, 5.0]), turn, False, *CAR) == 0.0
        assert plausible_turn(SIDE, 0.0, np.array([0.0, 5.0]), turn, True, *CAR) == turn
    end_along = END @ np.array([[0.0, 1.0], [1.0, 0.0]])  # the same face along x
    assert plausible_turn(end_along, 0.0, np.zeros(2), np.pi / 2, False, *CAR) == np.pi / 2
    assert plausible_turn(SIDE, 0.0, np.zeros(2), np.pi, False, *CAR) == np.pi


def test_plausible_turn_turns_an_unsettled_side_read_as_a_width():
    """3.6 m of returns across heading pi/2 (the side of a car fitted as its end): an unsettled
    track is turned across, the way nearer to its velocity; a settled one, a short face, and a
    square prior (a pedestrian: either axis fits) are left alone."""
    assert plausible_turn(SIDE, np.pi / 2, np.array([3.0, 0.5]), 0.0, False, *CAR) == \
        -np.pi / 2  # heading pi/2 - pi/2 = 0, along +x with the velocity
    assert plausible_turn(SIDE, np.pi / 2, np.array([-3.0, 0.5]), 0.0, False, *CAR) == \
        np.pi / 2  # heading pi: along -x
    assert plausible_turn(SIDE, np.pi / 2, np.array([3.0, 0.5]), 0.0, True, *CAR) == 0.0
    assert plausible_turn(END, 0.0, np.array([3.0, 0.0]), 0.0, False, *CAR) == 0.0
    assert plausible_turn(SIDE, np.pi / 2, np.array([3.0, 0.5]), 0.0, False, 0.6, 0.6) == 0.0
    assert plausible_turn(SIDE, 0.0, np.zeros(2), np.pi / 2, False, 0.6, 0.6) == np.pi / 2


@pytest.mark.parametrize('seed, before_deg', [(204, 20.0), (407, None)])
def test_a_cars_side_is_not_taken_for_its_width(seed, before_deg, monkeypatch):
    """car_static seed 204 object 4 (3.5 m/s) comes out from behind something: its first
    returns, a piece of its side, were fitted as its end; the side growing as it came out was
    read as a growing width (4.3 m), not as motion, and the track settled as too slow with its
    box 90 deg off (heading RMSE 23.8 deg).  Seed 407 object 4, found again after an occlusion
    with the right heading, was then voted across by its first velocity estimates (a few
    returns of its side at 30 m: (7.9, 3.2) m/s for (4.8, -1.2)), 2.7 m of side becoming its
    width (23.5 deg).  With WIDTH_SLACK: under 1 deg, one track.  Since the beam time is in
    the measurement (beam_time_measurement) 407's first velocity no longer votes it across
    (0.6 deg without WIDTH_SLACK): the control is 204's alone."""
    scans = scans_from_messages(KINDS['car_static'](seed).messages())
    config = configuration('car_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[4]
    assert result.heading_rmse_deg < 1.0 and result.id_switches == 0, result
    if before_deg is None:
        return
    monkeypatch.setattr(object_tracker, 'WIDTH_SLACK', np.inf)
    before = score(scans, run_offline(scans, config)[0])[4]
    assert before.heading_rmse_deg > before_deg, before


def test_an_f1tenth_car_found_again_keeps_its_id_and_speed():
    """f1tenth_static seed 626 object 1 (1.5 m/s) comes back after 0.75 s behind another car;
    the track started from its first 5 returns is handed the old id and speed.  Before: with
    the start's 10 m/s velocity std, the next fit's 0.27 m offset read as 5.3 m/s, the
    prediction left the car, and the track, 2 updates old (min_hits 3), was neither kept nor
    continued by the track started next: ids [1, 4].  A track continuing an id counts as
    established (LidarObjectTracker._established): one id, velocity within 0.1 m/s RMSE."""
    scans = scans_from_messages(KINDS['f1tenth_static'](626).messages())
    estimates, _ = run_offline(scans, configuration('f1tenth_static', TrackerConfig()))
    result = score(scans, estimates)[1]
    assert result.track_ids == [1] and result.id_switches == 0, result
    assert result.velocity_rmse < 0.1 and result.position_rmse < 0.01, result


def test_refit_along_by_hand():
    """Axes, not directions: a fit at 0.9 rad against a settled 0 is 51.6 deg across (refit),
    at 0.7 rad 40.1 deg (kept), at pi + 1.2 68.8 deg (refit), at pi - 0.1 5.7 deg (kept).  A
    fit at 1 rad of a line across it (direction 1 + pi/2) spreads L sin(1 + pi/2) across the
    old heading 0: 2.3 m is more than WIDTH_SLACK x 1.8 m = 2.25 m, no car seen along it
    (kept); 2.2 m is (refit).  A fit at pi/2 of a line along it, 1.9 m, longer than the prior
    width, was no ambiguous fit (kept); 1.7 m was (refit)."""
    def line(length, direction):
        return [10.0, 0.0] + np.outer(np.linspace(0.0, length, 5),
                                      [np.cos(direction), np.sin(direction)])
    short = line(0.28, np.pi / 4)
    assert refit_along(0.9, 0.0, short, 1.8)
    assert not refit_along(0.7, 0.0, short, 1.8)
    assert refit_along(np.pi + 1.2, 0.0, short, 1.8)
    assert not refit_along(np.pi - 0.1, 0.0, short, 1.8)
    across = 1.0 + np.pi / 2
    assert not refit_along(1.0, 0.0, line(2.3 / np.sin(across), across), 1.8)
    assert refit_along(1.0, 0.0, line(2.2 / np.sin(across), across), 1.8)
    assert not refit_along(np.pi / 2, 0.0, line(1.9, np.pi / 2), 1.8)
    assert refit_along(np.pi / 2, 0.0, line(1.7, np.pi / 2), 1.8)


def test_a_car_found_again_fitted_across_keeps_its_axis(monkeypatch):
    """car_static seed 1021 object 1 (1.95 m/s at 29 m) comes back from 1 s behind something;
    the track started from its first 5 returns was fitted 90 deg off and handed the coasting
    track's id and speed along that axis: the box stayed across the car for 14 scans (heading
    RMSE 42 deg, position 0.72 m).  Fitted again along the old track's settled axis
    (refit_along): heading RMSE under 1 deg, position under 0.3 m."""
    scans = scans_from_messages(KINDS['car_static'](1021).messages())
    config = configuration('car_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[1]
    assert result.id_switches == 0 and result.heading_rmse_deg < 1.0, result
    assert result.position_rmse < 0.3 and result.velocity_rmse < 0.8, result
    monkeypatch.setattr(object_tracker, 'refit_along', lambda *args: False)
    before = score(scans, run_offline(scans, config)[0])[1]
    assert before.heading_rmse_deg > 20.0, before


def test_a_refit_farther_from_the_coasting_prediction_is_not_taken():
    """f1tenth_moving seed 1000 object 1, found again 2.4 m from the sensor after 1.5 s behind
    another car: 5 returns fitted at 180 deg against a coasted heading of -52 deg.  fit_at
    along -52 deg extends them away from the sensor, 0.5 m from the car (velocity RMSE 1.05
    m/s when taken); that rectangle's centre is farther from the coasting track's prediction
    than the fit's, so the fit stays (_hand_over): velocity 0.28-0.29 m/s, position 0.022-0.026
    m.  The heading RMSE depends on the machine's floating-point kernels (the car is found again
    with 3-7 returns, a knife edge): 3.9 deg with OpenBLAS' Sandybridge kernels, 11.4 deg (30-50
    deg off on scans 71-76) with its Haswell ones on an AMD EPYC without AVX-512, so only a
    bound above both is asserted (docs/lidar.md "Results that depend on the CPU")."""
    scans = scans_from_messages(KINDS['f1tenth_moving'](1000).messages())
    result = score(scans, run_offline(scans, configuration('f1tenth_moving',
                                                           TrackerConfig()))[0])[1]
    assert result.id_switches == 0 and result.velocity_rmse < 0.5, result
    assert result.position_rmse < 0.05 and result.heading_rmse_deg < 15.0, result


def test_a_heading_coasted_round_a_bend_does_not_refit_the_car_found_again(monkeypatch):
    """race seed 1175 object 2 comes back after 1.25 s behind the other car, on the straight
    after a bend: its coasting track's heading turned on with the bend's yaw rate, 130 deg since
    its last update, and its 6 returns were fitted right (180 deg).  Fitted again along the
    coasted heading, the box was 68 deg off (heading RMSE 4.5 -> 6.6 deg); beyond
    TRUSTED_COAST_TURN (45 deg) the fit stays: within the limits.  Since the F1Tenth preset
    ties heading and velocity (slip_sigma 0.3, 2026-12-07) the velocity turns such a box back
    within a few scans (2.7 deg with the refit), so the rule is checked without it too."""
    scans = scans_from_messages(KINDS['race'](1175).messages())
    config = configuration('race', TrackerConfig())
    plain = config.with_values(slip_sigma=0.0)
    for each in (config, plain):
        result = score(scans, run_offline(scans, each)[0])[2]
        assert result.id_switches == 0 and result.heading_rmse_deg < 5.0, result
    monkeypatch.setattr(object_tracker, 'TRUSTED_COAST_TURN', np.inf)
    before = score(scans, run_offline(scans, plain)[0])[2]
    assert before.heading_rmse_deg > 5.0, before


def test_a_car_seen_end_on_before_a_wall_is_tracked(monkeypatch):
    """car_moving seed 1098 object 4: a car 6-8 m from the moving sensor, seen end-on with a
    wall 1.45 m behind it (test_lidar's by-hand scene).  Its side's line went through the
    wall's first return, so the car and 13 m of wall were one cluster from the fifth scan on,
    and the track started from it (14 m x 6.5 m, centre 6 m from the car) held the car's
    returns: the car, seen in 83 scans, was never tracked.  With the face ending at its far
    corner (clustering.ends_receding) it is tracked within the limits.  Without it, since a
    track wider than a car is no longer settled as too slow (12a26cf), the car is tracked on
    about half of its scans (coverage 0.52)."""
    scans = scans_from_messages(KINDS['car_moving'](1098).messages())
    config = configuration('car_moving', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[4]
    assert result.id_switches == 0 and result.coverage > 0.95, result
    assert result.position_rmse < 0.3 and result.heading_rmse_deg < 5.0 \
        and result.velocity_rmse < 0.8, result
    monkeypatch.setattr(clustering, 'ends_receding',
                        lambda points, jumps, at, *args: np.zeros(len(at), dtype=bool))
    before = score(scans, run_offline(scans, config)[0])[4]
    assert before.coverage < 0.6, before


def test_vague_by_hand():
    """Position covariance [[0.2, 0.1], [0.1, 0.2]]: eigenvalues 0.3 and 0.1, largest std
    sqrt(0.3) = 0.548 m.  Vague for a 0.5 m x 0.3 m track, not for 0.55 m x 0.3 m, nor for a
    0.3 m x 0.55 m one, vague again for 0.3 m x 0.45 m (max of length and width); the
    off-diagonal term counts (the diagonal alone gives std 0.447 m)."""
    track = _track(1, np.zeros(6), np.ones(6), hits=5, updated=0.0, length=0.5, width=0.3)
    track.filter.p[:2, :2] = [[0.2, 0.1], [0.1, 0.2]]
    assert vague(track)
    track.length = 0.55
    assert not vague(track)
    track.length, track.width = 0.3, 0.55
    assert not vague(track)
    track.length, track.width = 0.3, 0.45
    assert vague(track)
    track.filter.p[:2, :2] = [[0.2, 0.0], [0.0, 0.2]]
    assert not vague(track)


def test_a_wall_piece_near_a_coasting_cars_prediction_does_not_take_its_id(monkeypatch):
    """car_static seed 111 object 3 (3.89 m long) goes unseen for 0.8 s.  After 1 s without an
    update its position std is 2.5 m, and a new track is started 4.3 m from its prediction on
    an 8.9 m piece of the wall (y = 9 m).  Without the size rule that track took the car's id
    (checked: 1 switch, the car coming back under a new id); with it, a track more than
    SIZE_GROWTH times the car's length is not the car found again: one id."""
    scans = scans_from_messages(KINDS['car_static'](111).messages())
    config = configuration('car_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[3]
    assert len(result.track_ids) == 1 and result.id_switches == 0, result
    assert result.position_rmse < 0.3 and result.velocity_rmse < 0.8, result
    monkeypatch.setattr(object_tracker, 'SIZE_GROWTH', np.inf)
    before = score(scans, run_offline(scans, config)[0])[3]
    assert before.id_switches >= 1, before


def test_a_car_coasting_out_of_view_is_kept_while_its_prediction_is_vague(monkeypatch):
    """f1tenth_static seed 416 object 2 leaves the field of view for 1.6 s.  After 1.3 s of
    coasting (position std 3.7 m) its predicted rectangle comes back into view 0.2 m ahead of
    the car and 0.3 s before it: without the vague rule the beams through the rectangle's
    corner drop the track and the car comes back as a new id (checked: 1 switch); with it the
    track is kept as hidden and found again: one id."""
    scans = scans_from_messages(KINDS['f1tenth_static'](416).messages())
    config = configuration('f1tenth_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[2]
    assert len(result.track_ids) == 1 and result.id_switches == 0, result
    assert result.position_rmse < 0.05 and result.velocity_rmse < 0.8, result
    monkeypatch.setattr(object_tracker, 'vague', lambda track: False)
    before = score(scans, run_offline(scans, config)[0])[2]
    assert before.id_switches >= 1, before


@pytest.mark.parametrize('seed', [1098, 1106], ids=['front face out of an occlusion',
                                                     'returns thinning near range_max'])
def test_a_track_first_reported_on_a_coasting_track_continues_its_id(monkeypatch, seed):
    """car_static seeds 1098 and 1106 object 4: the car's track coasts (hidden for 0.3 s, or its
    cluster at 27 m could not correct it), and a new track is started on the car's returns
    (the test's id) with its rectangle 90 deg off, its centre 2 m from the coasting track's, so at
    its min_hits-th update it is outside _same_object's gate.  Two scans later its velocity has
    turned it and it lies on the coasting track.  Until then it was not reported (its heading
    was voting), so at its first report it continues the old id: one id for the car.  With only
    the min_hits-th update checked (the rule before) the car switches id (checked: 1 switch)."""
    scans = scans_from_messages(KINDS['car_static'](seed).messages())
    config = configuration('car_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[4]
    assert len(result.track_ids) == 1 and result.id_switches == 0, result
    assert result.position_rmse < 0.3 and result.velocity_rmse < 0.8, result
    monkeypatch.setattr(object_tracker.LidarObjectTracker, '_id_still_open',
                        lambda self, track, time: track.hits == self.config.min_hits)
    before = score(scans, run_offline(scans, config)[0])[4]
    assert before.id_switches >= 1, before


def test_two_cars_whose_returns_are_one_cluster_keep_their_ids(monkeypatch):
    """f1tenth_moving seed 1013 objects 2 and 4: two cars in a convoy, 0.8 m apart, seen by the
    moving sensor from behind; from scan 88 the near car's far corner and the far car's returns
    are one cluster.  Split by the two tracks' predicted rectangles (split_shared), each car
    keeps its track and id, within the limits.  Given whole to the near car's track (the rule
    before), that track grew over both cars to 1.24 m, was dropped as a wall, and the far
    car's coasting id was handed to the near car (checked: 1 switch each; with the coarse
    association serving the tracks corrected on the previous scan first, the near car
    switches and the far car's heading RMSE is 6.3 deg)."""
    scans = scans_from_messages(KINDS['f1tenth_moving'](1013).messages())
    config = configuration('f1tenth_moving', TrackerConfig())
    results = score(scans, run_offline(scans, config)[0])
    for car in (2, 4):
        assert len(results[car].track_ids) == 1 and results[car].id_switches == 0, results[car]
        assert results[car].position_rmse < 0.05 and results[car].heading_rmse_deg < 5.0 \
            and results[car].velocity_rmse < 0.8, results[car]
    monkeypatch.setattr(object_tracker, 'split_shared', lambda points, labels, *rest: labels)
    before = score(scans, run_offline(scans, config)[0])
    assert before[2].id_switches >= 1 and before[4].heading_rmse_deg > 5.0, before


def test_a_vague_track_does_not_take_the_cluster_of_one_corrected_the_scan_before():
    """By hand (F1Tenth settings: coarse_sigma 0.5, point_sigma 0.05, gate 9.21): a car's track R
    at the origin, corrected on the previous scan (position variance 0.001), and a track V never
    corrected, 2 m behind (variance 0.6); the car's cluster at the origin and a wall's 1 m ahead.
    Centroid covariances (P + 0.25 I + extent (0.0756, 0.0225) + 0.0025 I) in x: R 0.3291, V
    0.9281.  d2: R-car 0, R-wall 1 / 0.3291 = 3.04, V-car 4 / 0.9281 = 4.31, V-wall 9.70 (out of
    the gate).  In one assignment R-wall + V-car (7.35) beats R-car + the wall unpaired (9.21):
    the swap.  Served first, R takes the car; V gates nothing left."""
    recent = _track(1, [0, 0, 0, 0, 0, 0], [0.001, 0.001, 0.001, 0.01, 0.01, 0.01], 10, 0.975)
    vague = _track(2, [-2.0, 0, 0, 0, 0, 0], [0.6, 0.6, 0.04, 100, 100, 1], 1, 0.0)
    tracker = LidarObjectTracker(configuration('f1tenth_moving', TrackerConfig()))
    tracker.tracks = [recent, vague]
    points = np.array([[-0.05, -0.1], [0.05, 0.1], [0.95, -0.1], [1.05, 0.1]])
    labels = np.array([0, 0, 1, 1])
    assert tracker._coarse(points, labels, 2, None) == {1: [0], 0: [1]}  # one tier: swapped
    assert tracker._coarse(points, labels, 2, 0.975) == {0: [0]}


def test_tracks_corrected_on_the_previous_scan_take_their_clusters_first():
    """f1tenth_moving seed 1025 object 1, a car 1.2 m beside the moving sensor: a track started
    on the first scan and never corrected (velocity std 10 m/s) gates the car's cluster 2 m
    away.  Served after the tracks corrected on the previous scan (_tiers) it cannot take it:
    one id, within the limits.  In one assignment with the car's track (the rule before) it took
    the car's cluster while the car's track took a wall's, was restarted onto the car at 9 m/s
    and took the car's id (1 switch).  Since the beam time is in the measurement
    (beam_time_measurement) one assignment no longer switches here either; the rule's own
    witness is test_a_vague_track_does_not_take_the_cluster_of_one_corrected_the_scan_before
    (by hand)."""
    scans = scans_from_messages(KINDS['f1tenth_moving'](1025).messages())
    config = configuration('f1tenth_moving', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[1]
    assert len(result.track_ids) == 1 and result.id_switches == 0, result
    assert result.position_rmse < 0.05 and result.heading_rmse_deg < 5.0 \
        and result.velocity_rmse < 0.8, result


@settings(max_examples=200, deadline=None)
@given(st.floats(-np.pi, np.pi), st.floats(-20, 20), st.floats(-20, 20), st.floats(-10, 10),
       st.floats(-10, 10), st.floats(-3, 3),
       st.lists(st.tuples(st.floats(-3, 3), st.floats(-1, 1), st.floats(0.0, 0.1)),
                min_size=1, max_size=6))
def test_points_taken_late_go_where_they_are_on_the_object_at_the_stamp(yaw, cx, cy, vx, vy, w,
                                                                       hits):
    """A rigid object at centre c and heading yaw at the stamp, moving at v and turning at w:
    its body point b seen `late` after the stamp is at c + v late + R(yaw + w late) b, and
    at_stamp_points puts it back at c + R(yaw) b."""
    centre, velocity = np.array([cx, cy]), np.array([vx, vy])
    body = np.array([hit[:2] for hit in hits])
    late = np.array([hit[2] for hit in hits])
    taken = np.array([centre + velocity * t + rotation(yaw + w * t) @ b
                      for b, t in zip(body, late)])
    np.testing.assert_allclose(
        object_tracker.at_stamp_points(taken, late, centre, np.array([vx, vy, w])),
        centre + body @ rotation(yaw).T, atol=1e-9)


def heading_bias_in_a_circle(turn, start, scans=15):
    """(mean, mean absolute) heading error [deg] over the last `scans` scans of an F1Tenth car
    driving a circle at 1.5 m/s and yaw rate `turn` [rad/s] from `start`, seen by a 10 Hz 360
    deg scanner (360_10hz_coarse, the beams of one turn 0.1 s apart) with the F1Tenth preset."""
    scene = one_car_scene(start, 1.5, duration=3.0, size=(0.55, 0.3),
                          lidar=OTHER_LIDARS['360_10hz_coarse'], turn=turn)
    scans_seen = scans_from_messages(scene.messages())
    estimates, _ = run_offline(scans_seen, configuration('f1tenth_static', TrackerConfig()))
    errors = [np.angle(np.exp(1j * (estimate.states[0, 2] - scan.truth[0]['yaw'])))
              for scan, estimate in zip(scans_seen, estimates) if len(estimate.ids)]
    last = np.degrees(errors[-scans:])
    return float(np.mean(last)), float(np.mean(np.abs(last)))


@pytest.mark.parametrize('turn, start', [(0.8, (-4.5, 1.5, 0.0)), (1.2, (-4.5, 1.5, 0.0)),
                                         (0.8, (3.0, 3.0, 2.5)), (1.2, (3.0, 3.0, 2.5))])
def test_a_car_turning_in_a_slow_scan_is_reported_with_its_heading_at_the_stamp(turn, start):
    """Behind the sensor (start 1: 5-6 m away, its beams 0.084-0.089 s after the stamp of the
    0.1 s turn) or beside it (start 2: 1-2 m, 0.056-0.075 s), an F1Tenth car circling at 0.8 /
    1.2 rad/s turns 3-6 deg between the stamp and its beams.
    Mean heading error over the last 15 scans, measured: 0.79 / 0.55 / -0.07 / 0.26 deg (mean
    absolute 1.45 / 1.04 / 0.39 / 0.81 deg); with the points moved back by the velocity only and the heading read
    at the stamp (the code before, 2026-12-07) 3.83 / 5.55 / 2.78 / 4.65 deg."""
    bias, spread = heading_bias_in_a_circle(turn, start)
    assert abs(bias) < 1.5 and spread < 2.5, (bias, spread)


def test_a_heading_read_from_turned_points_says_so_in_its_measurement(monkeypatch):
    """car_static seed 100 object 1 seen by 360_10hz, driving straight at 9.3 m/s: once its
    track is settled its points are turned back by the predicted yaw rate w0, so the heading
    the correction reads is yaw + late (w - w0) and the measurement's H has late in its yaw
    rate column (beam_time_measurement turned).  Measured: heading RMSE 0.28 deg, position
    0.040 m; with H[2, 5] = 0 the predicted yaw rate fed back into the heading read and rang
    (-18, 39, -54, 73, -84 deg/s on 5 scans): 2.85 deg, 0.209 m, velocity 1.77 m/s."""
    scans = scans_seen_by('car_static', 100, '360_10hz')
    config = configuration('car_static', TrackerConfig())
    result = score(scans, run_offline(scans, config)[0])[1]
    assert result.heading_rmse_deg < 1.0 and result.position_rmse < 0.1, result
    measurement = object_tracker.beam_time_measurement
    monkeypatch.setattr(object_tracker, 'beam_time_measurement',
                        lambda late, elapsed=np.inf, turned=False: measurement(late, elapsed))
    rang = score(scans, run_offline(scans, config)[0])[1]
    assert rang.heading_rmse_deg > 2.0 and rang.velocity_rmse > 1.0, rang


def speeds_after_each_scan(lidar, start, speed, size=(4.5, 1.8), kind=None, scans=8):
    """|velocity| of the one track after each of the first `scans` scans of one object driving
    straight from `start` at `speed`, seen by `lidar` from the origin (offsets passed)."""
    scene = one_car_scene(start, speed, duration=1.0, size=size, lidar=lidar)
    tracker = LidarObjectTracker(TrackerConfig() if kind is None
                                 else configuration(kind, TrackerConfig()))
    speeds = []
    for scan in scans_from_messages(scene.messages())[:scans]:
        tracker.step(scan.points, scan.time,
                     offsets=np.arange(len(scan.points)) * scan.time_increment)
        assert len(tracker.tracks) == 1
        speeds.append(float(np.hypot(*tracker.tracks[0].filter.x[3:5])))
    return np.array(speeds)


@pytest.mark.parametrize('start, speed, size, kind, lidar, most', [
    ((0.0, 5.0, np.pi), 9.5, (4.5, 1.8), None, CAR_LIDAR, 0.4),
    ((0.0, 1.5, np.pi), 6.0, (0.55, 0.3), 'f1tenth_static', F1TENTH_LIDAR, 0.2)])
def test_a_scan_taken_over_time_does_not_slow_the_velocity(start, speed, size, kind, lidar, most,
                                                           monkeypatch):
    """A car (an F1Tenth car) side-on at 5 m (1.5 m), 16 ms into the scan, driving
    at 9.5 (6) m/s from its first scan: the mean speed error over updates 2-7.  Measured: 0.22
    (0.09) m/s; the same object scanned at one instant 0.10 (0.05); with the beam time left
    out of the measurement (H = I, the code before) 1.46 (0.82); in the measurement but the
    points not moved back again after the update (the shape steps then pulled the centre back
    towards where the predicted velocity put them) 0.52 (0.34)."""
    instant = dataclasses.replace(lidar, beams_per_turn=10 ** 9)  # time_increment ~ 0
    lag = np.mean(np.abs(speeds_after_each_scan(lidar, start, speed, size, kind)[2:] - speed))
    lag_instant = np.mean(np.abs(
        speeds_after_each_scan(instant, start, speed, size, kind)[2:] - speed))
    assert lag < most and lag_instant < 0.2, (lag, lag_instant)
    monkeypatch.setattr(object_tracker, 'beam_time_measurement',
                        lambda late, elapsed=np.inf, turned=False: np.eye(6))
    before = np.mean(np.abs(speeds_after_each_scan(lidar, start, speed, size, kind)[2:] - speed))
    assert before > 1.5 * most, before


def test_beam_time_measurement_and_the_start_covariance_by_hand():
    """z = p + late (v - v0): H = I with late in the velocity columns of x and y (and 1 + late /
    elapsed on the velocity's own rows, for velocity_measurement); turned back by the yaw rate
    as well (turned), late in the yaw rate's column of the yaw and 1 + late / elapsed on its
    own row; a start from
    points taken 0.02 s late: var(x) = 0.3^2 + 0.02^2 10^2 = 0.13, cov(x, vx) = -0.02 10^2."""
    h = object_tracker.beam_time_measurement(0.02)
    x = np.array([1.0, 2.0, 0.3, 5.0, -4.0, 0.1])
    np.testing.assert_allclose(h @ x, [1.1, 1.92, 0.3, 5.0, -4.0, 0.1])
    # velocity_measurement: (z - last) / elapsed reads v + late (v - v0) / elapsed
    h = object_tracker.beam_time_measurement(0.02, elapsed=0.025)
    np.testing.assert_allclose(h @ x, [1.1, 1.92, 0.3, 9.0, -7.2, 0.1])
    # turned back by the yaw rate too: the heading reads yaw + late (w - w0), w on its own row
    # as the velocity is on its own
    h = object_tracker.beam_time_measurement(0.02, elapsed=0.025, turned=True)
    np.testing.assert_allclose(h @ x, [1.1, 1.92, 0.302, 9.0, -7.2, 0.18])
    tracker = LidarObjectTracker()
    side = np.column_stack([np.linspace(-2.0, 2.0, 41), np.full(41, 5.0)])
    track = tracker._start(side, np.zeros(2, bool), 1.0, late=0.02)
    p = track.filter.p
    assert p[0, 0] == pytest.approx(0.13) and p[1, 1] == pytest.approx(0.13)
    assert p[0, 3] == pytest.approx(-2.0) and p[1, 4] == pytest.approx(-2.0)
    assert p[0, 4] == 0.0 and p[3, 3] == pytest.approx(100.0)
