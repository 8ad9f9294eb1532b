"""Benchmark problems: seeded scans of any size, and the clutter_range_bearing bag's scans.

Sizes grow at a constant landmark density, so the candidates per observation (and JCBB's
search) stay comparable from 10 to 1000 landmarks.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from data_association_ros import Landmarks, Observations, RobotPose
from data_association_ros.bag.scenarios import clutter_range_bearing
from data_association_ros.core.models import MODELS, wrap_angle


@dataclass
class Scene:
    """One single-scan problem and, per observation, the index of its landmark (-1: clutter)."""

    landmarks: Landmarks
    observations: Observations
    pose: Optional[RobotPose]
    state_covariance: Optional[np.ndarray]
    truth_index: np.ndarray

    def inputs(self) -> dict:
        """Keyword arguments of associate()."""
        return {'landmarks': self.landmarks, 'observations': self.observations,
                'pose': self.pose, 'state_covariance': self.state_covariance}


def _observed(rng: np.random.Generator, k: int, n: int) -> tuple[np.ndarray, int]:
    """(indices of the landmarks seen, clutter count): 90 % of K seen (at most N), the rest
    clutter."""
    seen = min(n, k - k // 10)
    return rng.choice(n, size=seen, replace=False), k - seen


def range_bearing_scene(k: int, n: int, seed: int = 0) -> Scene:
    """N landmarks uniform in a square of side 4 sqrt(N) m around the robot (one per 16 m^2),
    landmark sigma 0.1 m, pose sigma (0.05 m, 0.05 m, 0.02 rad) shared by all predictions;
    K range-bearing returns (sigma 0.05 m, 0.01 rad), 10 % clutter."""
    rng = np.random.default_rng(seed)
    half = 2.0 * np.sqrt(n)
    true = rng.uniform(-half, half, (n, 2))
    cov = np.tile(np.eye(2) * 0.1 ** 2, (n, 1, 1))
    means = true + rng.normal(0.0, 0.1, (n, 2))
    pose_cov = np.diag([0.05 ** 2, 0.05 ** 2, 0.02 ** 2])
    pose_mean = rng.multivariate_normal(np.zeros(3), pose_cov, method='cholesky')
    seen, clutter = _observed(rng, k, n)
    noise = np.diag([0.05 ** 2, 0.01 ** 2])
    z, _, _ = MODELS['range_bearing'].predict(true[seen], np.zeros(3))
    z = z + rng.multivariate_normal(np.zeros(2), noise, len(seen), method='cholesky')
    false = np.column_stack([rng.uniform(0.5, half, clutter), rng.uniform(-np.pi, np.pi, clutter)])
    values = np.vstack([z, false])
    values[:, 1] = wrap_angle(values[:, 1])
    return Scene(Landmarks(np.arange(n), means, cov),
                 Observations(values, np.tile(noise, (k, 1, 1)), 'range_bearing'),
                 RobotPose(pose_mean, pose_cov), None,
                 np.concatenate([seen, np.full(clutter, -1)]))


def point_map_scene(k: int, n: int, seed: int = 0) -> Scene:
    """Tracks (landmarks) uniform in a square of side 4 sqrt(N) m, sigma 0.3 m; K detections in
    the map frame (sigma 0.2 m), 10 % clutter: the single-scan problem of a tracker."""
    rng = np.random.default_rng(seed)
    half = 2.0 * np.sqrt(n)
    true = rng.uniform(-half, half, (n, 2))
    cov = np.tile(np.eye(2) * 0.3 ** 2, (n, 1, 1))
    means = true + rng.normal(0.0, 0.3, (n, 2))
    seen, clutter = _observed(rng, k, n)
    values = np.vstack([true[seen] + rng.normal(0.0, 0.2, (len(seen), 2)),
                        rng.uniform(-half, half, (clutter, 2))])
    return Scene(Landmarks(np.arange(n), means, cov),
                 Observations(values, np.tile(np.eye(2) * 0.2 ** 2, (k, 1, 1)), 'point_map'),
                 None, None, np.concatenate([seen, np.full(clutter, -1)]))


def box_scene(k: int, n: int, seed: int = 0) -> Scene:
    """N predicted boxes (30-80 px) in an image of side 100 sqrt(N) px; K detections: the boxes
    moved by sigma 3 px, 10 % random boxes."""
    rng = np.random.default_rng(seed)
    side = 100.0 * np.sqrt(n)
    boxes = np.column_stack([rng.uniform(0, side, (n, 2)), rng.uniform(30, 80, (n, 2))])
    seen, clutter = _observed(rng, k, n)
    detections = np.vstack([boxes[seen] + rng.normal(0.0, 3.0, (len(seen), 4)),
                            np.column_stack([rng.uniform(0, side, (clutter, 2)),
                                             rng.uniform(30, 80, (clutter, 2))])])
    return Scene(Landmarks(np.arange(n), boxes, np.tile(np.eye(4) * 9.0, (n, 1, 1))),
                 Observations(detections, np.tile(np.eye(4) * 9.0, (k, 1, 1)), 'box'),
                 None, None, np.concatenate([seen, np.full(clutter, -1)]))


def bag_scenes(seeds: tuple[int, ...] = (2, 5)) -> list[Scene]:
    """The scans of the clutter_range_bearing scenario (the committed bag is seed 2): 26-35
    range-bearing returns, 36 landmarks with 8 near-duplicate pairs, 4 clutter, a joint state
    covariance with a yaw sigma of 0.1 rad."""
    scenes = []
    for seed in seeds:
        for scan in clutter_range_bearing(seed):
            obs = scan.observations
            k = len(obs['range'])
            cov = np.zeros((k, 2, 2))
            cov[:, 0, 0], cov[:, 1, 1] = obs['var_range'], obs['var_bearing']
            index = {int(i): j for j, i in enumerate(scan.landmark_ids)}
            scenes.append(Scene(
                Landmarks(scan.landmark_ids, scan.landmark_means, scan.landmark_covariances),
                Observations(np.column_stack([obs['range'], obs['bearing']]), cov,
                             'range_bearing'),
                RobotPose(*scan.pose), scan.state_covariance,
                np.array([index.get(int(t), -1) for t in scan.truth])))
    return scenes
