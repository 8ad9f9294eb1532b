"""Start-up work done before a node reports ready, so that its first scan costs what later ones do.

* the compiled JCBB search is compiled, or loaded from numba's on-disk cache
  (core/associators/jcbb_compiled.py);
* the chi-square thresholds of the configured gate probabilities are computed for
  1..WARM_DOF degrees of freedom (scipy's chi2.ppf costs about 0.3 ms a call; JCBB needs m l
  of them for l pairs, cached once computed);
* a throw-away AssociationPipeline answers a small synthetic range-bearing scan with every
  single-scan algorithm (first calls into numpy, scipy and the message code).
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np
from nav_msgs.msg import Odometry
from std_msgs.msg import Header

from msg_adapters import array_to_cloud

from ..core.associators import REGISTRY, jcbb_compiled
from ..core.gating import chi2_threshold
from .association import AssociationPipeline

WARM_DOF = 256
"""Degrees of freedom whose chi-square thresholds are computed ahead (128 2-D pairs)."""


def _synthetic_messages(count: int = 8):
    """(landmarks cloud, Odometry, observations cloud): `count` landmarks on a circle of 10 m
    seen from the origin, stamp 1 s."""
    header = Header(frame_id='map')
    header.stamp.sec = 1
    angles = np.linspace(-1.0, 1.0, count)
    landmarks = np.zeros(count, dtype=[('id', '<i4'), ('x', '<f4'), ('y', '<f4'),
                                       ('cov_xx', '<f4'), ('cov_xy', '<f4'), ('cov_yy', '<f4')])
    landmarks['id'] = np.arange(count)
    landmarks['x'], landmarks['y'] = 10.0 * np.cos(angles), 10.0 * np.sin(angles)
    landmarks['cov_xx'] = landmarks['cov_yy'] = 0.01
    odometry = Odometry(header=header)
    odometry.pose.pose.orientation.w = 1.0
    odometry.pose.covariance = np.diag([0.01, 0.01, 0.0, 0.0, 0.0, 0.003]).ravel().tolist()
    scan = np.zeros(count, dtype=[('range', '<f4'), ('bearing', '<f4'), ('var_range', '<f4'),
                                  ('var_bearing', '<f4')])
    scan['range'], scan['bearing'] = 10.0, angles + 0.01
    scan['var_range'], scan['var_bearing'] = 0.01, 1e-4
    return (array_to_cloud(landmarks, header), odometry,
            array_to_cloud(scan, Header(stamp=header.stamp, frame_id='base_link')))


def warm_up(config: dict[str, Any]) -> dict[str, float]:
    """Do the start-up work of the module docstring for a node `config`; returns the seconds
    spent per step and 'compiled' (1.0 when the compiled JCBB search is in use, else 0.0)."""
    spent: dict[str, float] = {}
    started = time.perf_counter()
    spent['compiled'] = float(jcbb_compiled.warm_up())
    spent['compile_s'] = time.perf_counter() - started
    started = time.perf_counter()
    for probability in {config['gate_probability'], config['joint_gate_probability']}:
        if 0.0 < probability < 1.0:
            for dof in range(1, WARM_DOF + 1):
                chi2_threshold(probability, dof)
    spent['thresholds_s'] = time.perf_counter() - started
    started = time.perf_counter()
    landmarks, odometry, scan = _synthetic_messages()
    for algorithm in REGISTRY:
        pipeline = AssociationPipeline({**config, 'algorithm': algorithm,
                                        'measurement_model': 'auto', 'publish_markers': True})
        pipeline.on_landmarks(landmarks)
        pipeline.on_robot_pose(odometry)
        pipeline.answer(scan)
    spent['scans_s'] = time.perf_counter() - started
    return spent
