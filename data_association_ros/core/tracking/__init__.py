"""Multi-object tracking on top of the associators: a linear Kalman filter, interacting
multiple models (IMM) over Kalman filters and a SORT-style box tracker (no ROS)."""
from .box_tracker import BoxTracker, Track
from .interacting_models import InteractingModels
from .kalman import KalmanFilter

__all__ = ['BoxTracker', 'InteractingModels', 'KalmanFilter', 'Track']
