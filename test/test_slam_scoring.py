"""The SLAM score table's definitions on hand-built runs (numbers worked out by hand)."""
import numpy as np
import pytest

from data_association_ros.bag.slam_plot import plot_name, plot_run
from data_association_ros.bag.slam_run import SlamRun
from data_association_ros.bag.slam_scoring import SlamTruth, pose_rmse, scan_outcomes, score_run

S = 1_000_000_000
MAP_DTYPE = np.dtype([('id', '<i4'), ('x', '<f4'), ('y', '<f4'), ('origin_stamp_sec', '<i4'),
                      ('origin_stamp_nanosec', '<u4'), ('origin_observation', '<i4')])


def final_map(rows):
    """rows: (id, x, y, origin second, origin observation)."""
    points = np.zeros(len(rows), dtype=MAP_DTYPE)
    for point, (landmark, x, y, second, index) in zip(points, rows):
        point['id'], point['x'], point['y'] = landmark, x, y
        point['origin_stamp_sec'], point['origin_observation'] = second, index
    return points


def test_scores_by_hand():
    # scan 1 sees true 7 and 8 (both new); scan 2: 7, 8, clutter; scan 3: 7 (uncertain), 8
    truth = SlamTruth(
        labels={1 * S: np.array([7, 8]), 2 * S: np.array([7, 8, -2]), 3 * S: np.array([7, 8])},
        certain={1 * S: np.array([True, True]), 2 * S: np.array([True, True, True]),
                 3 * S: np.array([False, True])},
        landmarks={7: np.array([0.0, 0.0]), 8: np.array([4.0, 0.0])}, poses={})
    # the SLAM made landmark 0 from 7 and 1 from 8 at scan 1, 2 from scan 2's clutter (false),
    # 3 from 8 again at scan 3 (duplicate)
    run = SlamRun(answers={1 * S: np.array([-1, -1]), 2 * S: np.array([0, -1, -1]),
                           3 * S: np.array([1, -1])},
                  times_ms={1 * S: 1.0, 2 * S: 2.0, 3 * S: 3.0},
                  final_map=final_map([(0, 1.0, 0.0, 1, 0), (1, 5.0, 0.0, 1, 1),
                                       (2, 9.0, 9.0, 2, 2), (3, 4.5, 0.0, 3, 1)]))
    row = score_run(run, truth)
    # pairs on certain truth: scan 2's 0 <- 7 (right); scan 3's pair is on uncertain truth
    assert row['pair_precision'] == 1.0
    # certain and in the map before their scan: scan 2's 7 and 8, scan 3's 8 -> 1 right of 3
    assert row['pair_recall'] == pytest.approx(1 / 3)
    # 6 certain observations; correct: scan 1's two NEW (not mapped yet), scan 2's pair and
    # its clutter NEW = 4; missed: scan 2's and scan 3's 8 (mapped, not paired) = 2
    assert row['correct_percent'] == pytest.approx(100 * 4 / 6)
    assert row['missed_percent'] == pytest.approx(100 * 2 / 6)
    assert row['wrong_percent'] == 0.0
    assert row['new_false'] == 2
    assert (row['landmarks'], row['landmarks_right'], row['landmarks_duplicate'],
            row['landmarks_false'], row['landmarks_true'], row['landmarks_missed']) == \
        (4, 2, 1, 1, 2, 0)
    assert np.isnan(row['map_rmse_m'])      # only 2 right landmarks: no alignment
    assert row['time_median_ms'] == 2.0 and row['answered'] == 3


def test_unanswered_scans_are_left_out_of_the_percentages():
    truth = SlamTruth({S: np.array([7]), 2 * S: np.array([7])},
                      {S: np.array([True]), 2 * S: np.array([True])}, {}, {})
    run = SlamRun(answers={S: np.array([-1])}, times_ms={S: 1.0},
                  final_map=final_map([(0, 0.0, 0.0, 1, 0)]))
    row = score_run(run, truth)
    assert row['answered'] == 1 and row['scans'] == 2
    assert row['correct_percent'] == 100.0


def rotate(point, angle, shift):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([c * point[0] - s * point[1], s * point[0] + c * point[1]]) + shift


