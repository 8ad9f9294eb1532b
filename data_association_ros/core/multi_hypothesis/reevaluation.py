"""Sampled re-evaluation of a past step m (Shelly & Indelman 2022): for each hypothesis q kept at
m, a bootstrap particle filter from q's Gaussian accumulates
log Psi_q = sum_{t=m+1..k} log mean_s p(z_t | x_s),
p(z | x) = sum_{g in FOV(x)} 1/|FOV(x)| N(z; h(x, l_g), R),
marginalising over every later association (pruned ones too); w_{m|k}^q is proportional to
Psi_q w_{m|m}^q.  Incremental: one factor per new scan; naive: replay from m (same random stream,
same answer)."""
from __future__ import annotations

import numpy as np

from .motion import compose
from .tree import HypothesisTree


class ParticleReevaluation:
    """Particle sets and log Psi for every hypothesis kept at step m of `tree`."""

    def __init__(self, tree: HypothesisTree, step: int, samples: int, seed: int = 0) -> None:
        self.tree, self.step, self.samples = tree, step, samples
        self.rng = np.random.default_rng(seed)
        self.hypotheses = tree.at_step(step)
        self.particles = [self.rng.multivariate_normal(tree.nodes[q].mean,
                                                       tree.nodes[q].covariance, samples,
                                                       method='cholesky')
                          for q in self.hypotheses]
        self.log_psi = np.zeros(len(self.hypotheses))
        self.current = step

    def advance(self) -> None:
        """Add the factor of the next step the tree has seen."""
        self.current += 1
        increment, observation = self.tree.inputs[self.current]
        tree = self.tree
        for k, particles in enumerate(self.particles):
            noise = self.rng.multivariate_normal(np.zeros(3), tree.motion_noise, self.samples,
                                                 method='cholesky')
            moved = compose(particles, increment + noise)
            if observation is None:
                self.particles[k] = moved
                continue
            likelihood = self._likelihood(moved, observation)
            mean = likelihood.mean()
            self.log_psi[k] += np.log(mean) if mean > 0 else -np.inf
            weights = likelihood / likelihood.sum() if mean > 0 else \
                np.full(self.samples, 1.0 / self.samples)
            positions = (self.rng.random() + np.arange(self.samples)) / self.samples
            self.particles[k] = moved[np.minimum(np.searchsorted(np.cumsum(weights), positions),
                                                 self.samples - 1)]

    def advance_to(self, step: int) -> None:
        """Advance until the factors of every step up to `step` are in."""
        while self.current < step:
            self.advance()

    def _likelihood(self, poses: np.ndarray, observation: np.ndarray) -> np.ndarray:
        """p(z | x) per particle (S,)."""
        landmarks = self.tree.landmarks
        r = self.tree.measurement_noise
        inverse, norm = np.linalg.inv(r), 1.0 / (2 * np.pi * np.sqrt(np.linalg.det(r)))
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        delta = landmarks[None, :, :] - poses[:, None, :2]  # (S, L, 2)
        predicted = np.stack([c[:, None] * delta[..., 0] + s[:, None] * delta[..., 1],
                              -s[:, None] * delta[..., 0] + c[:, None] * delta[..., 1]], axis=-1)
        nu = observation - predicted
        density = norm * np.exp(-0.5 * np.einsum('sla,ab,slb->sl', nu, inverse, nu))
        visible = np.hypot(delta[..., 0], delta[..., 1]) <= self.tree.fov_range
        none = ~visible.any(axis=1)
        visible[none] = True
        return (density * visible).sum(axis=1) / visible.sum(axis=1)

    def weights(self) -> dict[int, float]:
        """w_{m|k}^q for the hypotheses at m (normalised), k = the step reached."""
        prior = np.array([self.tree.nodes[q].weight for q in self.hypotheses])
        log_w = self.log_psi + np.log(prior)
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        return dict(zip(self.hypotheses, w))


def reevaluate_naive(tree: HypothesisTree, step: int, until: int, samples: int,
                     seed: int = 0) -> dict[int, float]:
    """w_{step|until} from a fresh particle filter per hypothesis (recomputed from `step`)."""
    reevaluation = ParticleReevaluation(tree, step, samples, seed)
    reevaluation.advance_to(until)
    return reevaluation.weights()
