"""EKF-SLAM core against a dense textbook EKF with finite-difference Jacobians, and a Monte-Carlo
consistency check (NEES) on a simulated world."""
import numpy as np
import pytest

from data_association_ros.core import InvalidInputError
from data_association_ros.core.models import MODELS, wrap_angle
from data_association_ros.core.multi_hypothesis.motion import compose
from data_association_ros.core.slam import EkfSlam, OdometryIncrements


def numeric_jacobian(function, x, eps=1e-6):
    """d function / d x by central differences (function returns a vector)."""
    x = np.asarray(x, dtype=float)
    columns = []
    for i in range(len(x)):
        step = np.zeros_like(x)
        step[i] = eps
        columns.append((function(x + step) - function(x - step)) / (2 * eps))
    return np.stack(columns, axis=1)


def random_covariance(rng, n, scale):
    a = rng.normal(size=(n, n)) * scale
    return a @ a.T + np.eye(n) * scale ** 2


def slam_with_map(rng, model, n=4):
    slam = EkfSlam([1.0, -2.0, 0.7], np.zeros((3, 3)), model)
    slam.mean = np.concatenate([[1.0, -2.0, 0.7], rng.uniform(-10, 10, 2 * n)])
    slam.covariance = random_covariance(rng, 3 + 2 * n, 0.1)
    slam.ids = np.arange(n) * 10 + 5
    return slam


def test_predict_matches_finite_differences():
    rng = np.random.default_rng(0)
    slam = slam_with_map(rng, 'range_bearing')
    u, q = np.array([0.8, 0.1, 0.2]), np.diag([0.01, 0.02, 0.003])
    x0, p0 = slam.mean.copy(), slam.covariance.copy()

    def move(x, increment=u):
        out = x.copy()
        out[:3] = compose(x[:3], increment)
        return out
    f = numeric_jacobian(move, x0)
    v = numeric_jacobian(lambda w: move(x0, w), u)
    slam.predict(u, q)
    np.testing.assert_allclose(slam.mean, move(x0), atol=1e-12)
    np.testing.assert_allclose(slam.covariance, f @ p0 @ f.T + v @ q @ v.T, atol=1e-8)


@pytest.mark.parametrize('model', ['range_bearing', 'point_robot'])
def test_update_matches_dense_textbook_ekf(model):
    rng = np.random.default_rng(1)
    slam = slam_with_map(rng, model)
    x0, p0 = slam.mean.copy(), slam.covariance.copy()
    ids = np.array([25, 5, 35])
    index = [2, 0, 3]

    def h(x):
        means = x[3:].reshape(-1, 2)[index]
        return MODELS[model].predict(means, x[:3])[0].ravel()
    truth = h(x0) + rng.normal(0, 0.05, 6)
    z = truth.reshape(3, 2)
    r = np.array([random_covariance(rng, 2, 0.05) for _ in range(3)])
    jac = numeric_jacobian(h, x0)
    s = jac @ p0 @ jac.T
    s = s + np.block([[r[i] if i == j else np.zeros((2, 2)) for j in range(3)]
                      for i in range(3)])
    nu = z.ravel() - h(x0)
    if model == 'range_bearing':
        nu[1::2] = wrap_angle(nu[1::2])
    gain = p0 @ jac.T @ np.linalg.inv(s)
    nis = slam.update(z, r, ids)
    np.testing.assert_allclose(slam.mean, x0 + gain @ nu, atol=1e-7)
    np.testing.assert_allclose(slam.covariance, p0 - gain @ s @ gain.T, atol=1e-7)
    assert nis == pytest.approx(nu @ np.linalg.solve(s, nu), rel=1e-6)


