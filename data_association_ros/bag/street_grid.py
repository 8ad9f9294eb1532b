"""Localisation against a large prior map: poles along a city's street grid.

Streets every 50 m in x and y; poles on both sides of every street (6 m from its centre line)
every 8 m, jittered by 0.5 m; the map of a square of side `side` m centred on the route
(side 2250: about 50,700 poles; side 216: 540).  The map is published once, before the first scan
(transient_local, `prior_map`), with sigma 0.05 m per pole.  A robot drives a rounded 100 m x
100 m loop through the centre at 5 m/s; 10 Hz range-bearing scans (sigma 0.1 m, 0.01 rad) of the
poles within 25 m and 2 clutter returns; its localisation pose is the truth plus an error drawn
from its covariance (sigma 0.15 m, 0.15 m, 0.02 rad).  Pole positions, ids and every draw of the
scans do not depend on `side`: a smaller map is the same bag with fewer poles far away.
"""
from __future__ import annotations

import numpy as np

from ..core.models import MODELS, wrap_angle
from .scan import CLUTTER, Scan

STREET_SPACING = 50.0
POLE_OFFSET = 6.0
POLE_SPACING = 8.0
FULL_SIDE = 2250.0
SENSOR_RANGE = 25.0
SCAN_PERIOD_NS = 100_000_000
SPEED = 5.0
POLE_SIGMA = 0.05
POSE_COVARIANCE = np.diag([0.15 ** 2, 0.15 ** 2, 0.02 ** 2])
NOISE = np.diag([0.1 ** 2, 0.01 ** 2])
CLUTTER_PER_SCAN = 2


def poles(side: float = FULL_SIDE, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """(ids (N,), true positions (N, 2)) of the poles within the square of `side` m (inf: the
    whole grid); ids and positions are those of the whole grid, cropped."""
    rng = np.random.default_rng(seed)
    half = FULL_SIDE / 2
    streets = np.arange(-1100.0, 1100.0 + 1e-9, STREET_SPACING)    # through the origin
    along = np.arange(-half, half + 1e-9, POLE_SPACING)
    points = []
    for street in streets:
        for side_offset in (-POLE_OFFSET, POLE_OFFSET):
            points.append(np.column_stack([along, np.full(len(along), street + side_offset)]))
            points.append(np.column_stack([np.full(len(along), street + side_offset), along]))
    true = np.vstack(points)
    true = true + rng.normal(0.0, 0.5, true.shape)
    ids = np.arange(len(true))
    keep = np.all(np.abs(true) <= side / 2, axis=1)
    return ids[keep], true[keep]


def route(steps: int) -> np.ndarray:
    """(steps, 3) true poses x, y, yaw along a 100 m square loop with corners of radius 6 m,
    centred on the intersection at the origin's block, at SPEED m/s, one per scan period."""
    half, radius = 50.0, 6.0
    straight = 2 * (half - radius)
    length = 4 * straight + 2 * np.pi * radius
    s = (np.arange(steps) * SPEED * SCAN_PERIOD_NS / 1e9) % length
    poses = np.empty((steps, 3))
    for k, distance in enumerate(s):
        side, rest = divmod(distance, straight + np.pi * radius / 2)
        heading = side * np.pi / 2
        start = np.array([[-half + radius, -half], [half, -half + radius], [half - radius, half],
                          [-half, half - radius]][int(side)])
        direction = np.array([np.cos(heading), np.sin(heading)])
        if rest <= straight:
            position, yaw = start + direction * rest, heading
        else:
            angle = (rest - straight) / radius
            centre = start + direction * straight + radius * np.array([-direction[1],
                                                                        direction[0]])
            position = centre + radius * np.array([np.sin(heading + angle),
                                                   -np.cos(heading + angle)])
            yaw = heading + angle
        poses[k] = (position[0], position[1], wrap_angle(yaw))
    return poses


def street_grid(side: float = FULL_SIDE, steps: int = 800, seed: int = 8) -> list[Scan]:
    """The scans: the first carries the whole prior map, the others none (see module doc)."""
    ids, true = poles(side)
    rng = np.random.default_rng(seed)
    map_rng = np.random.default_rng(seed + 1)
    all_ids, all_true = poles(float('inf'))
    errors = map_rng.normal(0.0, POLE_SIGMA, all_true.shape)     # per pole, whatever the side
    means = true + errors[ids]
    covariances = np.tile(np.eye(2) * POLE_SIGMA ** 2, (len(ids), 1, 1))
    near_route = np.flatnonzero(np.all(np.abs(all_true) <= 50.0 + SENSOR_RANGE + 1.0, axis=1))
    scans = []
    for step, pose in enumerate(route(steps)):
        pose_estimate = pose + rng.multivariate_normal(np.zeros(3), POSE_COVARIANCE,
                                                       method='cholesky')
        pose_estimate[2] = wrap_angle(pose_estimate[2])
        z = MODELS['range_bearing'].predict(all_true[near_route], pose)[0]
        visible = np.flatnonzero(z[:, 0] <= SENSOR_RANGE)
        z = z[visible] + rng.multivariate_normal(np.zeros(2), NOISE, len(visible),
                                                  method='cholesky')
        clutter = np.column_stack([rng.uniform(1.0, SENSOR_RANGE, CLUTTER_PER_SCAN),
                                   rng.uniform(-np.pi, np.pi, CLUTTER_PER_SCAN)])
        values = np.vstack([z, clutter])
        values[:, 1] = wrap_angle(values[:, 1])
        truth = np.concatenate([all_ids[near_route][visible], np.full(CLUTTER_PER_SCAN,
                                                                      CLUTTER)])
        truth_xy = np.vstack([all_true[near_route][visible],
                              MODELS['range_bearing'].inverse(clutter, pose)[0]])
        first = step == 0
        scans.append(Scan(
            time_ns=int(1e9) + step * SCAN_PERIOD_NS,
            landmark_ids=ids if first else None, landmark_means=means if first else None,
            landmark_covariances=covariances if first else None,
            observations={'range': values[:, 0], 'bearing': values[:, 1],
                          'var_range': np.full(len(values), NOISE[0, 0]),
                          'var_bearing': np.full(len(values), NOISE[1, 1])},
            observation_frame='base_link', truth=truth, truth_xy=truth_xy,
            pose=(pose_estimate, POSE_COVARIANCE)))
    return scans
