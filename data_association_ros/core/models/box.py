"""box: an axis-aligned box z = (centre x, centre y, width, height), observed directly, z = m."""
from .base import IdentityModel


class BoxModel(IdentityModel):
    """z = m = (cx, cy, w, h) in pixels or metres; dh/dm = I; dh/dpose = 0."""

    name = 'box'
