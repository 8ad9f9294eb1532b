"""A SlamSequence as bag messages: what a robot records (odometry, robot-frame observations) and
the truth (/ground_truth/correspondences, /ground_truth/pose, /ground_truth/landmarks).

Per step k (stamp t_k): /odometry (the dead-reckoned pose: initial pose composed with the
increments so far, in frame 'odom'; covariance = the step's increment covariance, DESIGN.md 4),
/sensor_observations (frame 'base_link'; range, bearing, var_range, var_bearing or x, y, cov_xx,
cov_xy, cov_yy), /ground_truth/correspondences (landmark = true id or -2; probability 1 = certain
truth, 0 = uncertain, left out of the scores; x, y = the true landmark position, NaN if unknown)
and /ground_truth/pose when known.  One /odometry message with the initial pose and the
/ground_truth/landmarks map (when known) come 50 ms before the first step.
"""
from __future__ import annotations

import json
from typing import Iterator

import numpy as np

from msg_adapters import array_to_cloud, point_map_cloud
from msg_adapters.outputs import CORRESPONDENCE_DTYPE

from ...core.multi_hypothesis.motion import compose
from .. import topics
from ..topics import header, odometry_at
from .sequence import SlamSequence

SLAM_PARAMETERS_KEY = 'data_association_ros.slam_parameters'
TRUTH_KIND_KEY = 'data_association_ros.truth'
START_LEAD_NS = 50_000_000
ODOMETRY_LEAD_NS = 1_000_000
"""Odometry is logged this long before the scan it belongs to (same stamp)."""


def slam_parameters(sequence: SlamSequence) -> dict:
    """ekf_slam_node parameters the bag needs: its initial pose and standard deviations, and
    the sequence's own (slam_parameters)."""
    pose, covariance = sequence.initial_pose, sequence.initial_covariance
    return {'initial_x': float(pose[0]), 'initial_y': float(pose[1]),
            'initial_yaw': float(pose[2]),
            'initial_position_std': float(np.sqrt(max(covariance[0, 0], covariance[1, 1]))),
            'initial_yaw_std': float(np.sqrt(covariance[2, 2])), **sequence.slam_parameters}


def custom_data(sequence: SlamSequence) -> dict[str, str]:
    """metadata.yaml custom_data of the bag (association and SLAM parameters, truth kind)."""
    from ..make_bags import ALGORITHMS_KEY, PARAMETERS_KEY
    return {PARAMETERS_KEY: json.dumps(sequence.parameters, sort_keys=True),
            ALGORITHMS_KEY: 'euclidean_nn,mahalanobis_nn,maximum_likelihood,gnn,jcbb',
            SLAM_PARAMETERS_KEY: json.dumps(slam_parameters(sequence), sort_keys=True),
            TRUTH_KIND_KEY: 'reference' if sequence.truth_is_reference else 'true'}


def observation_columns(sequence: SlamSequence, values: np.ndarray,
                        covariances: np.ndarray) -> dict[str, np.ndarray]:
    """PointCloud2 columns of one scan in the sequence's model."""
    if sequence.model == 'range_bearing':
        if np.any(covariances[:, 0, 1] != 0):
            raise ValueError('range_bearing observations carry only var_range and var_bearing')
        return {'range': values[:, 0], 'bearing': values[:, 1],
                'var_range': covariances[:, 0, 0], 'var_bearing': covariances[:, 1, 1]}
    return {'x': values[:, 0], 'y': values[:, 1], 'cov_xx': covariances[:, 0, 0],
            'cov_xy': covariances[:, 0, 1], 'cov_yy': covariances[:, 1, 1]}


def sequence_messages(sequence: SlamSequence) -> Iterator[tuple[str, object, int]]:
    """(topic, message, log time ns) of the whole sequence in log-time order."""
    start = sequence.steps[0].time_ns - START_LEAD_NS
    zero = np.zeros((3, 3))
    yield topics.ODOMETRY, odometry_at(sequence.initial_pose, zero, start, 'odom'), start
    known = sequence.true_landmarks or {}
    if known:
        ids = np.array(sorted(known), dtype=np.int64)
        means = np.array([known[i] for i in ids], dtype=float)
        yield topics.GROUND_TRUTH_LANDMARKS, point_map_cloud(header(start, 'map'), ids, means,
                                                             None), start
    pose = np.asarray(sequence.initial_pose, dtype=float)
    for step in sequence.steps:
        t = step.time_ns
        pose = compose(pose, step.increment)
        yield topics.ODOMETRY, odometry_at(pose, step.increment_covariance, t, 'odom'), \
            t - ODOMETRY_LEAD_NS
        columns = observation_columns(sequence, step.values, step.covariances)
        points = np.zeros(len(step.truth), dtype=[(k, '<f4') for k in columns])
        for name, column in columns.items():
            points[name] = column
        yield topics.SENSOR_OBSERVATIONS, array_to_cloud(points, header(t, 'base_link')), t
        truth = np.zeros(len(step.truth), dtype=CORRESPONDENCE_DTYPE)
        truth['observation'] = np.arange(len(step.truth))
        truth['landmark'] = step.truth
        truth['nis'] = np.nan
        truth['probability'] = step.truth_certain.astype(np.float32)
        position = np.array([known.get(int(i), (np.nan, np.nan)) for i in step.truth],
                            dtype=float).reshape(-1, 2)
        truth['x'], truth['y'] = position[:, 0], position[:, 1]
        yield topics.GROUND_TRUTH, array_to_cloud(truth, header(t, 'base_link')), t
        if step.true_pose is not None:
            yield topics.GROUND_TRUTH_POSE, odometry_at(step.true_pose, zero, t, 'map'), t