def test_map_rmse_after_rigid_alignment():
    true = {1: np.array([0.0, 0.0]), 2: np.array([4.0, 0.0]), 3: np.array([0.0, 3.0])}
    truth = SlamTruth({S: np.array([1, 2, 3])}, {S: np.ones(3, bool)}, true, {})
    moved = {k: rotate(v, np.pi / 2, [10.0, -2.0]) for k, v in true.items()}

    def run_with(points):
        return SlamRun(answers={S: np.array([-1, -1, -1])}, times_ms={S: 1.0},
                       final_map=final_map([(k - 1, *points[k], 1, k - 1) for k in (1, 2, 3)]))
    assert score_run(run_with(moved), truth)['map_rmse_m'] < 1e-5   # float32 map
    moved[3] = moved[3] + [0.3, 0.0]
    rmse = score_run(run_with(moved), truth)['map_rmse_m']
    # the fit spreads one point's 0.3 m error over all three: below 0.3 / sqrt(3)
    assert 0.05 < rmse < 0.3 / np.sqrt(3)


def test_trajectory_rmse_is_gauge_free():
    true = {k * S: np.array([k, 0.5 * k * k, 0.0]) for k in range(6)}
    moved = {k: np.append(rotate(p, 0.4, [3.0, -1.0]), 0.4) for k, p in true.items()}
    assert pose_rmse(moved, true) < 1e-9
    moved[2 * S] = moved[2 * S] + [0.6, 0.0, 0.0]
    assert 0.0 < pose_rmse(moved, true) < 0.6 / np.sqrt(6) + 1e-9


def test_merged_and_dropped_landmarks_keep_their_identity():
    # scan 1 starts 0 (from true 7) and 1 (from true 7 again: a duplicate), scan 2 pairs true 7
    # with 1, then 1 is merged into 0 and is gone from the final map; scan 3 pairs 7 with 0
    truth = SlamTruth(labels={1 * S: np.array([7, 7]), 2 * S: np.array([7]),
                              3 * S: np.array([7])},
                      certain={1 * S: np.array([True, True]), 2 * S: np.array([True]),
                               3 * S: np.array([True])}, landmarks={}, poses={})
    answers = {1 * S: np.array([-1, -1]), 2 * S: np.array([1]), 3 * S: np.array([0])}
    final = final_map([(0, 0.0, 0.0, 1, 0)])
    without = score_run(SlamRun(answers=answers, final_map=final), truth)
    assert without['pair_precision'] == 0.5        # landmark 1 unknown: its pair counts wrong
    run = SlamRun(answers=answers, final_map=final, origins={0: (1 * S, 0), 1: (1 * S, 1)})
    row = score_run(run, truth)
    assert row['pair_precision'] == 1.0 and row['correct_percent'] == 100.0
    assert row['landmarks'] == 1 and row['landmarks_duplicate'] == 0
    assert scan_outcomes(run, truth) == {1 * S: (0, 0), 2 * S: (0, 0), 3 * S: (0, 0)}
    assert scan_outcomes(SlamRun(answers=answers, final_map=final), truth)[2 * S] == (1, 0)


def test_plot_writes_a_picture(tmp_path):
    truth = SlamTruth(labels={1 * S: np.array([7, 8]), 2 * S: np.array([7, 8])},
                      certain={1 * S: np.array([True, True]), 2 * S: np.array([True, True])},
                      landmarks={7: np.array([0.0, 0.0]), 8: np.array([4.0, 0.0]),
                                 9: np.array([0.0, 4.0])},
                      poses={1 * S: np.array([1.0, 1.0, 0.0]), 2 * S: np.array([2.0, 1.0, 0.0])})
    run = SlamRun(answers={1 * S: np.array([-1, -1]), 2 * S: np.array([1, 0])},
                  poses={1 * S: np.array([1.0, 1.0, 0.0]), 2 * S: np.array([2.0, 1.0, 0.0]),
                         3 * S: np.array([3.0, 1.0, 0.0])},
                  final_map=final_map([(0, 0.0, 0.0, 1, 0), (1, 4.0, 0.0, 1, 1),
                                       (2, 0.1, 0.0, 2, 0)]))
    assert scan_outcomes(run, truth) == {1 * S: (0, 0), 2 * S: (2, 0)}    # both pairs swapped
    path = plot_run(run, truth, plot_name('bag', 'jcbb', 'node', tmp_path), 'title')
    assert path == tmp_path / 'bag_jcbb_closed.png'
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and path.stat().st_size > 5000
