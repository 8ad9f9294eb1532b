"""2-D LiDAR object tracking for seed 003 (no ROS): ray casting (simulated scans), clustering,
the rectangle boundary model, fine association, rigid correction, fictitious measurement and
the tracker."""
from .clustering import cluster_consecutive, cluster_ends
from .object_tracker import LidarObjectTracker, ObjectTrack
from .parameters import PARAMETERS, TrackerConfig
from .raycast import rectangle_segments, raycast

__all__ = ['LidarObjectTracker', 'ObjectTrack', 'PARAMETERS', 'TrackerConfig',
           'cluster_consecutive', 'cluster_ends', 'raycast', 'rectangle_segments']
