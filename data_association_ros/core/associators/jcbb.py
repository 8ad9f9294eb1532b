"""jcbb: joint compatibility branch and bound (Neira & Tardos 2001; seed 000, 4.2-4.3).

Among all one-to-one sets H of individually compatible pairs whose joint NIS
d2_H = nu_H^T C_H^-1 nu_H  (C_H = H_H P H_H^T + blockdiag R)  passes chi2(m |H|, p), return one
with the most pairs, ties broken by the smallest d2_H.  d2_H is updated incrementally: the
Cholesky factor of C_H grows by one m x m block per pair (Schur complement), O(l m^2) per node.

Pruning is exact by default: a branch is cut when its d2 exceeds the threshold of the largest
dimension still reachable in it (d2 never decreases as pairs are added), or when it cannot reach
more pairs than the best so far (or as many with a smaller d2).  `classic_pruning` also cuts at
every node failing its own test, which is faster but can miss a larger valid set.
"""
from __future__ import annotations

import time

import numpy as np
from scipy.linalg import solve_triangular

from ..gating import chi2_threshold
from ..parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, ParameterSpec
from .base import NO_LANDMARK, Associator, result

TIME_BUDGET_MS = ParameterSpec(
    'time_budget_ms', 0.0, 'stop the search after this many milliseconds and return the best '
    'hypothesis so far (0: no limit)', low=0.0)
MAX_NODES = ParameterSpec(
    'max_nodes', 0, 'stop the search after this many search nodes (0: no limit)', kind=int, low=0)
CLASSIC_PRUNING = ParameterSpec(
    'classic_pruning', False, 'also prune every node failing its own joint test (faster, may '
    'miss the largest valid set)', kind=bool)


class _Search:
    """Depth-first branch and bound over observations (fewest candidates first)."""

    def __init__(self, problem, gate_probability, candidates, order, deadline, max_nodes,
                 classic):
        m = problem.observations.dim
        self.m = m
        self.nu = problem.innovations
        self.s = problem.innovation_covariances
        self.candidates = candidates
        self.order = order
        local = np.unique(np.concatenate([candidates[i] for i in order])) if order else \
            np.zeros(0, dtype=np.intp)
        self.local_index = {int(j): a for a, j in enumerate(local)}
        self.joint = problem.joint_prediction_covariance(local)
        k = len(order)
        self.thresholds = np.array([chi2_threshold(gate_probability, m * l) if l else 0.0
                                    for l in range(k + 1)])
        self.factor = np.zeros((k * m, k * m))
        self.whitened = np.zeros(k * m)
        self.pairs: list[tuple[int, int]] = []
        self.used = np.zeros(problem.sizes[1], dtype=bool)
        # candidate_mask[t, j]: observation order[t] may pair with landmark j
        self.candidate_mask = np.zeros((k, problem.sizes[1]), dtype=bool)
        for t, i in enumerate(order):
            self.candidate_mask[t, candidates[i]] = True
        self.best_pairs: list[tuple[int, int]] = []
        self.best_nis = 0.0
        self.nodes = 0
        self.deadline = deadline
        self.max_nodes = max_nodes
        self.classic = classic
        self.truncated = False

    def _reachable(self, position: int) -> int:
        """How many of the observations from `position` on still have a free candidate."""
        free = self.candidate_mask[position:] & ~self.used
        return int(free.any(axis=1).sum())

    def _extend(self, i: int, j: int, nis: float):
        """d2 after adding pair (i, j) to self.pairs, writing the new factor block; None if the
        joint covariance is not positive definite."""
        m, l = self.m, len(self.pairs)
        a = self.local_index[j]
        size = l * m
        if l:
            cross = np.concatenate([self.joint[self.local_index[jj], a] for _, jj in self.pairs])
            x = solve_triangular(self.factor[:size, :size], cross, lower=True,
                                 check_finite=False)
            schur = self.s[i, j] - x.T @ x
            residual = self.nu[i, j] - x.T @ self.whitened[:size]
        else:
            x = None
            schur = self.s[i, j]
            residual = self.nu[i, j]
        try:
            block = np.linalg.cholesky(schur)
        except np.linalg.LinAlgError:
            return None
        w = solve_triangular(block, residual, lower=True, check_finite=False)
        if x is not None:
            self.factor[size:size + m, :size] = x.T
        self.factor[size:size + m, size:size + m] = block
        self.whitened[size:size + m] = w
        return nis + float(w @ w)

    def _out_of_budget(self) -> bool:
        if (self.max_nodes and self.nodes >= self.max_nodes) or (
                self.deadline is not None and time.perf_counter() >= self.deadline):
            self.truncated = True
        return self.truncated

    def run(self, position: int = 0, nis: float = 0.0) -> None:
        """Explore from observation order[position] with the current pairs and joint NIS."""
        if self.truncated:
            return
        l = len(self.pairs)
        upper = l + (self._reachable(position) if position < len(self.order) else 0)
        if upper < len(self.best_pairs) or (
                upper == len(self.best_pairs) and nis >= self.best_nis):
            return
        if nis > self.thresholds[upper]:
            return
        if position == len(self.order):
            return
        i = self.order[position]
        for j in self.candidates[i]:
            if self.used[j]:
                continue
            self.nodes += 1
            if self._out_of_budget():
                return
            new_nis = self._extend(i, int(j), nis)
            if new_nis is None:
                continue
            passes = new_nis <= self.thresholds[l + 1]
            if passes and (l + 1 > len(self.best_pairs) or (
                    l + 1 == len(self.best_pairs) and new_nis < self.best_nis)):
                self.best_pairs = self.pairs + [(i, int(j))]
                self.best_nis = new_nis
            if passes or not self.classic:
                self.pairs.append((i, int(j)))
                self.used[j] = True
                self.run(position + 1, new_nis)
                self.used[j] = False
                self.pairs.pop()
            if self.truncated:
                return
        self.run(position + 1, nis)


def run(problem, gate_probability: float, min_innovation_variance: float, time_budget_ms: float,
        max_nodes: int, classic_pruning: bool):
    """JCBB over the individually compatible pairs; see the module docstring."""
    started = time.perf_counter()
    k, n = problem.sizes
    nis = problem.nis
    gated = nis <= chi2_threshold(gate_probability, problem.observations.dim)
    candidates = [np.flatnonzero(gated[i])[np.argsort(nis[i, gated[i]], kind='stable')]
                  for i in range(k)]
    order = sorted((i for i in range(k) if len(candidates[i])),
                   key=lambda i: (len(candidates[i]), i))
    deadline = started + time_budget_ms / 1000.0 if time_budget_ms > 0 else None
    search = _Search(problem, gate_probability, candidates, order, deadline, max_nodes,
                     classic_pruning)
    search.run()
    columns = np.full(k, NO_LANDMARK, dtype=np.intp)
    for i, j in search.best_pairs:
        columns[i] = j
    return result(problem, 'jcbb', columns, gated, joint_nis=search.best_nis,
                  search_nodes=search.nodes, truncated=search.truncated,
                  elapsed_ms=(time.perf_counter() - started) * 1000.0)


ASSOCIATOR = Associator(
    name='jcbb', run=run,
    parameters=(GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, TIME_BUDGET_MS, MAX_NODES,
                CLASSIC_PRUNING),
    summary='joint compatibility branch and bound: the largest jointly consistent set of pairs')
