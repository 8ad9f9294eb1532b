"""Seed 003's approximate joint NIS, for comparison with the exact incremental one.

The seed factorises once S_all = H P H^T + blockdiag(R) over every candidate landmark,
L L^T = S_all, and for a hypothesis takes the rows and columns of L of its landmarks
(L_sigma, still lower triangular when the pairs are sorted by landmark):
    d2 ~ |L_sigma^-1 nu_sigma|^2.
It is exact only when the landmarks form a leading block of S_all (a principal submatrix of a
Cholesky factor is the factor of the submatrix only then).  R is the observations' mean
covariance, since S_all is built before observations are paired.
"""
from __future__ import annotations

import time
from typing import Optional

import numpy as np
from scipy.linalg import solve_triangular

from data_association_ros.core.associators.jcbb import deadline_of, individually_compatible
from data_association_ros.core.associators.joint_compatibility import JointCompatibilitySearch


class ApproximateJointCompatibilitySearch(JointCompatibilitySearch):
    """The same branch and bound, with d2 from rows and columns of one Cholesky factor."""

    def __init__(self, problem, *args, **kwargs) -> None:
        super().__init__(problem, *args, **kwargs)
        count, m = self.joint.shape[0], self.m
        s_all = self.joint.transpose(0, 2, 1, 3).reshape(count * m, count * m).copy()
        mean_r = problem.observations.covariances.mean(axis=0)
        for a in range(count):
            s_all[a * m:(a + 1) * m, a * m:(a + 1) * m] += mean_r
        self.factor = np.linalg.cholesky(s_all)

    def _extend(self, i: int, j: int, a: int, nis: float) -> Optional[float]:
        l, m = len(self.pairs), self.m
        local = np.append(self.pair_locals[:l], a)
        rows = [r for r, _ in self.pairs] + [i]
        columns = [c for _, c in self.pairs] + [j]
        order = np.argsort(local)
        nu = self.nu[np.array(rows)[order], np.array(columns)[order]].reshape(-1)
        index = (local[order][:, None] * m + np.arange(m)).reshape(-1)
        w = solve_triangular(self.factor[np.ix_(index, index)], nu, lower=True,
                             check_finite=False)
        return float(w @ w)


def search_pairs(problem, gate_probability: float = 0.99, approximate: bool = False,
                 time_budget_ms: float = 0.0) -> tuple[set, float, int]:
    """(pairs {(observation, landmark column)}, joint NIS, nodes) of the JCBB search with the
    exact or the seed's approximate joint NIS."""
    started = time.perf_counter()
    _, candidates, order = individually_compatible(problem, gate_probability)
    kind = ApproximateJointCompatibilitySearch if approximate else JointCompatibilitySearch
    search = kind(problem, gate_probability, candidates, order,
                  deadline_of(started, time_budget_ms), 0)
    search.run()
    return set(search.best_pairs), search.best_nis, search.nodes


def approximate_nis(problem, pairs: set, gate_probability: float = 0.99) -> float:
    """The seed's approximate joint NIS of a set of pairs (observation, landmark column)."""
    _, candidates, order = individually_compatible(problem, gate_probability)
    search = ApproximateJointCompatibilitySearch(problem, gate_probability, candidates, order,
                                                 None, 0)
    return search.start_from(sorted(pairs))
