"""Deterministic simulated scenarios for the bags (seeds fixed): each a list of scans.

A scan holds what the node gets (landmarks, robot pose, joint covariance, observations) and the
ground truth of each observation: a landmark id, -1 for a landmark not yet in the map, -2 for
clutter.  Estimates are the truth plus errors drawn from the covariances they are published
with, so the covariances are honest.  Correlated draws use the Cholesky factor (unique), not
numpy's default SVD, whose basis of a repeated eigenvalue depends on the LAPACK build: the bags
then regenerate to the same messages on any machine.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from typing import Callable, Optional

import numpy as np

from ..core import NEW
from ..core.models import MODELS, wrap_angle
from .scan import CLUTTER, Scan
from .street_grid import street_grid
POINT_ALGORITHMS = ('euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood', 'gnn', 'jcbb')


@dataclass(frozen=True)
class Scenario:
    """A named generator with the algorithms that apply and the node parameters it needs."""

    name: str
    description: str
    generate: Callable[[], list[Scan]]
    algorithms: tuple[str, ...] = POINT_ALGORITHMS
    parameters: dict = field(default_factory=dict)


def _range_bearing(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    return MODELS['range_bearing'].predict(points, pose)[0]


def easy_point_map(seed: int = 1) -> list[Scan]:
    """25 landmarks on a jittered 4 m grid, 40 scans of ~12 observations in the map frame
    (sigma 5 cm), landmark sigma 10 cm: every algorithm should be near perfect."""
    rng = np.random.default_rng(seed)
    grid = np.stack(np.meshgrid(np.arange(5), np.arange(5)), -1).reshape(-1, 2) * 4.0
    true = grid + rng.uniform(-0.5, 0.5, grid.shape)
    ids = np.arange(len(true)) + 100
    lm_cov = np.tile(np.eye(2) * 0.01, (len(true), 1, 1))
    estimate = true + rng.normal(0, 0.1, true.shape)
    scans = []
    for step in range(40):
        seen = np.sort(rng.choice(len(true), 12, replace=False))
        z = true[seen] + rng.normal(0, 0.05, (len(seen), 2))
        scans.append(Scan(
            time_ns=int(1e9) + step * 100_000_000, landmark_ids=ids, landmark_means=estimate,
            landmark_covariances=lm_cov,
            observations={'x': z[:, 0], 'y': z[:, 1], 'cov_xx': np.full(len(z), 0.0025),
                          'cov_xy': np.zeros(len(z)), 'cov_yy': np.full(len(z), 0.0025)},
            observation_frame='map', truth=ids[seen], truth_xy=true[seen]))
    return scans


def clutter_range_bearing(seed: int = 2) -> list[Scan]:
    """EKF-SLAM-like: 36 landmarks with 8 near-duplicate pairs (0.9 m apart), a correlated
    joint covariance (pose yaw sigma 0.1 rad dominates; a map-wide drift correlates landmarks),
    range-bearing scans within 18 m (sigma 0.05 m, 0.005 rad) plus 4 clutter returns each."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(-16, 16, (28, 2))
    direction = rng.uniform(0, 2 * np.pi, 8)
    twins = base[:8] + 0.9 * np.column_stack([np.cos(direction), np.sin(direction)])
    true = np.vstack([base, twins])
    n = len(true)
    ids = np.arange(n) * 2 + 1
    noise = np.diag([0.05 ** 2, 0.005 ** 2])
    scans = []
    for step in range(40):
        angle = 2 * np.pi * step / 40
        true_pose = np.array([6 * np.cos(angle), 6 * np.sin(angle), wrap_angle(angle + np.pi / 2)])
        pose_cov = np.diag([0.03 ** 2, 0.03 ** 2, 0.1 ** 2])
        drift = 0.08 ** 2
        size = 3 + 2 * n
        p = np.zeros((size, size))
        p[:3, :3] = pose_cov
        landmark_block = np.kron(np.full((n, n), drift), np.eye(2)) + np.eye(2 * n) * 0.04 ** 2
        p[3:, 3:] = landmark_block
        error = rng.multivariate_normal(np.zeros(size), p, method='cholesky')
        pose_estimate = true_pose + error[:3]
        estimate = true + error[3:].reshape(n, 2)
        z = _range_bearing(true, true_pose)
        visible = np.flatnonzero(z[:, 0] < 18.0)
        z = z[visible] + rng.multivariate_normal(np.zeros(2), noise, len(visible),
                                                  method='cholesky')
        clutter = np.column_stack([rng.uniform(1, 18, 4), rng.uniform(-np.pi, np.pi, 4)])
        values = np.vstack([z, clutter])
        values[:, 1] = wrap_angle(values[:, 1])
        truth = np.concatenate([ids[visible], np.full(4, CLUTTER)])
        truth_xy = np.vstack([true[visible], MODELS['range_bearing'].inverse(clutter,
                                                                            true_pose)[0]])
        covariances = np.array([p[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j] for j in range(n)])
        scans.append(Scan(
            time_ns=int(1e9) + step * 100_000_000, landmark_ids=ids, landmark_means=estimate,
            landmark_covariances=covariances,
            observations={'range': values[:, 0], 'bearing': values[:, 1],
                          'var_range': np.full(len(values), noise[0, 0]),
                          'var_bearing': np.full(len(values), noise[1, 1])},
            observation_frame='base_link', truth=truth, truth_xy=truth_xy,
            pose=(pose_estimate, pose_cov), state_covariance=p))
    return scans


