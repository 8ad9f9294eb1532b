"""Re-association after a motion outlier.

When most of a scan would start new landmarks although the map is there, the predicted pose is
likely off by more than its covariance says (a wheel slip, one bad odometry increment: DLR step
884 is 6 sigma off in dy and 2 sigma in yaw, and all 9 landmarks seen one scan earlier fall out
of their gates).  The scan is then associated again with the pose covariance widened by
Q_r = diag(position_std^2, position_std^2, yaw_std^2) - P + E Q_r E^T, E = [I_3 0], as if that
one motion step had had Q_r more noise - and the second answer is kept when it pairs at least
`min_new` more observations than the first.  Everything the second pass does is still gated
and (for jcbb) jointly tested; its NIS values are those under the widened covariance.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Optional

import numpy as np

from .api import associate
from .errors import InvalidInputError
from .parameters import ParameterSpec
from .types import NEW, Association, Landmarks, Observations, RobotPose

RECOVERED = 'pose_recovered'
"""Association.extras key: True when the answer comes from the widened second pass."""

POSITION_STD = ParameterSpec(
    'recovery_position_std', 0.0, 'when most of a scan would start new landmarks, associate it '
    'again with this much more robot position noise [m] (a motion outlier); 0 with '
    'recovery_yaw_std 0: off', low=0.0, high=1e3)
YAW_STD = ParameterSpec(
    'recovery_yaw_std', 0.0, 'the heading noise [rad] added in that second association',
    low=0.0, high=10.0)
MIN_NEW = ParameterSpec(
    'recovery_min_new', 2, 'a scan is associated again when at least this many observations '
    'are NEW (and no fewer than the paired ones); the second answer is kept when it pairs this '
    'many more', kind=int, low=1, high=1000)
RECOVERY_PARAMETERS = (POSITION_STD, YAW_STD, MIN_NEW)
"""The settings of PoseRecovery as parameters (the association node declares these)."""


def added_pose_noise(position_std: float, yaw_std: float) -> np.ndarray:
    """Q_r = diag(position_std^2, position_std^2, yaw_std^2) (3, 3): the noise a second pass
    adds to the pose block [m^2, m^2, rad^2]."""
    return np.diag([position_std ** 2, position_std ** 2, yaw_std ** 2])


@dataclasses.dataclass(frozen=True)
class PoseRecovery:
    """position_std [m], yaw_std [rad]: the extra pose noise of the second pass (0, 0: off;
    checked as recovery_position_std, recovery_yaw_std); min_new (recovery_min_new): a scan is retried when at least this many observations are NEW and they are at
    least as many as the paired ones, and the retry is kept when it pairs this many more."""

    position_std: float = 0.0
    yaw_std: float = 0.0
    min_new: int = 2

    def __post_init__(self) -> None:
        if not isinstance(self.min_new, int):
            raise InvalidInputError(f'{MIN_NEW.name}: expected an integer, got {self.min_new!r}')
        for attribute, spec in (('position_std', POSITION_STD), ('yaw_std', YAW_STD),
                                ('min_new', MIN_NEW)):
            spec.check(getattr(self, attribute))

    @property
    def enabled(self) -> bool:
        """True when the second pass widens anything."""
        return self.position_std > 0.0 or self.yaw_std > 0.0

    def wanted(self, assignment: np.ndarray) -> bool:
        """True when the first answer starts at least min_new landmarks and no fewer than it
        pairs."""
        new = int((assignment == NEW).sum())
        return new >= self.min_new and new >= int((assignment >= 0).sum())

    def widen(self, pose: RobotPose, state_covariance: Optional[np.ndarray]
              ) -> tuple[RobotPose, Optional[np.ndarray]]:
        """The pose and joint covariance with Q_r added to the pose block."""
        extra = added_pose_noise(self.position_std, self.yaw_std)
        wide_pose = RobotPose(pose.mean, pose.covariance + extra)
        if state_covariance is None:
            return wide_pose, None
        wide = np.array(state_covariance, dtype=float)
        wide[:3, :3] += extra
        return wide_pose, wide

    def better(self, first: np.ndarray, second: np.ndarray) -> bool:
        """True when the second assignment pairs at least min_new more observations."""
        return int((second >= 0).sum()) >= int((first >= 0).sum()) + self.min_new


def associate_with_pose_recovery(landmarks: Landmarks, observations: Observations,
                                 algorithm: str, pose: Optional[RobotPose],
                                 state_covariance: Optional[np.ndarray],
                                 recovery: PoseRecovery, **arguments: Any) -> Association:
    """`associate`, then the widened second pass of `recovery` when the first answer asks for
    it (see the module doc); the kept answer has extras[RECOVERED] True or False."""
    first = associate(landmarks, observations, algorithm, pose=pose,
                      state_covariance=state_covariance, **arguments)
    second = None
    if recovery.enabled and pose is not None and len(landmarks) \
            and recovery.wanted(first.assignment):
        wide_pose, wide_covariance = recovery.widen(pose, state_covariance)
        second = associate(landmarks, observations, algorithm, pose=wide_pose,
                           state_covariance=wide_covariance, **arguments)
        if not recovery.better(first.assignment, second.assignment):
            second = None
    kept = first if second is None else second
    kept.extras = {**kept.extras, RECOVERED: second is not None}   # kept is this call's own
    return kept
