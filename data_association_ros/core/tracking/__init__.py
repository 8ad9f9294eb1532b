"""Multi-object tracking on top of the associators: a linear Kalman filter and a SORT-style
box tracker (no ROS)."""
from .box_tracker import BoxTracker, Track
from .kalman import KalmanFilter

__all__ = ['BoxTracker', 'KalmanFilter', 'Track']
