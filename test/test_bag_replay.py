"""Every bag x every applicable algorithm through the LIVE node (da_bag_replay over real DDS):
scores above thresholds, and exactly the offline pipeline's answers."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from data_association_ros.bag import topics
from data_association_ros.bag.evaluate import (bag_algorithms, evaluate_offline, read_truth,
                                               read_truth_xy, score_recording)
from data_association_ros.bag.offline import node_config, run_offline
from data_association_ros.bag.reader import BagReader
from data_association_ros.bag.replay import bag_parameters, replay, write_recording
from data_association_ros.pipelines.association import stamp_ns
from msg_adapters import cloud_to_array

BAGS = Path(__file__).resolve().parents[1] / 'bags'
RATE = 8.0

# (bag, algorithm) -> (minimum pairing precision, minimum recall, reason). Measured values
# (offline = live) are in the README table; each threshold sits below them by the margin the
# reason gives, so a regression fails while the bag's own randomness cannot.
THRESHOLDS = {
    'easy_point_map': {a: (0.99, 0.99) for a in bag_algorithms(BAGS / 'easy_point_map')},
    # 4 m spacing vs 5 cm noise: anything below 99 % is a bug.
    'clutter_range_bearing': {
        'euclidean_nn': (0.88, 0.94),        # measured 0.893 / 0.952: ignores uncertainty
        'mahalanobis_nn': (0.93, 0.94),      # 0.944 / 0.950: greedy, fooled by the yaw error
        'maximum_likelihood': (0.93, 0.94),  # 0.938 / 0.952
        'gnn': (0.98, 0.97),                 # 0.990 / 0.983: one-to-one helps
        'jcbb': (0.99, 0.98),                # 1.000 / 0.997: joint test resolves the twins
    },
    'exploration': {a: (0.97, 0.97) for a in bag_algorithms(BAGS / 'exploration')},
    # 1-8 m ranges, 5 cm noise, 2 cm / 0.01 rad pose: measured 0.983-0.998 for all.
    'boxes': {a: (0.98, 0.98) for a in bag_algorithms(BAGS / 'boxes')},
    # 2 px noise on 50-140 px boxes, crossings: measured 0.991-1.000.
}
CASES = [(bag, algorithm) for bag in THRESHOLDS for algorithm in THRESHOLDS[bag]]


def parameters(bag: str) -> dict:
    """The bag's parameters without the search's wall-clock budget (its search-node budget
    stays): on a loaded host a JCBB search beyond the node's default 100 ms was cut short live
    but not offline (exploration jcbb, precision 0.99802 vs 0.99800)."""
    return {**bag_parameters(BAGS / bag), 'time_budget_ms': 0.0}


@pytest.fixture(scope='module')
def live_runs(tmp_path_factory):
    """Replays each case once (module scope): {(bag, algorithm): (recording dir, result)}."""
    cache = {}

    def get(bag, algorithm):
        if (bag, algorithm) not in cache:
            path = BAGS / bag
            result = replay(path, algorithm, parameters(bag), RATE, progress=False)
            out = tmp_path_factory.mktemp(f'{bag}_{algorithm}') / 'recording'
            write_recording(out, result)
            cache[(bag, algorithm)] = (out, result)
        return cache[(bag, algorithm)]
    return get


@pytest.mark.parametrize('bag,algorithm', CASES)
def test_live_scores_meet_thresholds_and_equal_offline(live_runs, bag, algorithm):
    out, result = live_runs(bag, algorithm)
    assert result.node_alive, result.node_log[-2000:]
    assert result.answered == result.sent > 0, result.node_log[-2000:]
    _, truth = read_truth(BAGS / bag)
    live = score_recording(truth, BagReader(out), read_truth_xy(BAGS / bag)).summary()
    precision, recall = THRESHOLDS[bag][algorithm]
    assert live['pair_precision'] >= precision, live
    assert live['pair_recall'] >= recall, live
    assert live['answered'] == live['messages'] == len(truth)
    assert np.isfinite(live['latency_median_ms'])

    offline = evaluate_offline(BAGS / bag, algorithm, parameters(bag))
    for key in ('pair_precision', 'pair_recall', 'new_correct', 'new_false', 'clutter_paired',
                'answered', 'landmarks_right', 'landmarks_false'):
        assert live[key] == offline[key], key
    # and answer by answer
    reader = BagReader(BAGS / bag)
    inputs = [(m.topic, m.msg) for m in reader.messages(
        [t for t in topics.INPUT_TOPICS if t in reader.topics])]
    expected = run_offline(inputs, node_config(algorithm, parameters(bag)))
    recorded = {stamp_ns(m.msg.header): cloud_to_array(m.msg)['landmark']
                for m in BagReader(out).messages([topics.CORRESPONDENCES])}
    assert recorded.keys() == expected.keys()
    for stamp, assignment in expected.items():
        np.testing.assert_array_equal(recorded[stamp], assignment)


def test_jcbb_is_the_most_precise_on_clutter_range_bearing(live_runs):
    _, truth = read_truth(BAGS / 'clutter_range_bearing')
    precision = {a: score_recording(truth, BagReader(live_runs('clutter_range_bearing', a)[0]))
                 .summary()['pair_precision'] for a in ('jcbb', 'mahalanobis_nn', 'gnn')}
    assert precision['jcbb'] > precision['mahalanobis_nn']
    assert precision['jcbb'] > precision['gnn']


def test_node_killed_mid_replay_is_restarted_and_the_gap_reported(tmp_path):
    # da_bag_replay as a process of its own, as a user runs it, with UDP only (loopback) on both
    # sides: after a reader's process is SIGKILLed, Fast DDS's shared-memory transport can keep
    # a writer from reaching the restarted reader for longer than this test waits
    # (eProsima/Fast-DDS#5469, #2811; 2 of 4 full runs here: none of messages 9-59 answered);
    # run inside pytest, the replay's writer belonged to a participant created long before with
    # the default transports, and 2 of 3 full runs (2026-12-02) lost the restarted node again
    environment = {**os.environ, 'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4'}
    # rate 0.5: the 50 scans after the kill take 10 s, ample for a new node to come up
    result = subprocess.run(
        [sys.executable, '-m', 'data_association_ros.bag.replay', str(BAGS / 'exploration'),
         '--algorithm', 'gnn', '--out', str(tmp_path / 'out'), '--rate', '0.5',
         '--kill-node-after', '10'], env=environment, capture_output=True, text=True,
        timeout=120)
    printed = result.stdout
    assert result.returncode == 0, printed + result.stderr
    assert 'node killed and restarted after message 10' in printed
    gap = printed.split('unanswered observation messages (0-based, in sending order): ')[1]
    bounds = [int(v) for v in gap.split()[0].rstrip(',').split('-')]
    first, last = bounds[0], bounds[-1]
    # the gap starts at the kill, then answers (printed has the restarted node's log)
    assert 8 <= first <= 10 and first <= last < 59, printed + result.stderr
    recorded = list(BagReader(tmp_path / 'out').messages([topics.CORRESPONDENCES]))
    assert 0 < len(recorded) < 60
