"""point_map: the observation is the landmark position already in the map frame, z = m (2-D or 3-D)."""
from .base import IdentityModel


class PointMapModel(IdentityModel):
    """z = m [m]; dh/dm = I; dh/dpose = 0."""

    name = 'point_map'
