"""2-D LiDAR building blocks for seed 003's object tracker (no ROS): ray casting against line
segments (for simulated scans) and clustering of consecutive scan points."""
from .clustering import cluster_consecutive
from .raycast import rectangle_segments, raycast

__all__ = ['cluster_consecutive', 'raycast', 'rectangle_segments']
