"""The node's `multi_hypothesis` algorithm (no rclpy): a HypothesisTree fed by the known
landmark map, wheel odometry and relative-position observations, answered with the most
probable hypothesis' correspondences, the pose mixture and the re-evaluated past decisions.

Per observation message (point_robot observations, x, y in the robot frame): the motion
increment is the odometry pose at its stamp relative to the odometry pose of the previous message,
with that odometry message's 3x3 covariance as its noise; the first message starts the tree at the
robot pose (`robot_pose`, else the odometry pose) with its covariance.  The observations of one
message are tree steps in index order (the first after the increment, the others without motion).
"""
from __future__ import annotations

from typing import Any, Optional

import numpy as np

from ..core import Association, InvalidInputError, Landmarks, Observations, RobotPose
from ..core.multi_hypothesis import HypothesisTree
from ..core.multi_hypothesis.motion import between

HYPOTHESIS_DTYPE = np.dtype([('hypothesis', '<i4'), ('weight', '<f4'), ('x', '<f4'),
                             ('y', '<f4'), ('yaw', '<f4'), ('cov_xx', '<f4'), ('cov_xy', '<f4'),
                             ('cov_yy', '<f4'), ('cov_yawyaw', '<f4'), ('parent', '<i4')])
PAST_DTYPE = np.dtype([('steps_back', '<i4'), ('observation', '<i4'), ('landmark', '<i4'),
                       ('probability', '<f4')])
MIN_VARIANCE = 1e-9


class MultiHypothesisStage:
    """State across messages for the multi_hypothesis algorithm."""

    def __init__(self) -> None:
        self.tree: Optional[HypothesisTree] = None
        self.last_odometry: Optional[np.ndarray] = None
        self.step_of: list[tuple[int, int]] = [(0, -1)]  # tree step -> (stamp ns, observation)
        self.landmark_ids = np.zeros(0, dtype=np.int64)

    def reset(self) -> None:
        self.__init__()

    def answer(self, config: dict[str, Any], landmarks: Landmarks, observations: Observations,
               odometry: RobotPose, prior: RobotPose, stamp: int):
        """(Association, pose_hypotheses cloud fields, past_associations points) for one
        message; see the module docstring."""
        if observations.model != 'point_robot':
            raise InvalidInputError('multi_hypothesis: observations must be x, y in the robot '
                                    f'frame (point_robot), not {observations.model}')
        if self.tree is None or not np.array_equal(self.landmark_ids, landmarks.ids):
            self._start(config, landmarks, prior)
            increment = np.zeros(3)
        else:
            increment = between(self.last_odometry, odometry.mean)
        self.last_odometry = odometry.mean
        tree = self.tree
        tree.prune_threshold = config['mh_prune_threshold']
        tree.max_leaves = config['mh_max_leaves']
        tree.merge_threshold = config['mh_merge_threshold']
        tree.fov_range = config['mh_fov_range']
        noise = odometry.covariance + np.eye(3) * MIN_VARIANCE
        steps = []
        if len(observations) == 0:
            tree.motion_noise = noise
            tree.step(increment, None)
            self.step_of.append((stamp, -1))
        for index in range(len(observations)):
            tree.motion_noise = noise if index == 0 else np.eye(3) * MIN_VARIANCE
            tree.measurement_noise = observations.covariances[index]
            tree.step(increment if index == 0 else np.zeros(3), observations.values[index])
            self.step_of.append((stamp, index))
            steps.append(tree.step_count)
        best = max(tree.leaves, key=lambda i: tree.nodes[i].weight)
        assignment = np.empty(len(steps), dtype=np.int64)
        probability = np.empty(len(steps))
        for k, step in enumerate(steps):
            decision = tree.nodes[tree.ancestor(best, step)].decision
            assignment[k] = landmarks.ids[decision]
            probability[k] = tree.decision_probability(tree.reevaluate_exact(step))[decision]
        association = Association(assignment, np.full(len(steps), np.nan),
                                  algorithm='multi_hypothesis',
                                  extras={'probability': probability,
                                          'hypotheses': len(tree.leaves)})
        return association, self._hypotheses(config), self._past(config)

    def _start(self, config: dict[str, Any], landmarks: Landmarks, prior: RobotPose) -> None:
        if len(landmarks) == 0:
            raise InvalidInputError('multi_hypothesis: needs a known landmark map')
        self.tree = HypothesisTree(landmarks.means[:, :2], prior.mean,
                                   prior.covariance + np.eye(3) * MIN_VARIANCE,
                                   np.eye(3) * MIN_VARIANCE, np.eye(2),
                                   fov_range=config['mh_fov_range'],
                                   prune_threshold=config['mh_prune_threshold'],
                                   max_leaves=config['mh_max_leaves'],
                                   merge_threshold=config['mh_merge_threshold'])
        self.landmark_ids = landmarks.ids.copy()
        self.step_of = [(0, -1)]

    def _hypotheses(self, config: dict[str, Any]) -> np.ndarray:
        tree = self.tree
        back = max(tree.step_count - config['reevaluation_window'], 0)
        points = np.zeros(len(tree.leaves), dtype=HYPOTHESIS_DTYPE)
        for point, leaf in zip(points, tree.leaves):
            node = tree.nodes[leaf]
            point['hypothesis'], point['weight'] = leaf, node.weight
            point['x'], point['y'], point['yaw'] = node.mean
            point['cov_xx'], point['cov_xy'] = node.covariance[0, 0], node.covariance[0, 1]
            point['cov_yy'], point['cov_yawyaw'] = node.covariance[1, 1], node.covariance[2, 2]
            point['parent'] = tree.ancestor(leaf, back)
        return points

    def _past(self, config: dict[str, Any]) -> np.ndarray:
        tree = self.tree
        rows = []
        for back in range(1, config['reevaluation_window'] + 1):
            step = tree.step_count - back
            if step < 1:
                break
            _, observation = self.step_of[step]
            if observation < 0:
                continue
            for decision, p in sorted(tree.decision_probability(
                    tree.reevaluate_exact(step)).items()):
                rows.append((back, observation, self.landmark_ids[decision], p))
        return np.array(rows, dtype=PAST_DTYPE)
