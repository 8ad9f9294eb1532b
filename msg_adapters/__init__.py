"""ROS messages <-> core types (numpy). The only place that knows message layouts; no Node code."""
from .inputs import (detect_model, joint_covariance_from_array, landmarks_from_cloud,
                     landmarks_from_points, landmarks_from_pose_array, observations_from_cloud,
                     observations_from_points, pose_from_odometry)
from .outputs import (association_markers, candidates_cloud, correspondences_cloud,
                      diagnostics_message, new_landmarks_cloud, transform_message)
from .pointcloud import PointCloudFormatError, array_to_cloud, cloud_to_array
from .state import covariance_message, odometry_message, point_map_cloud

__all__ = ['PointCloudFormatError', 'array_to_cloud', 'association_markers', 'candidates_cloud',
           'cloud_to_array', 'correspondences_cloud', 'covariance_message', 'detect_model',
           'diagnostics_message', 'joint_covariance_from_array', 'landmarks_from_cloud', 'landmarks_from_points',
           'landmarks_from_pose_array', 'new_landmarks_cloud', 'observations_from_cloud',
           'observations_from_points', 'odometry_message', 'point_map_cloud', 'pose_from_odometry',
           'transform_message']
