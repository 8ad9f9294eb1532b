"""Linear Kalman filter: x' = F x, P' = F P F^T + Q;  K = P H^T S^-1, S = H P H^T + R,
x += K (z - H x),  P = (I - K H) P (I - K H)^T + K R K^T (Joseph form)."""
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
        s = self.innovation_covariance()
        gain = np.linalg.solve(s, self.h @ self.p).T  # P H^T S^-1 (S, P symmetric)
        self.x = self.x + gain @ (np.asarray(z, dtype=float) - self.h @ self.x)
        i_kh = np.eye(len(self.x)) - gain @ self.h
        self.p = i_kh @ self.p @ i_kh.T + gain @ self.r @ gain.T
