"""The core: types, measurement models, gating and associators (numpy + scipy, no ROS)."""
from .api import associate, available_algorithms
from .errors import InvalidInputError
from .types import NEW, UNASSOCIATED, Association, Landmarks, Observations, RobotPose

__all__ = ['Association', 'InvalidInputError', 'Landmarks', 'NEW', 'Observations', 'RobotPose',
           'UNASSOCIATED', 'associate', 'available_algorithms']
