"""Interacting multiple models (IMM; Blom and Bar-Shalom 1988; Bar-Shalom, Li, Kirubarajan,
"Estimation with Applications to Tracking and Navigation", 2001, 11.6.6) over Kalman filters
that share one state x (n,) and differ in their prediction (F, Q).

Per prediction over dt [s], with model probabilities mu (M,) and the switching matrix
Pi[i, j] = dt / switch_time / (M - 1) for i != j (at most 1 / M), 1 - sum of the others on the
diagonal:
    c_j = sum_i Pi[i, j] mu_i,   w_ij = Pi[i, j] mu_i / c_j,
    x0_j = sum_i w_ij x_i,   P0_j = sum_i w_ij (P_i + (x_i - x0_j)(x_i - x0_j)^T),
    model j predicts (x0_j, P0_j) with its own (x' = f(x), F, Q_j);   mu = c.
Per update with z (m,), H, R: each model's Kalman update (Joseph form) and likelihood
N(z - H x_j; 0, S_j); mu_j proportional to mu_j N_j.  The reported state and covariance are the
moment-matched mixture x = sum_j mu_j x_j, P = sum_j mu_j (P_j + (x_j - x)(x_j - x)^T).

The owner may edit x (in place or by assigning a new array): the edit moves every model's state
by the same amount before the next predict or update.  Assigning a new P restarts every model at
(x, P) with the initial probabilities.  Angle components (`angles`) are mixed and combined on
the branch of the most probable model (models at +179 and -179 deg combine at 180, not 0).  A
model whose predicted probability c_j is 0 keeps its own state (no mixture to take).
"""
from __future__ import annotations

from typing import Callable, Iterator, Sequence

import numpy as np

from .kalman import KalmanFilter

