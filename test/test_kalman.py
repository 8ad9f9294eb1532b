"""The Kalman filter and the box tracker's conversions against hand-computed values."""
import numpy as np
import pytest

from data_association_ros import InvalidInputError
from data_association_ros.core.tracking import BoxTracker, KalmanFilter
from data_association_ros.core.tracking.box_tracker import box_to_z, z_to_box


def test_constant_velocity_predict_and_update_by_hand():
    # x = [position, velocity], dt = 1, q = 0.5 on velocity, r = 2
    kf = KalmanFilter([0.0, 1.0], np.diag([4.0, 1.0]), [[1, 1], [0, 1]], np.diag([0.0, 0.5]),
                      [[1.0, 0.0]], [[2.0]])
    kf.predict()
    np.testing.assert_allclose(kf.x, [1.0, 1.0])
    np.testing.assert_allclose(kf.p, [[5.0, 1.0], [1.0, 1.5]])  # F P F^T + Q
    np.testing.assert_allclose(kf.innovation_covariance(), [[7.0]])  # 5 + 2
    kf.update([3.0])
    # K = P H^T / S = [5/7, 1/7]; x = [1, 1] + K * (3 - 1)
    np.testing.assert_allclose(kf.x, [1 + 10 / 7, 1 + 2 / 7])
    # P = (I - K H) P: [[10/7, 2/7], [2/7, 1.5 - 1/7]]
    np.testing.assert_allclose(kf.p, [[10 / 7, 2 / 7], [2 / 7, 1.5 - 1 / 7]])


def test_correct_with_an_innovation_and_its_jacobian_by_hand():
    """P = [[2, 1], [1, 2]], H = [0, 1], R = 1, innovation 3: S = 3, K = [1/3, 2/3], x = [1, 2],
    P = P - K S K^T = [[5/3, 1/3], [1/3, 2/3]] (the Joseph form gives the same); update(z)
    with z - H x = 3 is the same correction."""
    p, h, r = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([[0.0, 1.0]]), np.array([[1.0]])
    full = KalmanFilter(np.zeros(2), p, np.eye(2), np.zeros((2, 2)), h, r)
    full.correct(np.array([3.0]), h, r)
    np.testing.assert_allclose(full.x, [1.0, 2.0])
    np.testing.assert_allclose(full.p, [[5 / 3, 1 / 3], [1 / 3, 2 / 3]])
    update = KalmanFilter(np.zeros(2), p, np.eye(2), np.zeros((2, 2)), h, r)
    update.update([3.0])
    np.testing.assert_allclose(update.x, full.x)
    np.testing.assert_allclose(update.p, full.p)


def test_box_state_conversions_and_jacobian():
    box = np.array([10.0, 20.0, 4.0, 16.0])
    z = box_to_z(box)
    np.testing.assert_allclose(z, [10, 20, 64, 0.25])
    back, jacobian = z_to_box(z)
    np.testing.assert_allclose(back, box)
    step = 1e-6
    for k in (2, 3):
        dz = np.zeros(4)
        dz[k] = step
        numeric = (z_to_box(z + dz)[0] - z_to_box(z - dz)[0]) / (2 * step)
        np.testing.assert_allclose(jacobian[:, k], numeric, rtol=1e-6)


def test_tracker_keeps_ids_confirms_after_min_hits_and_deletes_after_max_age():
    tracker = BoxTracker('iou', min_hits=3, max_age=1)
    a, b = np.array([50.0, 50.0, 20.0, 40.0]), np.array([200.0, 80.0, 30.0, 60.0])
    out = [tracker.step(np.array([a + [2 * k, 0, 0, 0], b])) for k in range(5)]
    assert [sorted(i for i, _ in o) for o in out] == [[1, 2]] * 5  # first min_hits frames too
    assert [len(tracker.step(np.zeros((0, 4)))) for _ in range(2)] == [0, 0]
    assert tracker.tracks == []  # not updated for 2 > max_age frames
    assert [i for i, _ in tracker.step(np.array([a]))] == []  # a new track is not confirmed
    assert tracker.tracks[0].id == 3


def test_tracker_refuses_an_associator_that_cannot_do_boxes():
    with pytest.raises(InvalidInputError):
        BoxTracker('jcbb_points')