def exploration(seed: int = 3, clutter: int = 0, sightings_to_map: int = 1) -> list[Scan]:
    """A robot drives 60 m along a corridor of 40 landmarks, sensing positions in its own frame
    within 8 m (sigma 5 cm); a landmark enters the map the scan after it is first seen, so its
    first observation is NEW (-1)."""
    rng = np.random.default_rng(seed)
    xs = np.sort(rng.uniform(0, 64, 40))
    true = np.column_stack([xs, rng.choice([-1, 1], 40) * rng.uniform(1.5, 4, 40)])
    ids = np.arange(40) + 500
    mapped: dict[int, np.ndarray] = {}
    sightings = np.zeros(40, dtype=int)
    scans = []
    for step in range(60):
        true_pose = np.array([step * 1.0, 0.2 * np.sin(step / 5), 0.05 * np.cos(step / 7)])
        pose_cov = np.diag([0.02 ** 2, 0.02 ** 2, 0.01 ** 2])
        pose_estimate = true_pose + rng.multivariate_normal(np.zeros(3), pose_cov,
                                                           method='cholesky')
        in_map = np.array(sorted(mapped), dtype=int)
        distance = np.hypot(*(true - true_pose[:2]).T)
        seen = np.flatnonzero(distance < 8.0)
        z = MODELS['point_robot'].predict(true[seen], true_pose)[0] + \
            rng.normal(0, 0.05, (len(seen), 2))
        truth = np.where(np.isin(seen, in_map), ids[seen], NEW)
        truth_xy = true[seen]
        if clutter:
            false = np.column_stack([rng.uniform(-6, 6, clutter), rng.uniform(-6, 6, clutter)])
            z = np.vstack([z, false])
            truth = np.concatenate([truth, np.full(clutter, CLUTTER)])
            truth_xy = np.vstack([truth_xy, MODELS['point_robot'].inverse(false, true_pose)[0]])
        means = np.array([mapped[j] for j in in_map]).reshape(-1, 2)
        scans.append(Scan(
            time_ns=int(1e9) + step * 100_000_000, landmark_ids=ids[in_map], landmark_means=means,
            landmark_covariances=np.tile(np.eye(2) * 0.05 ** 2, (len(in_map), 1, 1)),
            observations={'x': z[:, 0], 'y': z[:, 1], 'cov_xx': np.full(len(z), 0.0025),
                          'cov_xy': np.zeros(len(z)), 'cov_yy': np.full(len(z), 0.0025)},
            observation_frame='base_link', truth=truth, truth_xy=truth_xy,
            pose=(pose_estimate, pose_cov)))
        sightings[seen] += 1
        for j in seen[sightings[seen] >= sightings_to_map]:
            mapped.setdefault(int(j), true[j] + rng.normal(0, 0.05, 2))
    return scans


def exploration_clutter(seed: int = 6) -> list[Scan]:
    """exploration with 2 clutter returns per scan (uniform within 6 m of the robot) and a map
    owner that adds a landmark only after its third sighting, so each landmark is NEW (-1) on
    its first three observations: the bag for confirming new landmarks (confirm_hits)."""
    return exploration(seed, clutter=2, sightings_to_map=3)


