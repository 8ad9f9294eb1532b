"""Start-up work done before a node reports ready, so that its first scan costs what later ones do.

* the compiled kernels are compiled, or loaded from numba's on-disk cache: the problem's
  arithmetic (core/problem_kernels.py), the JCBB search (core/associators/jcbb_compiled.py)
  and the output packing (msg_adapters/packing_kernels.py);
* the chi-square thresholds of the configured gate probabilities are computed for
  1..WARM_DOF degrees of freedom (scipy's chi2.ppf costs about 0.3 ms a call; JCBB needs m l
  of them for l pairs, cached once computed);
* a throw-away AssociationPipeline answers a small synthetic range-bearing scan with every
  single-scan algorithm, as a message and from its bytes (first calls into numpy, scipy and
  the message code).
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np
from nav_msgs.msg import Odometry
from std_msgs.msg import Header

from msg_adapters import array_to_cloud, packing_kernels
from msg_adapters.pointcloud import packed_points
from msg_adapters.serialized_cloud import SerializedCloud, packed_cloud_cdr

from ..core import jit
from ..core.associators import REGISTRY, jcbb_compiled
from ..core.gating import chi2_threshold
from .association import AssociationPipeline

WARM_DOF = 256
"""Degrees of freedom whose chi-square thresholds are computed ahead (128 2-D pairs)."""


def _synthetic_messages(observed: int = 64, count: int = 256):
    """(landmarks cloud, Odometry, observations cloud, the same as the node reads it from its
    bytes): `count` landmarks on a spiral around the
    origin (golden-angle steps, 0.2 m further out each), the first `observed` of them seen
    without noise from the origin, stamp 1 s.  Scan-sized arrays: the first K x N arrays of a
    process also pay for fresh memory pages (5 ms at K = 50, N = 200)."""
    header = Header(frame_id='map')
    header.stamp.sec = 1
    index = np.arange(count)
    radii, angles = 5.0 + 0.2 * index, np.angle(np.exp(2.39996j * index))
    landmarks = np.zeros(count, dtype=[('id', '<i4'), ('x', '<f4'), ('y', '<f4'),
                                       ('cov_xx', '<f4'), ('cov_xy', '<f4'), ('cov_yy', '<f4')])
    landmarks['id'] = index
    landmarks['x'], landmarks['y'] = radii * np.cos(angles), radii * np.sin(angles)
    landmarks['cov_xx'] = landmarks['cov_yy'] = 1e-4
    odometry = Odometry(header=header)
    odometry.pose.pose.orientation.w = 1.0
    odometry.pose.covariance = np.diag([1e-4, 1e-4, 0.0, 0.0, 0.0, 1e-6]).ravel().tolist()
    scan = np.zeros(observed, dtype=[('range', '<f4'), ('bearing', '<f4'), ('var_range', '<f4'),
                                     ('var_bearing', '<f4')])
    seen = np.hypot(landmarks['x'][:observed], landmarks['y'][:observed])
    scan['range'] = seen
    scan['bearing'] = np.arctan2(landmarks['y'][:observed], landmarks['x'][:observed])
    scan['var_range'], scan['var_bearing'] = 1e-4, 1e-6
    scan_header = Header(stamp=header.stamp, frame_id='base_link')
    data, observed, dtype, is_dense = packed_points(scan)
    return (array_to_cloud(landmarks, header), odometry, array_to_cloud(scan, scan_header),
            SerializedCloud.from_cdr(packed_cloud_cdr(data, observed, dtype, scan_header,
                                                      is_dense)))


def warm_up(config: dict[str, Any]) -> dict[str, float]:
    """Do the start-up work of the module docstring for a node `config`; returns the seconds
    spent per step and 'compiled' (1.0 when the compiled kernels are in use, else 0.0)."""
    spent: dict[str, float] = {}
    started = time.perf_counter()
    problem_kernels_ready = jit.problem_kernels() is not None
    search_ready = jcbb_compiled.available()   # all, even when one of them failed
    packing_ready = packing_kernels.available()
    spent['compiled'] = float(problem_kernels_ready and search_ready and packing_ready)
    spent['compile_s'] = time.perf_counter() - started
    started = time.perf_counter()
    for probability in {config['gate_probability'], config['joint_gate_probability']}:
        if 0.0 < probability < 1.0:
            for dof in range(1, WARM_DOF + 1):
                chi2_threshold(probability, dof)
    spent['thresholds_s'] = time.perf_counter() - started
    started = time.perf_counter()
    landmarks, odometry, scan, serialized_scan = _synthetic_messages()
    for algorithm in REGISTRY:
        pipeline = AssociationPipeline({**config, 'algorithm': algorithm,
                                        'measurement_model': 'auto', 'publish_markers': True})
        pipeline.on_landmarks(landmarks)
        pipeline.on_robot_pose(odometry)
        pipeline.answer(scan)
        pipeline.answer(serialized_scan)
    spent['scans_s'] = time.perf_counter() - started
    return spent
