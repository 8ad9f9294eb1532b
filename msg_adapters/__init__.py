"""ROS messages <-> core types (numpy). The only place that knows message layouts; no Node code."""
from .inputs import (detect_model, landmarks_from_cloud, landmarks_from_points,
                     landmarks_from_pose_array, observations_from_cloud, observations_from_points,
                     pose_from_odometry, state_covariance_from_cloud)
from .outputs import (association_markers, candidates_cloud, correspondences_cloud,
                      diagnostics_message, new_landmarks_cloud, transform_message)
from .pointcloud import PointCloudFormatError, array_to_cloud, cloud_points, cloud_to_array
from .state import odometry_message, point_map_cloud, state_covariance_cloud

__all__ = ['PointCloudFormatError', 'array_to_cloud', 'association_markers', 'candidates_cloud',
           'cloud_points', 'cloud_to_array', 'correspondences_cloud', 'detect_model',
           'diagnostics_message', 'landmarks_from_cloud', 'landmarks_from_points',
           'landmarks_from_pose_array', 'new_landmarks_cloud', 'observations_from_cloud',
           'observations_from_points', 'odometry_message', 'point_map_cloud', 'pose_from_odometry',
           'state_covariance_cloud', 'state_covariance_from_cloud', 'transform_message']
