"""2-D EKF-SLAM on the package's measurement models (the associators' own Jacobians)."""
from .ekf_slam import EkfSlam
from .odometry import OdometryIncrements

__all__ = ['EkfSlam', 'OdometryIncrements']
