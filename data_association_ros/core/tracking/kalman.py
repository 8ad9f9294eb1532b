"""Linear Kalman filter: x' = F x, P' = F P F^T + Q;  K = P H^T S^-1, S = H P H^T + R,
x += K (z - H x),  P = (I - K H) P (I - K H)^T + K R K^T (Joseph form, which holds for
any gain and keeps P positive semi-definite under rounding)."""
from __future__ import annotations

import numpy as np


class KalmanFilter:
    """State x (n,), covariance P (n, n); F, Q (n, n); H (m, n); R (m, m)."""

    def __init__(self, x: np.ndarray, p: np.ndarray, f: np.ndarray, q: np.ndarray,
                 h: np.ndarray, r: np.ndarray) -> None:
        self.x = np.asarray(x, dtype=float).copy()
        self.p = np.asarray(p, dtype=float).copy()
        self.f, self.q, self.h, self.r = (np.asarray(a, dtype=float) for a in (f, q, h, r))

    def predict(self) -> None:
        """x = F x, P = F P F^T + Q."""
        self.x = self.f @ self.x
        self.p = self.f @ self.p @ self.f.T + self.q

    def innovation_covariance(self) -> np.ndarray:
        """S = H P H^T + R (m, m)."""
        return self.h @ self.p @ self.h.T + self.r

    def update(self, z: np.ndarray) -> None:
        """Correct with measurement z (m,)."""
        self.correct(np.asarray(z, dtype=float) - self.h @ self.x, self.h, self.r)

    def correct(self, innovation: np.ndarray, h: np.ndarray, r: np.ndarray) -> None:
        """Correct with an innovation (m,) of Jacobian H (m, n) and noise R (m, m) (an EKF's
        z - h(x)); P in Joseph form."""
        s = h @ self.p @ h.T + r
        gain = np.linalg.solve(s, h @ self.p).T  # P H^T S^-1 (S, P symmetric)
        self.x = self.x + gain @ innovation
        i_kh = np.eye(len(self.x)) - gain @ h
        self.p = i_kh @ self.p @ i_kh.T + gain @ r @ gain.T
