"""bag/slam_consistency.py: chi-square summaries against hand-computed values and a sampled
consistent filter."""
import numpy as np
import pytest
from scipy.stats import chi2

from data_association_ros.bag.slam_consistency import chi_square_summary, pose_nees, update_nis
from data_association_ros.bag.slam_run import SlamRun
from data_association_ros.bag.slam_scoring import SlamTruth

S = 1_000_000_000


def test_chi_square_summary_by_hand():
    low, high = chi2.ppf(0.025, 2), chi2.ppf(0.975, 2)       # 0.0506, 7.378
    summary = chi_square_summary(np.array([0.01, 1.0, 3.0, 10.0]), np.full(4, 2.0))
    assert summary['ratio'] == pytest.approx(14.01 / 8.0)
    assert summary['inside'] == 0.5 and summary['above'] == 0.25 and summary['count'] == 4
    assert low < 1.0 < high
    empty = chi_square_summary(np.array([]), np.array([]))
    assert empty['count'] == 0 and np.isnan(empty['ratio'])


def test_nis_and_nees_of_a_consistent_sample():
    rng = np.random.default_rng(7)
    covariance = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.002], [0.0, 0.002, 0.01]])
    truth = SlamTruth({}, {}, {}, {})
    run = SlamRun()
    for k in range(4000):
        stamp = (k + 1) * S
        true_pose = np.array([k * 0.1, 0.0, 3.1])          # yaw near pi: the error wraps
        error = rng.multivariate_normal(np.zeros(3), covariance)
        estimate = true_pose - error
        estimate[2] = (estimate[2] + np.pi) % (2 * np.pi) - np.pi
        truth.poses[stamp] = true_pose
        run.poses[stamp] = estimate
        run.pose_covariances[stamp] = covariance
        dof = 2 * (k % 3)                                  # updates of 0, 1 or 2 pairs
        run.update_nis[stamp] = (float(rng.chisquare(dof)) if dof else 0.0, dof)
    run.pose_covariances[1 * S] = np.zeros((3, 3))         # singular: left out
    nees = pose_nees(run, truth)
    assert nees['count'] == 3999
    assert nees['ratio'] == pytest.approx(1.0, abs=0.05)
    assert nees['inside'] == pytest.approx(0.95, abs=0.015)
    nis = update_nis(run)
    assert nis['count'] == 2666                            # the updates without pairs left out
    assert nis['ratio'] == pytest.approx(1.0, abs=0.05)
    assert nis['inside'] == pytest.approx(0.95, abs=0.015)
