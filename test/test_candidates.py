"""Candidate landmarks: M-of-N confirmation, expiry, fusion, against hand-worked scan sequences."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from data_association_ros import InvalidInputError
from data_association_ros.core.candidates import CandidateManager, check_confirmation

R = np.eye(2) * 0.01


def scan(manager, points, stamp, indices=None):
    """Feed one scan's NEW observations (list of (x, y)) with covariance R each."""
    points = np.array(points, dtype=float).reshape(-1, 2)
    indices = np.arange(len(points)) if indices is None else np.array(indices)
    return manager.update(points, np.tile(R, (len(points), 1, 1)), stamp, indices)


def test_confirm_hits_one_announces_every_new_observation_at_once():
    manager = CandidateManager(confirm_hits=1)
    update = scan(manager, [(0, 0), (5, 5)], stamp=7, indices=[2, 4])
    assert [c.observations for c in update.confirmed] == [((7, 2),), ((7, 4),)]
    assert [c.delay_scans for c in update.confirmed] == [0, 0]
    np.testing.assert_allclose(update.confirmed[1].mean, [5, 5])
    assert manager.pending == []
    # the same place again is announced again: no state at confirm_hits 1
    assert len(scan(manager, [(0, 0)], stamp=8).confirmed) == 1


def test_candidate_seen_on_alternate_scans_is_confirmed_on_its_third_hit():
    manager = CandidateManager(confirm_hits=3, confirm_window=5, max_misses=2)
    confirmed_at = {}
    for k in range(1, 8):
        points = [(3.0, 1.0)] if k % 2 == 1 else []
        update = scan(manager, points, stamp=100 + k)
        for landmark in update.confirmed:
            confirmed_at[landmark.candidate] = (k, landmark)
    assert len(confirmed_at) == 1  # hits on scans 1, 3, 5: confirmed on 5, never again
    (k, landmark), = confirmed_at.values()
    assert k == 5 and landmark.delay_scans == 4
    assert landmark.observations == ((101, 0), (103, 0), (105, 0))
    # three fused hits of covariance R: R / 3
    np.testing.assert_allclose(landmark.covariance, R / 3)


def test_hits_outside_the_window_do_not_count():
    manager = CandidateManager(confirm_hits=2, confirm_window=2, max_misses=3)
    assert scan(manager, [(0, 0)], 1).confirmed == ()
    scan(manager, [], 2)
    assert scan(manager, [(0, 0)], 3).confirmed == ()  # window (1, 3] holds one hit
    assert len(scan(manager, [(0, 0)], 4).confirmed) == 1


def test_candidate_expires_after_max_misses_in_a_row():
    manager = CandidateManager(confirm_hits=2, confirm_window=3, max_misses=2)
    scan(manager, [(0, 0)], 1)
    assert scan(manager, [], 2).expired == ()
    update = scan(manager, [], 3)
    assert update.expired == (0,) and manager.pending == [] and manager.expired_total == 1


def test_fusion_is_the_information_form_update():
    manager = CandidateManager(confirm_hits=2, confirm_window=2, max_misses=2)
    p1, p2 = np.array([[0.04, 0.01], [0.01, 0.02]]), np.array([[0.01, 0.0], [0.0, 0.03]])
    manager.update(np.array([[1.0, 2.0]]), p1[None], 1, np.array([0]))
    update = manager.update(np.array([[1.1, 1.9]]), p2[None], 2, np.array([0]))
    fused = np.linalg.inv(np.linalg.inv(p1) + np.linalg.inv(p2))
    mean = fused @ (np.linalg.solve(p1, [1.0, 2.0]) + np.linalg.solve(p2, [1.1, 1.9]))
    np.testing.assert_allclose(update.confirmed[0].covariance, fused)
    np.testing.assert_allclose(update.confirmed[0].mean, mean)


def test_confirmed_candidate_absorbs_later_sightings_instead_of_announcing_twice():
    manager = CandidateManager(confirm_hits=2, confirm_window=3, max_misses=2)
    announced = [len(scan(manager, [(4, 4)], k).confirmed) for k in range(1, 6)]
    assert announced == [0, 1, 0, 0, 0]


def test_far_observations_start_separate_candidates_and_near_ones_join():
    manager = CandidateManager(confirm_hits=2, confirm_window=3, max_misses=2)
    scan(manager, [(0, 0), (10, 0)], 1)
    update = scan(manager, [(10.05, 0.02), (20, 0)], 2)
    assert [c.observations for c in update.confirmed] == [((1, 1), (2, 0))]
    assert len(manager.pending) == 2  # (0, 0) and (20, 0)


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 4), st.integers(0, 3), st.lists(
    st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), min_size=1, max_size=30,
    unique_by=lambda p: (round(p[0] / 5), round(p[1] / 5))))
def test_single_stray_returns_never_become_landmarks(hits, extra_window, strays):
    """Each stray return appears once, far (> 5 m) from every other: with confirm_hits >= 2
    none is ever confirmed, and each expires."""
    strays = [p for k, p in enumerate(strays)
              if all(np.hypot(p[0] - q[0], p[1] - q[1]) > 5 for q in strays[:k])]
    manager = CandidateManager(confirm_hits=hits, confirm_window=hits + extra_window,
                               max_misses=2)
    for k, point in enumerate(strays):
        assert scan(manager, [point], k).confirmed == ()
    for k in range(3):
        assert scan(manager, [], len(strays) + k).confirmed == ()
    assert manager.confirmed_total == 0 and manager.expired_total == len(strays)


@pytest.mark.parametrize('hits,window,misses', [(0, 3, 2), (4, 3, 2), (2, 3, 0), (2.5, 3, 2),
                                                (True, 3, 2)])
def test_invalid_confirmation_rules_are_refused(hits, window, misses):
    with pytest.raises(InvalidInputError):
        check_confirmation(hits, window, misses)
