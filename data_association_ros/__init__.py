"""data_association_ros: which observations belong to which landmarks.

The public API is the ROS-free core; the node lives in data_association_ros.node.
"""
from .core import (NEW, UNASSOCIATED, Association, InvalidInputError, Landmarks, Observations,
                   RobotPose, associate, available_algorithms)

__all__ = ['Association', 'InvalidInputError', 'Landmarks', 'NEW', 'Observations', 'RobotPose',
           'UNASSOCIATED', 'associate', 'available_algorithms']
