"""data_association_ros: which observations belong to which landmarks.

The public API is the ROS-free core; the node lives in data_association_ros.nodes.association_node.

BLAS runs single-threaded unless OPENBLAS_NUM_THREADS / OMP_NUM_THREADS say otherwise (set
before numpy is first imported): the per-scan matrices are small, and OpenBLAS threads on a busy
2-core machine made an EKF-SLAM run of 1000 scans take 11.2 s instead of 1.4 s (association
p95 21 ms instead of 0.5 ms).
"""
import os

if 'OMP_NUM_THREADS' not in os.environ:
    os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

from .core import (NEW, UNASSOCIATED, Association, InvalidInputError, Landmarks, Observations,
                   RobotPose, associate, available_algorithms)

__all__ = ['Association', 'InvalidInputError', 'Landmarks', 'NEW', 'Observations', 'RobotPose',
           'UNASSOCIATED', 'associate', 'available_algorithms']
