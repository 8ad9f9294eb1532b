"""Confirmed new landmarks on the exploration_clutter bag (2 clutter returns per scan; the bag's
map owner adds a landmark after its third sighting, so each landmark is NEW three times).

Measured with mahalanobis_nn (python -m data_association_ros.bag.evaluate
bags/exploration_clutter --offline -p confirm_hits:=H, 2026-11-25):

| confirm_hits | right | false (duplicates) | missed | delay [scans] |
| 1            | 40    | 203 (80)           | 0      | 0             |
| 2            | 40    | 0                  | 0      | 1             |
| 3            | 40    | 0                  | 0      | 2             |

The bounds below are those values: at 1 every clutter return (123 NEW answers) and every
repeated sighting before the map owner adds the landmark (2 x 40) is announced; from 2 on,
clutter (uniform in 12 m x 12 m) never repeats within the gate, and landmarks seen on
consecutive scans are confirmed exactly confirm_hits - 1 scans after their first sighting.
"""
from pathlib import Path

import pytest

from data_association_ros.bag.evaluate import evaluate_live, evaluate_offline

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'exploration_clutter'
EXPECTED = {1: (40, 203, 80, 0, 0.0), 2: (40, 0, 0, 0, 1.0), 3: (40, 0, 0, 0, 2.0)}
KEYS = ('landmarks_right', 'landmarks_false', 'landmarks_duplicate', 'landmarks_missed',
        'confirm_delay_scans')


@pytest.mark.parametrize('hits', sorted(EXPECTED))
def test_false_landmarks_and_delay_per_confirm_hits(hits):
    score = evaluate_offline(BAG, 'mahalanobis_nn', {'confirm_hits': hits})
    assert tuple(score[k] for k in KEYS) == EXPECTED[hits]


def test_live_node_announces_the_same_landmarks_as_offline():
    live = evaluate_live(BAG, 'mahalanobis_nn', {'confirm_hits': 2}, rate=2.0)
    assert live['node_alive'] and live['answered'] == live['messages']
    assert tuple(live[k] for k in KEYS) == EXPECTED[2]