Prediction = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""x (n,) -> (predicted x (n,), Jacobian F (n, n))."""


class InteractingModels:
    """See the module docstring.  x, p: the mixture; h, r: the next update's H (m, n), R (m, m);
    probabilities (M,): the models' probabilities."""

    def __init__(self, x: np.ndarray, p: np.ndarray, probabilities: Sequence[float],
                 switch_time: float, angles: Sequence[int] = ()) -> None:
        initial = np.asarray(probabilities, dtype=float)
        if initial.ndim != 1 or initial.size < 1 or np.any(initial < 0) or initial.sum() <= 0:
            raise ValueError(f'probabilities: {probabilities!r} are not M >= 1 non-negative '
                             'weights')
        if not switch_time > 0:
            raise ValueError(f'switch_time: {switch_time!r} is not positive')
        self.initial = initial / initial.sum()
        self.switch_time = float(switch_time)
        self.angles = tuple(int(a) for a in angles)
        n = len(x)
        self.h, self.r = np.eye(n), np.eye(n)
        self._restart(np.asarray(x, dtype=float), np.asarray(p, dtype=float))

    def _restart(self, x: np.ndarray, p: np.ndarray) -> None:
        self.models = [KalmanFilter(x, p, np.eye(len(x)), np.zeros_like(p), self.h, self.r)
                       for _ in self.initial]
        self.probabilities = self.initial.copy()
        self._combine()

    def _states(self) -> np.ndarray:
        """The models' states (M, n), angle components on the most probable model's branch."""
        states = np.array([m.x for m in self.models])
        if self.angles and len(states) > 1:
            reference = states[int(np.argmax(self.probabilities))]
            for a in self.angles:   # only those more than pi away move (the rest exactly kept)
                far = np.abs(states[:, a] - reference[a]) > np.pi
                if far.any():
                    states[far, a] = reference[a] + (np.mod(
                        states[far, a] - reference[a] + np.pi, 2 * np.pi) - np.pi)
        return states

    def _combine(self) -> None:
        mu = self.probabilities
        states = self._states()
        x = mu @ states
        spread = states - x
        p = np.einsum('j,jab->ab', mu, np.array([m.p for m in self.models])) \
            + np.einsum('j,ja,jb->ab', mu, spread, spread)
        self.x, self.p = x, p
        self._x_seen, self._p_seen = x.copy(), p

    def _sync(self) -> None:
        """Apply the owner's edits of x and p to the models (module docstring)."""
        if self.p is not self._p_seen:
            self._restart(np.asarray(self.x, dtype=float), np.asarray(self.p, dtype=float))
            return
        shift = np.asarray(self.x, dtype=float) - self._x_seen
        if np.any(shift != 0):
            for model in self.models:
                model.x = model.x + shift
            self._x_seen = np.asarray(self.x, dtype=float).copy()

    def switching(self, dt: float) -> np.ndarray:
        """Pi (M, M) over dt [s] (module docstring)."""
        count = len(self.models)
        if count == 1:
            return np.ones((1, 1))
        leave = min(dt / self.switch_time, 1.0 - 1.0 / count) / (count - 1)
        pi = np.full((count, count), leave)
        np.fill_diagonal(pi, 1.0 - leave * (count - 1))
        return pi

    def predict(self, prediction: Prediction, noises: Sequence[np.ndarray], dt: float) -> None:
        """Mix, then predict model j with `prediction` and Q = noises[j] (module docstring)."""
        self._sync()
        pi = self.switching(dt)
        weights = pi * self.probabilities[:, None]  # (i, j)
        c = weights.sum(axis=0)
        weights = np.where(c > 0, weights / np.where(c > 0, c, 1.0), np.eye(len(c)))
        states = self._states()
        covariances = np.array([m.p for m in self.models])
        for j, model in enumerate(self.models):
            x0 = weights[:, j] @ states
            spread = states - x0
            p0 = np.einsum('i,iab->ab', weights[:, j], covariances) \
                + np.einsum('i,ia,ib->ab', weights[:, j], spread, spread)
            predicted, model.f = prediction(x0)
            model.x, model.p, model.q = x0, p0, np.asarray(noises[j], dtype=float)
            model.predict()
            model.x = predicted
        self.probabilities = c / c.sum()
        self._combine()

    def correct(self, measure: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                r: np.ndarray) -> None:
        """Every model's KalmanFilter.correct with (innovation (m,), H (m, n)) = measure(its
        x) and R (m, m); the probabilities are kept (a constraint such as a
        pseudo-measurement, not evidence for one model)."""
        self._sync()
        for model in self.models:
            model.correct(*measure(model.x), r)
        self._combine()

    def innovation_covariance(self) -> np.ndarray:
        """S = H P H^T + R (m, m) of the mixture."""
        return self.h @ self.p @ self.h.T + self.r

    def smallest_nis(self, z: np.ndarray) -> float:
        """min over the models of (z - H x_j)^T S_j^-1 (z - H x_j), S_j = H P_j H^T + R: gated
        on it, a measurement passes if any one model would take it (the mixture's covariance is
        mostly the probable model's: a manoeuvre's first measurements fail its gate while the
        agile model's would take them).  A model whose S is not positive definite (a negative
        NIS) takes nothing: inf."""
        self._sync()
        nis = []
        for _, innovation, s in self._innovations(z):
            d2 = innovation @ np.linalg.solve(s, innovation)
            nis.append(d2 if d2 >= 0 else np.inf)
        return float(min(nis))

    def _innovations(self, z: np.ndarray
                     ) -> Iterator[tuple[KalmanFilter, np.ndarray, np.ndarray]]:
        """Per model (the model with this H and R, z - H x_j (m,), S_j (m, m))."""
        z = np.asarray(z, dtype=float)
        for model in self.models:
            model.h, model.r = self.h, self.r
            yield model, z - model.h @ model.x, model.innovation_covariance()

    def update(self, z: np.ndarray) -> None:
        """Every model's Kalman update with z (m,); the probabilities by their likelihoods."""
        self._sync()
        logs = np.empty(len(self.models))
        for j, (model, innovation, s) in enumerate(self._innovations(z)):
            sign, log_det = np.linalg.slogdet(2 * np.pi * s)
            logs[j] = -0.5 * (innovation @ np.linalg.solve(s, innovation) + log_det) \
                if sign > 0 else -np.inf
            model.update(z)
        if np.all(np.isfinite(logs)):
            weights = self.probabilities * np.exp(logs - logs.max())
            if weights.sum() > 0:
                self.probabilities = weights / weights.sum()
        self._combine()