def boxes(seed: int = 4) -> list[Scan]:
    """Four boxes (pixels, 640 x 480) at constant velocity; two cross; a box more than half
    covered by a nearer one is not detected; 5 % random misses; a false detection every third
    frame.  Landmarks are the tracker's predicted boxes (truth + 2 px noise)."""
    rng = np.random.default_rng(seed)
    start = np.array([[100, 200, 60, 120], [540, 220, 70, 140], [320, 80, 50, 50],
                      [200, 400, 90, 60]], float)
    velocity = np.array([[8, 0, 0, 0], [-8, 0, 0, 0], [0, 3, 0, 0], [2, -1, 0, 0]], float)
    depth = np.array([1.0, 2.0, 3.0, 4.0])  # smaller is nearer
    ids = np.array([1, 2, 3, 4])
    scans = []
    for step in range(60):
        truth_boxes = start + velocity * step
        visible = []
        for j in range(4):
            covered = 0.0
            for k in range(4):
                if k != j and depth[k] < depth[j]:
                    lo = np.maximum(truth_boxes[j, :2] - truth_boxes[j, 2:] / 2,
                                    truth_boxes[k, :2] - truth_boxes[k, 2:] / 2)
                    hi = np.minimum(truth_boxes[j, :2] + truth_boxes[j, 2:] / 2,
                                    truth_boxes[k, :2] + truth_boxes[k, 2:] / 2)
                    covered = max(covered, np.prod(np.clip(hi - lo, 0, None))
                                  / np.prod(truth_boxes[j, 2:]))
            if covered <= 0.5 and rng.uniform() > 0.05:
                visible.append(j)
        visible = np.array(visible, dtype=int)
        detections = truth_boxes[visible] + rng.normal(0, 2.0, (len(visible), 4))
        truth = ids[visible]
        if step % 3 == 0:
            false = np.array([[rng.uniform(40, 600), rng.uniform(40, 440), 40, 40]])
            detections = np.vstack([detections, false])
            truth = np.concatenate([truth, [CLUTTER]])
        predicted = truth_boxes + rng.normal(0, 2.0, truth_boxes.shape)
        scans.append(Scan(
            time_ns=int(1e9) + step * 50_000_000, landmark_ids=ids, landmark_means=predicted,
            landmark_covariances=None,
            observations={'x': detections[:, 0], 'y': detections[:, 1],
                          'width': detections[:, 2], 'height': detections[:, 3],
                          'score': rng.uniform(0.5, 1.0, len(detections))},
            observation_frame='camera', truth=truth, truth_xy=np.vstack(
                [truth_boxes[visible, :2], detections[len(visible):, :2]]), map_frame='camera'))
    return scans


def eight_identical_landmarks(seed: int = 0) -> list[Scan]:
    """Shelly & Indelman's ten-step scenario (core.multi_hypothesis.scenario): eight identical
    known landmarks, the nearest within 3 m observed as a relative position (sigma 0.48 m) or
    nothing; wheel odometry on /odometry (the noisy increments integrated, their covariance
    0.5 m, 1e-3 rad per step); the start pose on /robot_pose at the first scan only."""
    from ..core.multi_hypothesis.motion import compose
    from ..core.multi_hypothesis import scenario
    poses, increments, observations, truth = scenario.simulate(seed)
    ids = np.arange(8) + 1
    odometry = poses[0].copy()
    scans = []
    for k, (u, z, true) in enumerate(zip(increments, observations, truth), start=1):
        odometry = compose(odometry, u)
        seen = z is not None
        values = np.asarray(z).reshape(-1, 2) if seen else np.zeros((0, 2))
        r = scenario.MEASUREMENT_NOISE
        scans.append(Scan(
            time_ns=int(1e9) + k * 500_000_000, landmark_ids=ids,
            landmark_means=scenario.LANDMARKS, landmark_covariances=None,
            observations={'x': values[:, 0], 'y': values[:, 1],
                          'cov_xx': np.full(len(values), r[0, 0]),
                          'cov_xy': np.zeros(len(values)),
                          'cov_yy': np.full(len(values), r[1, 1])},
            observation_frame='base_link',
            truth=np.array([ids[true]] if seen else [], dtype=np.int64),
            truth_xy=scenario.LANDMARKS[[true]] if seen else np.zeros((0, 2)),
            pose=(poses[0], scenario.MOTION_NOISE) if k == 1 else None,
            odometry=(odometry, scenario.MOTION_NOISE)))
    return scans



STREET_GRID_PARAMETERS = {'prior_map': True, 'time_budget_ms': 0.0, 'gate_probability': 0.999}
"""A map published once (transient_local); JCBB without a time budget (answers independent of
the machine's speed)."""

SCENARIOS: dict[str, Scenario] = {s.name: s for s in (
    Scenario('easy_point_map', easy_point_map.__doc__, easy_point_map),
    Scenario('clutter_range_bearing', clutter_range_bearing.__doc__, clutter_range_bearing,
             # no time budget: JCBB's answer must not depend on the machine's speed
             parameters={'time_budget_ms': 0.0}),
    Scenario('exploration', exploration.__doc__, exploration),
    Scenario('exploration_clutter', exploration_clutter.__doc__, exploration_clutter),
    Scenario('eight_identical_landmarks', eight_identical_landmarks.__doc__,
             eight_identical_landmarks, algorithms=('multi_hypothesis',),
             parameters={'measurement_model': 'point_robot', 'mh_fov_range': 3.0,
                         'pose_tolerance': 0.01}),
    Scenario('street_grid', street_grid.__doc__, street_grid,
             parameters=STREET_GRID_PARAMETERS),
    Scenario('street_grid_small', 'street_grid with a 540-pole map (side 216 m): the same '
             'scans; the baseline of the large map\'s latency', partial(street_grid, side=216.0),
             parameters=STREET_GRID_PARAMETERS),
    Scenario('boxes', boxes.__doc__, boxes,
             algorithms=('iou', 'euclidean_nn', 'mahalanobis_nn', 'gnn', 'jcbb'),
             parameters={'default_landmark_covariance': 16.0, 'observation_noise': [16.0],
                         'euclidean_gate': 40.0}),
)}
