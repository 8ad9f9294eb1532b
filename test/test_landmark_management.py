"""core/slam/landmark_management.py against explicit matrices (brute force) and small maps whose
outcome is known by construction."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.stats import chi2

from data_association_ros.core.slam import EkfSlam
from data_association_ros.core.slam.landmark_management import (
    LandmarkManagementConfig, LandmarkManager, fuse_equal, merge_statistic, remove_landmarks)


def random_filter(seed: int, landmarks: int) -> EkfSlam:
    """An EkfSlam whose state has a random mean and a random positive definite covariance."""
    rng = np.random.default_rng(seed)
    size = 3 + 2 * landmarks
    slam = EkfSlam(rng.normal(size=3), np.eye(3), 'range_bearing')
    root = rng.normal(size=(size, size))
    slam.mean = rng.normal(scale=3.0, size=size)
    slam.covariance = root @ root.T / size + 0.05 * np.eye(size)
    slam.ids = np.arange(10, 10 + landmarks, dtype=np.int64)
    return slam


def difference_matrix(size: int, i: int, j: int) -> np.ndarray:
    """H (2, size) with H x = l_i - l_j."""
    h = np.zeros((2, size))
    h[:, 3 + 2 * i:5 + 2 * i] = np.eye(2)
    h[:, 3 + 2 * j:5 + 2 * j] = -np.eye(2)
    return h


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), landmarks=st.integers(2, 6),
       floor=st.sampled_from([0.0, 0.05, 0.3, 2.0]), data=st.data())
def test_merge_statistic_and_fusion_match_explicit_matrices(seed, landmarks, floor, data):
    i = data.draw(st.integers(0, landmarks - 1))
    j = data.draw(st.integers(0, landmarks - 1).filter(lambda k: k != i))
    slam = random_filter(seed, landmarks)
    mean, covariance = slam.mean.copy(), slam.covariance.copy()
    h = difference_matrix(len(mean), i, j)
    s = h @ covariance @ h.T + floor ** 2 * np.eye(2)
    d = h @ mean
    statistic, _, _ = merge_statistic(slam, i, j, floor)
    assert statistic == pytest.approx(d @ np.linalg.solve(s, d), rel=1e-8)
    # conditioning on 0 = l_i - l_j + v, v ~ N(0, floor^2 I): Kalman update with z = 0,
    # R = floor^2 I (R -> 0 for floor 0), explicit K
    gain = covariance @ h.T @ np.linalg.inv(s)
    expected_mean = mean - gain @ d
    expected_covariance = covariance - gain @ s @ gain.T
    fuse_equal(slam, i, j, floor)
    np.testing.assert_allclose(slam.mean[:2], expected_mean[:2], atol=1e-8)
    np.testing.assert_allclose(slam.mean[3:], expected_mean[3:], atol=1e-8)
    np.testing.assert_allclose(slam.covariance, expected_covariance, atol=1e-8)
    if floor == 0.0:
        np.testing.assert_allclose(slam.mean[3 + 2 * i:5 + 2 * i],
                                   slam.mean[3 + 2 * j:5 + 2 * j], atol=1e-8)
    assert np.allclose(slam.covariance, slam.covariance.T)
    assert np.linalg.eigvalsh(slam.covariance).min() > -1e-8


def test_remove_landmarks_deletes_their_rows_and_keeps_the_rest_in_order():
    slam = random_filter(3, 4)
    mean, covariance = slam.mean.copy(), slam.covariance.copy()
    remove_landmarks(slam, np.array([11, 13]))
    keep = [0, 1, 2, 3, 4, 7, 8]                 # pose, landmark 10, landmark 12
    np.testing.assert_array_equal(slam.ids, [10, 12])
    np.testing.assert_array_equal(slam.mean, mean[keep])
    np.testing.assert_array_equal(slam.covariance, covariance[np.ix_(keep, keep)])
    with pytest.raises(ValueError):
        remove_landmarks(slam, np.array([11]))


def first_sighting() -> EkfSlam:
    """A robot at the origin facing +x that started landmark 0 at (5, 0)."""
    slam = EkfSlam([0.0, 0.0, 0.0], np.diag([0.01, 0.01, 0.001]), 'point_robot')
    slam.add_landmarks(np.array([[5.0, 0.0]]), np.diag([0.02, 0.02])[None], np.array([0]))
    return slam


def second_sighting(slam: EkfSlam, offset: float) -> EkfSlam:
    """Then, after a move of 1 m, landmark 1 started from a sighting `offset` m to the left of
    (5, 0)."""
    slam.predict(np.array([1.0, 0.0, 0.0]), np.diag([0.01, 0.01, 0.001]))
    slam.add_landmarks(np.array([[4.0, offset]]), np.diag([0.02, 0.02])[None], np.array([1]))
    return slam


def two_sightings_filter(second_offset: float) -> EkfSlam:
    """Both sightings (first_sighting, then second_sighting)."""
    return second_sighting(first_sighting(), second_offset)


def two_scans(manager: LandmarkManager, offset: float) -> tuple[EkfSlam, list]:
    """Landmark 0 started on one scan, landmark 1 (`offset`) on the next; the merges of the
    second scan."""
    slam = first_sighting()
    manager.started([0])
    assert manager.after_scan(slam, []).merged == []
    second_sighting(slam, offset)
    manager.started([1])
    return slam, manager.after_scan(slam, []).merged


def test_manager_merges_a_second_landmark_of_one_point_and_keeps_the_older():
    statistic, _, _ = merge_statistic(two_sightings_filter(0.05), 0, 1)
    assert statistic < chi2.ppf(0.99, 2)
    slam, merged = two_scans(LandmarkManager(LandmarkManagementConfig(merge_probability=0.99)),
                             0.05)
    assert merged == [(1, 0)]
    np.testing.assert_array_equal(slam.ids, [0])
    assert slam.covariance.shape == (5, 5)
    # the merged point lies between the two sightings' positions (5, 0) and (5, 0.05)
    assert slam.mean[3] == pytest.approx(5.0, abs=1e-3) and 0.0 < slam.mean[4] < 0.05


def test_manager_keeps_two_points_the_test_separates():
    statistic, _, _ = merge_statistic(two_sightings_filter(1.5), 0, 1)
    assert statistic > chi2.ppf(0.99, 2)     # 1.5 m apart, sigma ~0.2 m: different points
    slam, merged = two_scans(LandmarkManager(LandmarkManagementConfig(merge_probability=0.99)),
                             1.5)
    assert merged == []
    np.testing.assert_array_equal(slam.ids, [0, 1])


def test_two_landmarks_seen_on_one_scan_are_never_merged():
    """One scan sees an object once: landmarks started or fused on the same scan are two
    objects, however close (the pair two_scans merges, 0.05 m apart)."""
    for together in ('started', 'fused'):
        slam = two_sightings_filter(0.05)
        manager = LandmarkManager(LandmarkManagementConfig(merge_probability=0.99))
        if together == 'started':
            manager.started([0, 1])
        else:
            manager.started([0])
            manager.fused([1])
        assert manager.after_scan(slam, []).merged == []
        for _ in range(3):                  # later scans that see one of them: still two
            manager.fused([1])
            assert manager.after_scan(slam, [1]).merged == []
        np.testing.assert_array_equal(slam.ids, [0, 1])


def test_merge_floor_merges_a_copy_the_tight_covariance_keeps_apart():
    """A second landmark 0.4 m from the first, both with 0.03 m std and no correlation: the
    statistic is 0.16 / (2 * 0.0009) = 88.9 without a floor (kept apart), 0.16 / (0.0018 +
    0.0225) = 6.58 with a 0.15 m floor (merged at 0.99: 9.21), and the soft fusion leaves the
    kept landmark between the two (the gain on l_0 is 0.0009 / 0.0243 of d)."""
    noise = np.eye(2)[None] * 0.0009
    for floor, statistic, merged in ((0.0, 0.16 / 0.0018, []), (0.15, 0.16 / 0.0243, [(1, 0)])):
        slam = EkfSlam([0.0, 0.0, 0.0], np.zeros((3, 3)), 'point_robot')   # a known pose:
        slam.add_landmarks(np.array([[5.0, 0.0]]), noise, np.array([0]))   # no correlation
        manager = LandmarkManager(LandmarkManagementConfig(merge_probability=0.99,
                                                           merge_floor=floor))
        manager.started([0])
        manager.after_scan(slam, [])
        slam.add_landmarks(np.array([[5.0, 0.4]]), noise, np.array([1]))
        assert merge_statistic(slam, 0, 1, floor)[0] == pytest.approx(statistic)
        manager.started([1])
        assert manager.after_scan(slam, []).merged == merged
    np.testing.assert_array_equal(slam.ids, [0])
    assert slam.mean[3:5] == pytest.approx([5.0, 0.4 * 0.0009 / 0.0243])


def test_seen_together_follows_a_merge():
    """Landmark 2 was seen with landmark 1; 1 is merged into 0; then 0 and 2 count as seen
    together: 2, 0.05 m from 0, is not merged into it."""
    slam = EkfSlam([0.0, 0.0, 0.0], np.zeros((3, 3)), 'point_robot')
    noise = np.eye(2)[None] * 0.01
    slam.add_landmarks(np.array([[5.0, 0.0]]), noise, np.array([0]))
    manager = LandmarkManager(LandmarkManagementConfig(merge_probability=0.99))
    manager.started([0])
    manager.after_scan(slam, [])
    slam.add_landmarks(np.array([[5.0, 0.02], [5.0, -0.05]]), np.repeat(noise, 2, axis=0),
                       np.array([1, 2]))
    manager.started([1, 2])                 # 1 and 2 on one scan; 1 is nearer 0 than 2 is
    result = manager.after_scan(slam, [])
    assert result.merged == [(1, 0)]        # the smallest statistic first; 2 then seen with 0
    assert manager.together[0] == {2} and manager.together[2] == {0}
    manager.fused([2])
    assert manager.after_scan(slam, [2]).merged == []
    np.testing.assert_array_equal(slam.ids, [0, 2])


def test_manager_drops_a_landmark_predicted_in_view_but_never_seen():
    # robot at the origin facing +x; landmark 0 ahead (in view), landmark 1 behind (never in
    # a 60-degree field of view), landmark 2 ahead but seen every scan
    slam = EkfSlam([0.0, 0.0, 0.0], np.eye(3) * 1e-4, 'point_robot')
    noise = np.repeat(np.eye(2)[None] * 0.01, 3, axis=0)
    slam.add_landmarks(np.array([[3.0, 0.5], [-3.0, 0.0], [4.0, -0.5]]), noise,
                       np.array([0, 1, 2]))
    config = LandmarkManagementConfig(drop_misses=3, drop_max_sightings=1, view_range=10.0,
                                      view_half_angle=np.deg2rad(30.0))
    manager = LandmarkManager(config)
    manager.started([0, 1, 2])
    assert manager.after_scan(slam, []).dropped == []          # just started: not a miss
    assert manager.after_scan(slam, [2]).dropped == []          # miss 1 of landmark 0
    assert manager.after_scan(slam, [2]).dropped == []          # miss 2
    assert manager.after_scan(slam, [2]).dropped == [0]         # miss 3: dropped
    np.testing.assert_array_equal(slam.ids, [1, 2])
    for _ in range(10):                                        # 1 is behind, 2 seen: kept
        assert manager.after_scan(slam, [2]).dropped == []


def test_manager_spares_established_landmarks_unless_told_otherwise():
    slam = EkfSlam([0.0, 0.0, 0.0], np.eye(3) * 1e-4, 'point_robot')
    slam.add_landmarks(np.array([[3.0, 0.0]]), np.eye(2)[None] * 0.01, np.array([0]))
    for limit, dropped_after in ((1, None), (0, 2)):
        manager = LandmarkManager(LandmarkManagementConfig(drop_misses=2,
                                                           drop_max_sightings=limit))
        manager.started([0])
        manager.fused([0])                   # seen twice: established for limit 1
        manager.after_scan(slam, [0])
        outcomes = [manager.after_scan(slam, []).dropped for _ in range(3)]
        if dropped_after is None:
            assert outcomes == [[], [], []]
        else:
            assert outcomes == [[], [0], []]
            assert len(slam.ids) == 0
            slam.add_landmarks(np.array([[3.0, 0.0]]), np.eye(2)[None] * 0.01, np.array([0]))


def test_inactive_manager_changes_nothing():
    slam = two_sightings_filter(0.0)
    mean = slam.mean.copy()
    manager = LandmarkManager(LandmarkManagementConfig())
    manager.started([0, 1])
    assert not manager.active
    result = manager.after_scan(slam, [])
    assert result.merged == [] and result.dropped == []
    np.testing.assert_array_equal(slam.mean, mean)


def test_seen_together_is_recorded_only_for_pairs_a_merge_could_test():
    """Landmarks seen on one scan are recorded as a pair only when closer than
    TOGETHER_RANGE merge distances (2 x 2 m here): the record grows with the neighbourhoods, not
    with the square of the map."""
    slam = EkfSlam([0.0, 0.0, 0.0], np.zeros((3, 3)), 'point_robot')
    slam.add_landmarks(np.array([[5.0, 0.0], [5.0, 3.9], [5.0, -4.1]]),
                       np.repeat(np.eye(2)[None] * 0.01, 3, axis=0), np.array([0, 1, 2]))
    manager = LandmarkManager(LandmarkManagementConfig(merge_probability=0.99, merge_distance=2.0))
    manager.started([0, 1, 2])
    assert manager.after_scan(slam, []).merged == []
    assert manager.together == {0: {1}, 1: {0}}


def test_a_landmark_started_after_its_scan_is_seen_with_that_scan_only():
    """Live, a scan's new landmarks may arrive after the manager's call for it.  Landmark 2,
    started late from scan 1 at 0.05 m from landmark 3 (seen on scan 0 only), is a duplicate
    of 3: when scan 2 fuses 3, 2 is merged into it (it was never on a scan with 3), and 2 is
    recorded with landmark 0 of its own scan, not with 3 of the next."""
    slam = EkfSlam([0.0, 0.0, 0.0], np.zeros((3, 3)), 'point_robot')
    noise = np.eye(2)[None] * 0.01
    manager = LandmarkManager(LandmarkManagementConfig(merge_probability=0.99))
    slam.add_landmarks(np.array([[5.0, 0.0]]), noise, np.array([3]))
    manager.started([3], scan=0)
    assert manager.after_scan(slam, [], scan=0).merged == []
    slam.add_landmarks(np.array([[5.0, 3.0]]), noise, np.array([0]))
    manager.started([0], scan=1)
    assert manager.after_scan(slam, [], scan=1).merged == []
    slam.add_landmarks(np.array([[5.0, 0.05]]), noise, np.array([2]))
    manager.started([2], scan=1)            # after scan 1's call
    manager.fused([3], scan=2)
    assert manager.after_scan(slam, [3], scan=2).merged == [(2, 3)]
    np.testing.assert_array_equal(slam.ids, [3, 0])
    assert manager.together == {0: {3}, 3: {0}}    # 2's record (with 0) passed on to 3
    assert manager.seen_on == {2: {3}}


def test_a_dropped_landmark_leaves_the_seen_together_record():
    """Landmarks 0 and 2 started on one scan (1.4 m apart: recorded); 0 is never seen again and
    dropped after 2 misses: the record keeps no trace of it (2's entry is empty)."""
    slam = EkfSlam([0.0, 0.0, 0.0], np.eye(3) * 1e-4, 'point_robot')
    slam.add_landmarks(np.array([[3.0, 0.5], [4.0, -0.5]]),
                       np.repeat(np.eye(2)[None] * 0.01, 2, axis=0), np.array([0, 2]))
    manager = LandmarkManager(LandmarkManagementConfig(
        merge_probability=0.99, drop_misses=2, view_range=10.0, view_half_angle=np.pi / 6))
    manager.started([0, 2], scan=0)
    assert manager.after_scan(slam, [], scan=0).dropped == []
    assert manager.together == {0: {2}, 2: {0}}
    manager.fused([2], scan=1)
    assert manager.after_scan(slam, [2], scan=1).dropped == []
    manager.fused([2], scan=2)
    assert manager.after_scan(slam, [2], scan=2).dropped == [0]
    assert manager.together == {2: set()}


def test_a_merge_passes_the_scan_record_to_the_kept_landmark():
    """Landmark 1 (scan 1) is merged into 0; landmark 2 then starts late from scan 1 at 0.07 m
    from 0: it was on scan 1 with 1, now 0, so it is not merged into 0, as when it comes on
    time (the order of messages does not change the map)."""
    outcomes = []
    for late in (False, True):
        slam = EkfSlam([0.0, 0.0, 0.0], np.zeros((3, 3)), 'point_robot')
        noise = np.eye(2)[None] * 0.01
        manager = LandmarkManager(LandmarkManagementConfig(merge_probability=0.99))
        slam.add_landmarks(np.array([[5.0, 0.0]]), noise, np.array([0]))
        manager.started([0], scan=0)
        manager.after_scan(slam, [], scan=0)
        slam.add_landmarks(np.array([[5.0, 0.02]]), noise, np.array([1]))
        manager.started([1], scan=1)
        if not late:
            slam.add_landmarks(np.array([[5.0, 0.07]]), noise, np.array([2]))
            manager.started([2], scan=1)
        merged = manager.after_scan(slam, [], scan=1).merged
        if late:
            slam.add_landmarks(np.array([[5.0, 0.07]]), noise, np.array([2]))
            manager.started([2], scan=1)
        merged += manager.after_scan(slam, [], scan=2).merged
        outcomes.append((merged, slam.ids.tolist(), manager.together))
    assert outcomes[0] == outcomes[1] == ([(1, 0)], [0, 2], {0: {2}, 2: {0}})
