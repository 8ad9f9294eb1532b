"""Joint compatibility search shared by jcbb and jcbb_points (Neira & Tardos 2001).

Among one-to-one sets H of individually compatible pairs whose joint NIS
d2_H = nu_H^T C_H^-1 nu_H  (C_H = H_H P H_H^T + blockdiag R)  passes chi2(m |H|, p), find one
with the most pairs, ties broken by the smallest d2_H.  d2_H is exact and updated
incrementally: the inverse Cholesky factor of C_H grows by one m x m block per pair
(Schur complement), O(l^2 m) per node, with no refactorisation.

Pruning is exact: a branch is cut when its d2 exceeds the threshold of the largest dimension
still reachable in it (d2 never decreases as pairs are added, but the threshold grows with the
dimension, so cutting at every node failing its own test can miss a larger valid set), or when
it cannot reach more pairs than the best so far (or as many with a smaller d2).

With nis_ties=False the search is Neira & Tardos' original one (as in the TTK4250 course's
JCBB): a set replaces the best only with more pairs, so a branch is cut as soon as it
cannot reach more pairs than the best so far; the answer is the first set with the most pairs
in the search order, which can have a larger d2 than another set of that size.
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import Optional

import numpy as np

from .. import jit
from ..gating import chi2_threshold
from ..parameters import ParameterSpec

TIME_BUDGET_MS = ParameterSpec(
    'time_budget_ms', 0.0, 'stop the search after this many milliseconds and return the best '
    'hypothesis so far, flagged truncated (0: no limit)', low=0.0)
MAX_NODES = ParameterSpec(
    'max_nodes', 0, 'stop the search after this many search nodes (0: no limit)', kind=int, low=0)


def _inverse_cholesky(matrix: np.ndarray) -> Optional[np.ndarray]:
    """L^-1 for the Cholesky factor L of an SPD m x m matrix (closed form for m = 2); None when
    the matrix is not positive definite."""
    if matrix.shape == (2, 2):
        a = matrix[0, 0]
        if not a > 0.0:
            return None
        l00 = math.sqrt(a)
        l10 = matrix[1, 0] / l00
        d = matrix[1, 1] - l10 * l10
        if not d > 0.0:
            return None
        l11 = math.sqrt(d)
        return np.array([[1.0 / l00, 0.0], [-l10 / (l00 * l11), 1.0 / l11]])
    try:
        factor = np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        return None
    return np.linalg.inv(factor)


class CandidateLists(Sequence):
    """Each observation's candidate landmark columns (individually compatible, sorted by NIS):
    row i is columns[start[i]:start[i + 1]] (CSR: start (K + 1,), columns (E,), int64)."""

    def __init__(self, start: np.ndarray, columns: np.ndarray) -> None:
        self.start = start
        self.columns = columns

    @classmethod
    def from_counts(cls, counts, columns: np.ndarray) -> 'CandidateLists':
        """Rows of counts[i] (K,) columns each, one after the other in `columns` (E,)."""
        start = np.zeros(len(counts) + 1, dtype=np.int64)
        np.cumsum(counts, out=start[1:])
        return cls(start, np.asarray(columns, dtype=np.int64))

    @classmethod
    def of(cls, lists) -> 'CandidateLists':
        """The CandidateLists of a sequence of column arrays (itself when it is one)."""
        if isinstance(lists, CandidateLists):
            return lists
        counts = [len(c) for c in lists]
        return cls.from_counts(counts, np.concatenate(lists) if sum(counts) else np.zeros(0))

    @property
    def counts(self) -> np.ndarray:
        """Candidates per observation (K,)."""
        return np.diff(self.start)

    def __len__(self) -> int:
        return len(self.start) - 1

    def __getitem__(self, i):
        if not isinstance(i, (int, np.integer)):
            raise TypeError('CandidateLists: one row at a time')
        if not -len(self) <= i < len(self):
            raise IndexError(i)
        i = int(i) % len(self)
        return self.columns[self.start[i]:self.start[i + 1]]


def search_order(counts: np.ndarray, skip=()) -> list[int]:
    """The observations with candidates (counts (K,)), fewest candidates first, ties by index,
    without those in `skip`."""
    rows = np.flatnonzero(counts)
    if len(skip):
        rows = rows[~np.isin(rows, list(skip))]
    return rows[np.argsort(counts[rows], kind='stable')].tolist()


class JointCompatibilitySearch:
    """Depth-first branch and bound over observations (fewest candidates first).

    The joint innovation covariance C of the current pairs is kept as the inverse of its
    Cholesky factor, L^-1 (lower triangular), and the whitened innovation w = L^-1 nu, so
    d2 = |w|^2.  Adding a pair (i, j) with cross-covariance B = Cov(h_H, h_j):
    X = L^-1 B,  Schur complement D = S_ij - X^T X,  w_new = D_L^-1 (nu_ij - X^T w),
    new rows of L^-1 = [-D_L^-1 X^T L^-1, D_L^-1].
    """

    def __init__(self, problem, gate_probability: float, candidates: Sequence[np.ndarray],
                 order: list[int], deadline: Optional[float], max_nodes: int,
                 classic: bool = False, nis_ties: bool = True) -> None:
        m = problem.observations.dim
        self.m = m
        self.nu = problem.innovations
        self.s = problem.innovation_covariances
        nonempty = [c for c in candidates if len(c)]
        local = np.unique(np.concatenate(nonempty)) if nonempty else np.zeros(0, dtype=np.intp)
        self.joint = problem.joint_prediction_covariance(local)
        position_of = np.full(problem.sizes[1], -1, dtype=np.intp)
        position_of[local] = np.arange(len(local))
        # per search position t: observation, candidate landmarks (columns) and their local index
        self.order = order
        self.columns = [candidates[i] for i in order]
        self.locals = [position_of[candidates[i]] for i in order]
        self.position_of = position_of
        k = len(order)
        most = len(candidates)
        self.thresholds = np.array([chi2_threshold(gate_probability, m * l) if l else 0.0
                                    for l in range(most + 1)])
        self.inverse_factor = np.zeros((most * m, most * m))
        self.whitened = np.zeros(most * m)
        self.pair_locals = np.zeros(most, dtype=np.intp)
        self.pairs: list[tuple[int, int]] = []
        self.used = np.zeros(len(local), dtype=bool)
        # searched_by[a, t]: landmark a is a candidate of search position t; free[t]: how many
        # candidates of position t are not used by the current pairs
        self.searched_by = np.zeros((len(local), k), dtype=np.intp)
        for t in range(k):
            self.searched_by[self.locals[t], t] = 1
        self.free = self.searched_by.sum(axis=0)
        self.best_pairs: list[tuple[int, int]] = []
        self.best_nis = 0.0
        self.nodes = 0
        self.deadline = deadline
        self.max_nodes = max_nodes
        self.classic = classic
        self.nis_ties = nis_ties
        self.truncated = False

    def start_from(self, pairs: list[tuple[int, int]]) -> float:
        """Fix `pairs` (observation, landmark column) as the root of the search (seed 003's
        minimal association); returns their joint NIS and records them as the best so far
        when they pass the joint test."""
        nis = 0.0
        for i, j in pairs:
            a = int(self.position_of[j])
            nis = self._extend(i, j, a, nis)
            if nis is None:
                raise ValueError('joint covariance of the initial pairs is not positive definite')
            self.pair_locals[len(self.pairs)] = a
            self.pairs.append((i, j))
            self._use(a)
        if nis <= self.thresholds[len(self.pairs)]:
            self.best_pairs, self.best_nis = list(self.pairs), nis
        return nis

    def _reachable(self, position: int) -> int:
        """How many of the observations from `position` on still have a free candidate."""
        return int(np.count_nonzero(self.free[position:]))

    def _use(self, a: int) -> None:
        self.used[a] = True
        self.free -= self.searched_by[a]

    def _release(self, a: int) -> None:
        self.used[a] = False
        self.free += self.searched_by[a]

    def _extend(self, i: int, j: int, a: int, nis: float) -> Optional[float]:
        """d2 after adding pair (i, j) (local landmark a), writing the new rows of L^-1 and w;
        None if the joint covariance is not positive definite."""
        m, l = self.m, len(self.pairs)
        size = l * m
        if l:
            cross = self.joint[self.pair_locals[:l], a].reshape(size, m)
            inverse = self.inverse_factor[:size, :size]
            x = inverse @ cross
            schur = self.s[i, j] - x.T @ x
            residual = self.nu[i, j] - x.T @ self.whitened[:size]
        else:
            schur, residual = self.s[i, j], self.nu[i, j]
        block_inverse = _inverse_cholesky(schur)
        if block_inverse is None:
            return None
        w = block_inverse @ residual
        if l:
            self.inverse_factor[size:size + m, :size] = -(block_inverse @ x.T) @ inverse
        self.inverse_factor[size:size + m, size:size + m] = block_inverse
        self.whitened[size:size + m] = w
        return nis + float(w @ w)

    def _out_of_budget(self) -> bool:
        if (self.max_nodes and self.nodes >= self.max_nodes) or (
                self.deadline is not None and time.perf_counter() >= self.deadline):
            self.truncated = True
        return self.truncated

    def run(self, position: int = 0, nis: float = 0.0) -> None:
        """Search from `position` with the current pairs and joint NIS (recursion depth: one
        frame per search position, so the recursion limit is raised to fit)."""
        limit = sys.getrecursionlimit()
        sys.setrecursionlimit(max(limit, 2 * len(self.order) + 200))
        try:
            self._search(position, nis)
        finally:
            sys.setrecursionlimit(limit)

    def _search(self, position: int, nis: float) -> None:
        """Explore from search position `position` with the current pairs and joint NIS."""
        if self.truncated:
            return
        l = len(self.pairs)
        upper = l + (self._reachable(position) if position < len(self.order) else 0)
        best = len(self.best_pairs)
        if upper < best or (upper == best and (nis >= self.best_nis or not self.nis_ties)):
            return
        if nis > self.thresholds[upper] or position == len(self.order):
            return
        i = self.order[position]
        for j, a in zip(self.columns[position], self.locals[position]):
            if self.used[a]:
                continue
            self.nodes += 1
            if self._out_of_budget():
                return
            new_nis = self._extend(i, int(j), int(a), nis)
            if new_nis is None:
                continue
            passes = new_nis <= self.thresholds[l + 1]
            if passes and (l + 1 > len(self.best_pairs) or (
                    self.nis_ties and l + 1 == len(self.best_pairs)
                    and new_nis < self.best_nis)):
                self.best_pairs = self.pairs + [(i, int(j))]
                self.best_nis = new_nis
            if passes or not self.classic:
                self.pairs.append((i, int(j)))
                self.pair_locals[l] = a
                self._use(a)
                self._search(position + 1, new_nis)
                self._release(a)
                self.pairs.pop()
            if self.truncated:
                return
        self._search(position + 1, nis)




def joint_compatibility_search(problem, gate_probability: float,
                               candidates: Sequence[np.ndarray], order: list[int],
                               deadline: Optional[float], max_nodes: int, classic: bool = False,
                               nis_ties: bool = True):
    """The search of JointCompatibilitySearch's arguments: jcbb_compiled.CompiledSearch (the
    same answer, node count and truncation) when numba is available and jit.compiled() is on,
    else JointCompatibilitySearch."""
    from . import jcbb_compiled
    kind = jcbb_compiled.CompiledSearch if jit.enabled() and jcbb_compiled.available() \
        else JointCompatibilitySearch
    return kind(problem, gate_probability, candidates, order, deadline, max_nodes, classic,
                nis_ties)


def prepare_search() -> None:
    """Compile (or load) the compiled search now, if it is on: callers do this before they start
    a time budget's clock, so that a process's first search is not cut short by it."""
    if jit.enabled():
        from . import jcbb_compiled
        jcbb_compiled.available()


def _warm_up_problem() -> None:
    """Run the compiled search on a small range-bearing problem, with and without a deadline
    and a fixed root, without and with a state covariance (writable and read-only), so that every
    kernel version a search uses is compiled (or loaded from the cache) before it is timed."""
    from ..problem import AssociationProblem
    from ..types import Landmarks, Observations, RobotPose
    from ..validation import check_covariance_matrix
    from .jcbb_compiled import CompiledSearch
    bearings = np.array([0.0, 0.2, 0.4, 0.6])
    means = 10.0 * np.column_stack([np.cos(bearings), np.sin(bearings)])
    problem = AssociationProblem(
        Landmarks([0, 1, 2, 3], means, np.tile(np.eye(2) * 1e-2, (4, 1, 1))),
        Observations(np.column_stack([np.full(4, 10.0), bearings - 0.05]),
                     np.tile(np.diag([0.01, 1e-3]), (4, 1, 1)), 'range_bearing'),
        RobotPose([0.0, 0.0, 0.0], np.diag([1e-2, 1e-2, 0.05 ** 2])))
    # with a state covariance too (the Cholesky-factor path and _joint_blocks), writable and
    # read-only (a checked one): numba compiles one version per array type
    state = np.zeros((11, 11))
    state[:3, :3] = problem.pose.covariance
    state[3:, 3:] = np.kron(np.eye(4), np.eye(2) * 1e-2)
    problems = [problem] + [AssociationProblem(problem.landmarks, problem.observations,
                                               problem.pose, matrix)
                            for matrix in (state, check_covariance_matrix(state.copy(), 'warm'))]
    candidates = [np.arange(4) for _ in range(4)]
    for each in problems:
        for deadline, root in ((None, []), (time.perf_counter() + 3600.0, [(0, 0)])):
            search = CompiledSearch(each, 0.99, candidates,
                                    [1, 2, 3] if root else [0, 1, 2, 3], deadline, 0)
            search.run(0, search.start_from(root))
            if len(search.best_pairs) != 4:
                raise RuntimeError(f'compiled search warm-up found {search.best_pairs}')
