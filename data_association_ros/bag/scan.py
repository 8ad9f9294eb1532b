"""One time step of a simulated scenario, as the bag tools publish it."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..core import UNASSOCIATED

CLUTTER = UNASSOCIATED
"""Ground-truth value of a clutter observation (-2)."""


@dataclass
class Scan:
    """One time step. Arrays: landmark_ids (N,), landmark_means (N, d), landmark_covariances
    (N, d, d) or None (landmark_ids None: no landmarks message with this scan, the prior map
    was published before); observations: field name -> (K,) values; truth (K,); truth_xy
    (K, 2)."""

    time_ns: int
    landmark_ids: Optional[np.ndarray]
    landmark_means: Optional[np.ndarray]
    landmark_covariances: Optional[np.ndarray]
    observations: dict[str, np.ndarray]
    observation_frame: str
    truth: np.ndarray
    truth_xy: np.ndarray
    pose: Optional[tuple[np.ndarray, np.ndarray]] = None
    state_covariance: Optional[np.ndarray] = None
    map_frame: str = 'map'
    odometry: Optional[tuple[np.ndarray, np.ndarray]] = None  # wheel odometry pose, covariance
