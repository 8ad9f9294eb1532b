"""The hypothesis tree: a Gaussian-mixture belief over the robot pose, one leaf per sequence of
data-association decisions (DA-BSP / Shelly & Indelman 2022).

Per step (a motion increment, then at most one relative-position observation z of one of L
identical known landmarks; without one, every leaf is only predicted):
predict every leaf, mu- = g(mu, u), Sigma- = G Sigma G' + V Q V'; one child per landmark g in the
field of view (within `fov_range` of mu-; all landmarks if none), weight
w * 1/|FOV| * N(z; h(mu-, l_g), S), S = H Sigma- H' + R, Gaussian from an EKF update
(h: point_robot model, z = R(yaw)' (l_g - t)); normalise; prune children below
`prune_threshold` and renormalise; keep at most `max_leaves`; with `merge_threshold` > 0, merge
children closer than it (squared Mahalanobis distance in the heavier one's covariance) by moment
matching, the merged node keeping the heavier one's parent and decision (the tree sums are then
no longer exact).  Every node keeps its step,
parent, decision (landmark index), weight at its own step w_{t|t}, mean and covariance.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..errors import InvalidInputError
from ..models import MODELS
from ..models.base import wrap_angle
from .motion import compose, compose_jacobians

POINT_ROBOT = MODELS['point_robot']


@dataclass
class Node:
    """One hypothesis at one step."""

    step: int
    parent: Optional[int]
    decision: int  # landmark index observed at this step (-1 at the root)
    weight: float  # w_{step|step}
    mean: np.ndarray
    covariance: np.ndarray


class HypothesisTree:
    """See the module docstring.  `nodes[i]` for every hypothesis ever kept; `leaves` the
    current ones; `inputs[t]` the (increment, observation) of step t (1-based)."""

    def __init__(self, landmarks: np.ndarray, prior_mean: np.ndarray, prior_covariance: np.ndarray,
                 motion_noise: np.ndarray, measurement_noise: np.ndarray,
                 fov_range: float = np.inf, prune_threshold: float = 0.005,
                 max_leaves: int = 1000, merge_threshold: float = 0.0) -> None:
        self.landmarks = np.asarray(landmarks, dtype=float).reshape(-1, 2)
        if not len(self.landmarks):
            raise InvalidInputError('landmarks: at least one is needed')
        self.motion_noise = np.asarray(motion_noise, dtype=float)
        self.measurement_noise = np.asarray(measurement_noise, dtype=float)
        self.fov_range = float(fov_range)
        self.prune_threshold = float(prune_threshold)
        self.max_leaves = int(max_leaves)
        self.merge_threshold = float(merge_threshold)
        self.nodes = [Node(0, None, -1, 1.0, np.asarray(prior_mean, dtype=float),
                           np.asarray(prior_covariance, dtype=float))]
        self.leaves = [0]
        self.step_count = 0
        self.inputs: list[tuple[np.ndarray, np.ndarray]] = [(np.zeros(3), np.zeros(2))]
        self.pruned_mass: list[float] = [0.0]

    def in_view(self, pose: np.ndarray) -> np.ndarray:
        """Indices of the landmarks within fov_range of a pose (all when none is)."""
        near = np.flatnonzero(np.hypot(*(self.landmarks - pose[:2]).T) <= self.fov_range)
        return near if len(near) else np.arange(len(self.landmarks))

    def step(self, increment: np.ndarray, observation: Optional[np.ndarray]) -> None:
        """One motion increment (3,) then one observation (2,) of an unknown landmark, or None
        (nothing seen: every leaf is only predicted, one child each)."""
        increment = np.asarray(increment, dtype=float)
        self.step_count += 1
        if observation is None:
            self.inputs.append((increment, None))
            self._predict_only(increment)
            return
        observation = np.asarray(observation, dtype=float)
        self.inputs.append((increment, observation))
        children = []
        for leaf in self.leaves:
            node = self.nodes[leaf]
            g, v = compose_jacobians(node.mean, increment)
            mean = compose(node.mean, increment)
            covariance = g @ node.covariance @ g.T + v @ self.motion_noise @ v.T
            visible = self.in_view(mean)
            h, _, h_pose = POINT_ROBOT.predict(self.landmarks[visible], mean)
            for landmark, z_hat, jacobian in zip(visible, h, h_pose):
                s = jacobian @ covariance @ jacobian.T + self.measurement_noise
                innovation = observation - z_hat
                likelihood = np.exp(-0.5 * innovation @ np.linalg.solve(s, innovation)) / (
                    2 * np.pi * np.sqrt(np.linalg.det(s)))
                gain = np.linalg.solve(s, jacobian @ covariance).T
                updated = mean + gain @ innovation
                updated[2] = wrap_angle(updated[2])
                children.append(Node(self.step_count, leaf, int(landmark),
                                     node.weight * likelihood / len(visible), updated,
                                     (np.eye(3) - gain @ jacobian) @ covariance))
        total = sum(c.weight for c in children)
        if not total > 0:
            raise InvalidInputError('observation: no hypothesis explains it (all likelihoods 0)')
        for child in children:
            child.weight /= total
        kept = sorted((c for c in children if c.weight >= self.prune_threshold),
                      key=lambda c: -c.weight)[:self.max_leaves]
        kept_total = sum(c.weight for c in kept)
        self.pruned_mass.append(1.0 - kept_total)
        if self.merge_threshold > 0:
            kept = merge(kept, self.merge_threshold)
        self.leaves = []
        for child in kept:
            child.weight /= kept_total
            self.nodes.append(child)
            self.leaves.append(len(self.nodes) - 1)

    def _predict_only(self, increment: np.ndarray) -> None:
        leaves = []
        for leaf in self.leaves:
            node = self.nodes[leaf]
            g, v = compose_jacobians(node.mean, increment)
            self.nodes.append(Node(self.step_count, leaf, -1, node.weight,
                                   compose(node.mean, increment),
                                   g @ node.covariance @ g.T + v @ self.motion_noise @ v.T))
            leaves.append(len(self.nodes) - 1)
        self.leaves = leaves
        self.pruned_mass.append(0.0)

    def ancestor(self, index: int, step: int) -> int:
        """The ancestor of node `index` at `step` (itself at its own step)."""
        while self.nodes[index].step > step:
            index = self.nodes[index].parent
        return index

    def at_step(self, step: int) -> list[int]:
        """Node indices of the hypotheses kept at `step`."""
        return [i for i, n in enumerate(self.nodes) if n.step == step]

    def reevaluate_exact(self, step: int) -> dict[int, float]:
        """P(gamma_step = q | H_k) for the kept nodes q at `step`: the summed current weight of
        q's leaves (exact when nothing below `step` was pruned)."""
        weights = {q: 0.0 for q in self.at_step(step)}
        for leaf in self.leaves:
            weights[self.ancestor(leaf, step)] += self.nodes[leaf].weight
        return weights

    def decision_probability(self, weights: dict[int, float]) -> dict[int, float]:
        """P(beta = c | H_k) per landmark c from re-evaluated weights of one past step."""
        out: dict[int, float] = {}
        total = sum(weights.values())
        for q, w in weights.items():
            c = self.nodes[q].decision
            out[c] = out.get(c, 0.0) + w / total
        return out

    def prune_descendants(self, weights: dict[int, float], threshold: float) -> int:
        """Enhanced pruning: drop the current leaves descending from a past hypothesis whose
        re-evaluated weight is below `threshold`, renormalise; returns how many were dropped."""
        step = self.nodes[next(iter(weights))].step
        light = {q for q, w in weights.items() if w < threshold}
        keep = [leaf for leaf in self.leaves if self.ancestor(leaf, step) not in light]
        if not keep:
            return 0
        dropped = len(self.leaves) - len(keep)
        total = sum(self.nodes[i].weight for i in keep)
        for i in keep:
            self.nodes[i].weight /= total
        self.leaves = keep
        return dropped


