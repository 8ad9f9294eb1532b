"""Random association problems and straightforward reference computations for the tests.

The references build full Jacobians and joint covariances one pair at a time, independently of
the vectorised code in data_association_ros.core.problem.
"""
from __future__ import annotations

import itertools

import numpy as np

from data_association_ros import Landmarks, Observations, RobotPose
from data_association_ros.core.models import MODELS, wrap_angle


def random_range_bearing_problem(rng: np.random.Generator, n_landmarks: int, n_seen: int,
                                 n_clutter: int, duplicates: int = 1,
                                 joint: bool = False):
    """EKF-SLAM-like scan: landmarks around the robot, a yaw-dominated pose error shared by all
    observations, `duplicates` near-duplicate landmarks, uniform clutter.

    Returns (landmarks, observations, pose, state_covariance or None, truth (K,) ids/-1)."""
    means = rng.uniform(-8, 8, size=(n_landmarks, 2))
    for k in range(min(duplicates, n_landmarks - 1)):
        means[k + 1] = means[k] + rng.normal(0, 0.4, size=2)
    covariances = np.array([_random_spd(rng, 2, 0.005, 0.05) for _ in range(n_landmarks)])
    pose_cov = np.diag([rng.uniform(0.005, 0.05), rng.uniform(0.005, 0.05),
                        rng.uniform(0.002, 0.02)])
    pose_mean = np.array([0.3, -0.2, 0.1])
    true_pose = pose_mean + rng.multivariate_normal(np.zeros(3), pose_cov)
    state_covariance = None
    if joint:
        size = 3 + 2 * n_landmarks
        a = rng.normal(size=(size, size)) * 0.03
        state_covariance = a @ a.T + np.diag(np.concatenate(
            [np.diag(pose_cov), np.repeat(0.01, 2 * n_landmarks)]))
        true_landmarks = means.copy()
        covariances = np.array([state_covariance[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j]
                                for j in range(n_landmarks)])
    else:
        true_landmarks = means + np.array([rng.multivariate_normal(np.zeros(2), c)
                                           for c in covariances])
    seen = rng.choice(n_landmarks, size=min(n_seen, n_landmarks), replace=False)
    noise = np.diag([0.05 ** 2, 0.01 ** 2])
    model = MODELS['range_bearing']
    z, _, _ = model.predict(true_landmarks[seen], true_pose)
    z = z + rng.multivariate_normal(np.zeros(2), noise, size=len(seen))
    clutter = np.column_stack([rng.uniform(0.5, 10, n_clutter), rng.uniform(-np.pi, np.pi,
                                                                            n_clutter)])
    values = np.vstack([z, clutter])
    values[:, 1] = wrap_angle(values[:, 1])
    ids = np.arange(n_landmarks) * 3 + 10
    truth = np.concatenate([ids[seen], np.full(n_clutter, -2)])
    landmarks = Landmarks(ids, means, covariances)
    observations = Observations(values, np.tile(noise, (len(values), 1, 1)), 'range_bearing')
    return landmarks, observations, RobotPose(pose_mean, pose_cov), state_covariance, truth


def _random_spd(rng, dim, low, high):
    q, _ = np.linalg.qr(rng.normal(size=(dim, dim)))
    return q @ np.diag(rng.uniform(low, high, dim)) @ q.T


def full_jacobian(landmarks, observations, pose, j):
    """dh_j/dy (m, 3 + N d) for the joint state y = [pose, landmarks]."""
    model = MODELS[observations.model]
    n, d = len(landmarks), landmarks.dim
    _, h_m, h_x = model.predict(landmarks.means[j:j + 1], None if pose is None else pose.mean)
    jac = np.zeros((observations.dim, 3 + n * d))
    jac[:, :3] = h_x[0]
    jac[:, 3 + j * d:3 + (j + 1) * d] = h_m[0]
    return jac


def joint_covariance(landmarks, pose, state_covariance):
    """P of y = [pose, landmarks] (block diagonal unless `state_covariance` is given)."""
    if state_covariance is not None:
        return np.asarray(state_covariance)
    n, d = len(landmarks), landmarks.dim
    p = np.zeros((3 + n * d, 3 + n * d))
    if pose is not None:
        p[:3, :3] = pose.covariance
    for j in range(n):
        p[3 + j * d:3 + (j + 1) * d, 3 + j * d:3 + (j + 1) * d] = landmarks.covariances[j]
    return p


def innovation(landmarks, observations, pose, i, j):
    """z_i - h_j with angles wrapped, one pair at a time."""
    model = MODELS[observations.model]
    h, _, _ = model.predict(landmarks.means[j:j + 1], None if pose is None else pose.mean)
    nu = observations.values[i] - h[0]
    for a in model.angular:
        nu[a] = (nu[a] + np.pi) % (2 * np.pi) - np.pi
    return nu


def pair_nis(landmarks, observations, pose, state_covariance, i, j):
    """(NIS, S) of one pair from the full Jacobian and joint covariance."""
    jac = full_jacobian(landmarks, observations, pose, j)
    s = jac @ joint_covariance(landmarks, pose, state_covariance) @ jac.T + \
        observations.covariances[i]
    nu = innovation(landmarks, observations, pose, i, j)
    return float(nu @ np.linalg.solve(s, nu)), s


def joint_nis(landmarks, observations, pose, state_covariance, pairs):
    """Joint NIS of pairs [(i, j), ...]: stacked innovation, C = H P H^T + blockdiag(R)."""
    if not pairs:
        return 0.0
    p = joint_covariance(landmarks, pose, state_covariance)
    jac = np.vstack([full_jacobian(landmarks, observations, pose, j) for _, j in pairs])
    m = observations.dim
    c = jac @ p @ jac.T
    for k, (i, _) in enumerate(pairs):
        c[k * m:(k + 1) * m, k * m:(k + 1) * m] += observations.covariances[i]
    nu = np.concatenate([innovation(landmarks, observations, pose, i, j) for i, j in pairs])
    return float(nu @ np.linalg.solve(c, nu))


def one_to_one_subsets(compatible: np.ndarray):
    """Every one-to-one partial assignment {i: j} using only pairs with compatible[i, j]."""
    k = compatible.shape[0]
    options = [[None] + list(np.flatnonzero(compatible[i])) for i in range(k)]
    for choice in itertools.product(*options):
        taken = [j for j in choice if j is not None]
        if len(taken) == len(set(taken)):
            yield [(i, int(j)) for i, j in enumerate(choice) if j is not None]