@pytest.mark.parametrize('model', ['range_bearing', 'point_robot'])
def test_add_landmarks_matches_finite_differences(model):
    rng = np.random.default_rng(2)
    slam = slam_with_map(rng, model, n=2)
    x0, p0 = slam.mean.copy(), slam.covariance.copy()
    z = np.array([[6.0, 0.4], [3.0, -1.2]]) if model == 'range_bearing' else \
        np.array([[4.0, 1.0], [-2.0, 3.0]])
    r = np.array([random_covariance(rng, 2, 0.05) for _ in range(2)])

    def augment(x_and_z):
        x, zz = x_and_z[:len(x0)], x_and_z[len(x0):].reshape(2, 2)
        return np.concatenate([x, MODELS[model].inverse(zz, x[:3])[0].ravel()])
    joint = np.concatenate([x0, z.ravel()])
    jac = numeric_jacobian(augment, joint)
    cov = np.zeros((len(joint), len(joint)))
    cov[:len(x0), :len(x0)] = p0
    cov[len(x0):, len(x0):] = np.block([[r[0], np.zeros((2, 2))], [np.zeros((2, 2)), r[1]]])
    slam.add_landmarks(z, r, [100, 101])
    np.testing.assert_allclose(slam.mean, augment(joint), atol=1e-9)
    np.testing.assert_allclose(slam.covariance, jac @ cov @ jac.T, atol=1e-7)
    assert list(slam.ids) == [5, 15, 100, 101]
    assert list(slam.index_of([101, 7, 5])) == [3, -1, 0]
    with pytest.raises(InvalidInputError, match='ids'):
        slam.add_landmarks(z[:1], r[:1], [15])
    with pytest.raises(InvalidInputError, match='not in the map'):
        slam.update(z[:1], r[:1], [7])


def test_odometry_increments_compose_and_propagate():
    rng = np.random.default_rng(3)
    poses = [np.array([2.0, 1.0, 0.3])]
    steps = [np.array([1.0, 0.2, 0.1]), np.array([0.5, -0.1, -0.4]), np.array([0.7, 0.0, 0.2])]
    noises = [random_covariance(rng, 3, 0.05) for _ in steps]
    for step in steps:
        poses.append(compose(poses[-1], step))
    odometry = OdometryIncrements()
    odometry.add(poses[0], np.eye(3))   # origin: its covariance is not used
    for pose, noise in zip(poses[1:], noises):
        odometry.add(pose, noise)
    increment, noise = odometry.take()
    total = compose(compose(steps[0], steps[1]), steps[2])
    np.testing.assert_allclose(increment, total, atol=1e-12)

    def chained(flat):
        a, b, c = flat.reshape(3, 3)
        return compose(compose(a, b), c)
    jac = numeric_jacobian(chained, np.concatenate(steps))
    block = np.zeros((9, 9))
    for k, q in enumerate(noises):
        block[3 * k:3 * k + 3, 3 * k:3 * k + 3] = q
    np.testing.assert_allclose(noise, jac @ block @ jac.T, atol=1e-8)
    assert np.all(odometry.take()[0] == 0)


def test_filter_is_consistent_on_a_simulated_world():
    """Mean pose NEES over 40 runs x 30 steps near chi2_3's mean of 3 (mildly above it:
    EKF-SLAM's linearisation makes it overconfident)."""
    rng = np.random.default_rng(4)
    world = rng.uniform(-15, 15, (12, 2))
    q, r = np.diag([0.05, 0.05, 0.02]) ** 2, np.diag([0.1, 0.02]) ** 2
    model = MODELS['range_bearing']
    nees = np.zeros(30)
    runs = 40
    for _ in range(runs):
        true_pose = np.array([0.0, 0.0, 0.0])
        slam = EkfSlam(true_pose, np.zeros((3, 3)), 'range_bearing')
        for step in range(30):
            u = np.array([1.0, 0.0, 0.2])
            true_pose = compose(true_pose, u + rng.multivariate_normal(np.zeros(3), q))
            slam.predict(u, q)
            z = model.predict(world, true_pose)[0] + rng.multivariate_normal(
                np.zeros(2), r, len(world))
            z[:, 1] = wrap_angle(z[:, 1])
            seen = np.flatnonzero(z[:, 0] < 12)
            known = seen[slam.index_of(seen) >= 0]
            new = seen[slam.index_of(seen) < 0]
            slam.update(z[known], np.tile(r, (len(known), 1, 1)), known)
            slam.add_landmarks(z[new], np.tile(r, (len(new), 1, 1)), new)
            error = slam.mean[:3] - true_pose
            error[2] = wrap_angle(error[2])
            nees[step] += error @ np.linalg.solve(slam.covariance[:3, :3] + 1e-12 * np.eye(3),
                                                  error)
    mean_nees = nees.sum() / (runs * 30)
    # 1200 samples of chi2(3): mean 3 with std sqrt(6 / 1200) = 0.07 if consistent; EKF-SLAM
    # is mildly overconfident over long runs (measured 3.53), so allow up to 4
    assert 2.5 < mean_nees < 4.0, mean_nees