def merge(nodes: list[Node], threshold: float) -> list[Node]:
    """Moment-matching merge, heaviest first: every node within squared Mahalanobis distance
    `threshold` of a heavier kept one joins it (weights add; mean and covariance matched)."""
    out: list[Node] = []
    groups: list[list[Node]] = []
    for node in sorted(nodes, key=lambda n: -n.weight):
        for head, group in zip(out, groups):
            d = node.mean - head.mean
            d[2] = wrap_angle(d[2])
            if d @ np.linalg.solve(head.covariance, d) < threshold:
                group.append(node)
                break
        else:
            out.append(node)
            groups.append([node])
    merged = []
    for head, group in zip(out, groups):
        if len(group) == 1:
            merged.append(head)
            continue
        weights = np.array([n.weight for n in group])
        total = weights.sum()
        offsets = np.array([n.mean - head.mean for n in group])
        offsets[:, 2] = wrap_angle(offsets[:, 2])
        mean_offset = weights @ offsets / total
        spread = offsets - mean_offset
        covariance = sum(w * (n.covariance + np.outer(o, o))
                         for w, n, o in zip(weights, group, spread)) / total
        mean = head.mean + mean_offset
        mean[2] = wrap_angle(mean[2])
        merged.append(Node(head.step, head.parent, head.decision, float(total), mean,
                           covariance))
    return merged
