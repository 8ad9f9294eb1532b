"""Compiled joint compatibility search (numba; optional: without numba, or when it fails to
compile, `available()` is False and joint_compatibility's pure-Python search runs).

The same depth-first branch and bound as joint_compatibility.JointCompatibilitySearch: the same
search order, pruning, tie rule, node count and budget semantics, hence the same answer (test:
test_jcbb_compiled.py).  What differs is how it gets there:

* the recursion is an explicit per-position state (stage, next candidate, NIS, pairs on entry),
  so the search is resumable: with a deadline it returns to Python after its first node and
  then after the nodes that fit in half the time left (at least PAUSE_EVERY), and the caller
  reads the clock there (numba has no clock);
* without a state covariance the pose is the only correlation between predictions:
  C_H = blockdiag(B_t) + G_H U U^T G_H^T with B_t = H_m P_j H_m^T + R_i, G_t = dh/dpose and
  U U^T = the pose covariance, so (Woodbury)  d2_H = a - h^T (I + M)^-1 h  with
  a = sum nu_t^T B_t^-1 nu_t,  h = sum (G_t U)^T B_t^-1 nu_t,  M = sum (G_t U)^T B_t^-1 G_t U:
  three running sums per depth, O(m^2 + 27) per node (low_rank_terms);
* otherwise it keeps the Cholesky factor L of C_H (not L^-1) and, per candidate landmark a, the
  block rows X_a = L^-1 Cov(h_H, h_a) already computed, by forward substitution
  X_a[t] = D_t^-1 (Cov(h_t, h_a) - sum_{q<t} L[t, q] X_a[q]).  A row depends on the pairs up to
  t only, so it is reused while they are unchanged (a version stamp per depth); with X = X_a:
  D = S_ij - X^T X,  w_new = D_L^-1 (nu_ij - X^T w),  d2_new = d2 + |w_new|^2,  new block row
  of L = [X^T, D_L];
* innovations and S are taken for the candidate pairs only (problem.pair_terms), the joint
  covariance of the candidate landmarks by a compiled product (_joint_blocks); the candidate
  lists and the search's index arrays by gated_candidates and search_layout.

The kernels are in jcbb_kernels.py (numba, cached on disk); `available()` compiles (or loads)
them ahead of the first search; DATA_ASSOCIATION_ROS_NO_JIT=1 switches them off (core/jit.py).
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from functools import lru_cache
from typing import Optional

import numpy as np

from ..gating import chi2_threshold
from ..jit import Kernels
from .jcbb_kernels import (BEST_COUNT, ISTATE_SIZE, NODES, NPAIRS, PAUSE_EVERY, PAUSED, POS,
                           RUNNING, START, STATUS, NEXT_PAUSE, TRUNCATED, _extend, _joint_blocks,
                           _push, gated_candidates, search, search_layout)
from .joint_compatibility import CandidateLists


def joint_covariance(problem, local: np.ndarray) -> np.ndarray:
    """Cov(h_a, h_b) for a, b in `local` (L, L, m, m): the compiled _joint_blocks with a state
    covariance, else the problem's joint_prediction_covariance."""
    if problem.state_covariance is None or len(local) == 0:
        return np.ascontiguousarray(problem.joint_prediction_covariance(local))
    _, h_m, h_x = problem._prediction
    m = problem.observations.dim
    out = np.empty((len(local), len(local), m, m))
    _joint_blocks(np.ascontiguousarray(h_x), np.ascontiguousarray(h_m),
                  np.ascontiguousarray(problem.state_covariance),
                  np.asarray(local, dtype=np.int64), out)
    return out


def low_rank_terms(problem, rows: np.ndarray, columns: np.ndarray):
    """Per candidate pair (rows[e], columns[e]) the terms of _extend_low_rank: (nu^T B^-1 nu
    (E,), (G U)^T B^-1 nu (E, 3), (G U)^T B^-1 G U (E, 3, 3)) with B = H_m P_j H_m^T + R_i,
    G = H_x and U U^T = the pose covariance; None when that form does not hold exactly (a
    state covariance, a floor on S that may bind, a B not positive definite)."""
    if problem.state_covariance is not None or problem.landmarks.covariances is None or \
            problem.observations.covariances is None:
        return None
    _, h_m, h_x = problem._prediction
    pose = np.zeros((3, 3)) if problem.pose is None else problem.pose.covariance
    values, vectors = np.linalg.eigh(pose)
    root = vectors * np.sqrt(np.maximum(values, 0.0))
    g = h_x[columns] @ root
    hm = h_m[columns]
    b = hm @ problem.landmarks.covariances[columns] @ np.swapaxes(hm, 1, 2) + \
        problem.observations.covariances[rows]
    floor = problem.min_innovation_variance
    if floor > 0 and len(rows):
        diagonal = np.einsum('eii->ei', b) + np.einsum('eij,eij->ei', g, g)
        if not (diagonal > 2.0 * floor).all():
            return None
    try:
        np.linalg.cholesky(b)
        b_inverse = np.linalg.inv(b)
    except np.linalg.LinAlgError:
        return None
    nu = problem.innovations_of(rows, columns)
    b_nu = np.einsum('eij,ej->ei', b_inverse, nu)
    b_g = b_inverse @ g
    return (np.einsum('ei,ei->e', nu, b_nu), np.einsum('eir,ei->er', g, b_nu),
            np.ascontiguousarray(np.swapaxes(g, 1, 2) @ b_g))


_NO_LOW_RANK = (np.zeros(0), np.zeros((0, 1)), np.zeros((0, 1, 1)))
"""Zero-sized stand-ins for the low-rank arrays of a Cholesky-factor search (never written)."""


@lru_cache(maxsize=256)
def _thresholds(probability: float, m: int, most: int) -> np.ndarray:
    """chi2(m l, probability) for l = 0..most (0 for l = 0); shared: never written."""
    return np.array([chi2_threshold(probability, m * l) if l else 0.0 for l in range(most + 1)])


class CompiledSearch:
    """JointCompatibilitySearch's interface (start_from, run, best_pairs, best_nis, nodes,
    truncated) on the compiled kernel; same arguments as JointCompatibilitySearch."""

    def __init__(self, problem, gate_probability: float, candidates: Sequence[np.ndarray],
                 order: list[int], deadline: Optional[float], max_nodes: int,
                 classic: bool = False, nis_ties: bool = True) -> None:
        m = problem.observations.dim
        self.problem = problem
        lists = CandidateLists.of(candidates)
        k, most = len(order), len(lists)
        self.order = np.asarray(order, dtype=np.int64)
        (self.cptr, self.ccols, self.rows, self.cloc, self.local, self.position_of, self.lptr,
         self.lpos) = search_layout(self.order, lists.start, lists.columns, problem.sizes[1])
        count = len(self.local)
        self.thresholds = _thresholds(gate_probability, m, most)
        self.classic, self.nis_ties = bool(classic), bool(nis_ties)
        self.max_nodes, self.deadline = int(max_nodes), deadline
        self.depth = depth = max(most, 1)
        self.pobs, self.pcol, self.ploc, self.bobs, self.bcol = np.zeros((5, depth),
                                                                         dtype=np.int64)
        self.used = np.zeros(count, dtype=np.bool_)
        self.free = self.cptr[1:] - self.cptr[:-1]   # free candidates per position
        self.f_nis = np.zeros(k + 1)
        self.f_c, self.f_stage, self.f_l = np.zeros((3, k + 1), dtype=np.int64)
        self.istate = np.zeros(ISTATE_SIZE, dtype=np.int64)
        self.fstate = np.zeros(2)   # best NIS, NIS at the root
        sums = low_rank_terms(problem, self.rows, self.ccols)
        self.low_rank = sums is not None
        if self.low_rank:
            self.e_a, self.e_g, self.e_m = sums
            rank = self.e_g.shape[1]
            self.cum_a = np.zeros(depth + 1)
            self.cum_g = np.zeros((depth + 1, rank))
            self.cum_m = np.zeros((depth + 1, rank, rank))
            self._general(empty=True)
        else:
            self.e_a, self.e_g, self.e_m = _NO_LOW_RANK
            self.cum_a, self.cum_g, self.cum_m = _NO_LOW_RANK
            self._general()

    def _general(self, empty: bool = False) -> None:
        """The arrays of the Cholesky-factor search (zero-sized when `empty`); all but xvalid
        are written before they are read."""
        problem, m = self.problem, self.problem.observations.dim
        count, depth = (0, 0) if empty else (len(self.local), self.depth)
        self.joint = np.zeros((0, 0, m, m)) if empty else joint_covariance(problem, self.local)
        self.nu, self.s = (np.zeros((0, m)), np.zeros((0, m, m))) if empty else \
            problem.pair_terms(self.rows, self.ccols)
        self.lblk = np.empty((depth, depth, m, m))
        self.dinv = np.empty((depth, m, m))
        self.w = np.empty((depth, m))
        self.xc = np.empty((count, depth, m, m))
        self.xstamp, self.lversion = np.empty((count, depth), dtype=np.int64), \
            np.empty(depth, dtype=np.int64)
        self.xvalid = np.zeros(count, dtype=np.int64)

    @property
    def best_pairs(self) -> list[tuple[int, int]]:
        """The best set so far: (observation, landmark column) pairs."""
        count = int(self.istate[BEST_COUNT])
        return list(zip(self.bobs[:count].tolist(), self.bcol[:count].tolist()))

    @property
    def best_nis(self) -> float:
        """Joint NIS of best_pairs (0 when empty)."""
        return float(self.fstate[0])

    @property
    def nodes(self) -> int:
        """Search nodes visited (pairs tried)."""
        return int(self.istate[NODES])

    @property
    def truncated(self) -> bool:
        """True when max_nodes or the deadline cut the search short."""
        return bool(self.istate[TRUNCATED])

    def start_from(self, pairs: list[tuple[int, int]]) -> float:
        """Fix `pairs` (observation, landmark column) as the root of the search; returns their
        joint NIS and records them as the best so far when they pass the joint test."""
        if pairs and self.low_rank:
            self.low_rank = False
            self._general()
        if pairs:
            nu, s = self.problem.pair_terms(np.array([i for i, _ in pairs]),
                                            np.array([j for _, j in pairs]))
            self.nu, self.s = np.concatenate([self.nu, nu]), np.concatenate([self.s, s])
        m = self.problem.observations.dim
        schur, residual, block, w_new = np.empty((m, m)), np.empty(m), np.empty((m, m)), \
            np.empty(m)
        nis = 0.0
        for i, j in pairs:
            a, l = int(self.position_of[j]), int(self.istate[NPAIRS])
            nis = _extend(len(self.ccols) + l, a, nis, l, self.nu, self.s, self.joint, self.lblk,
                          self.dinv, self.w, self.xc, self.xstamp, self.xvalid, self.lversion,
                          self.ploc, schur, residual, block, w_new)
            if nis < 0.0:
                raise ValueError('joint covariance of the initial pairs is not positive definite')
            _push(int(i), int(j), a, l, self.lblk, self.dinv, self.w, self.xc, self.lversion,
                  self.pobs, self.pcol, self.ploc, self.used, self.free, self.lptr, self.lpos,
                  block, w_new, self.istate)
            self.istate[NPAIRS] = l + 1
        l = int(self.istate[NPAIRS])
        if nis <= self.thresholds[l]:
            self.bobs[:l], self.bcol[:l] = self.pobs[:l], self.pcol[:l]
            self.istate[BEST_COUNT], self.fstate[0] = l, nis
        return nis

    def run(self, position: int = 0, nis: float = 0.0) -> None:
        """Search from `position` with the current pairs and joint NIS, reading the clock at
        the first node and then, when a deadline is set, after the nodes that fit in half the
        time left at the rate so far (at least PAUSE_EVERY): a search far inside its budget
        returns to Python (about 25 us a call) a few times instead of every PAUSE_EVERY nodes,
        one near its deadline every PAUSE_EVERY nodes."""
        state = self.istate
        state[POS] = state[START] = position
        state[STATUS] = RUNNING
        state[NEXT_PAUSE] = 1
        self.fstate[1] = nis
        pause = self.deadline is not None
        started, first_node = time.perf_counter(), int(state[NODES])
        while True:
            search(self.nu, self.s, self.joint, self.order, self.cptr, self.ccols, self.cloc,
                   self.lptr, self.lpos, self.thresholds, self.classic, self.nis_ties,
                   self.max_nodes, pause, self.lblk, self.dinv, self.w, self.xc, self.xstamp,
                   self.xvalid, self.lversion, self.pobs, self.pcol, self.ploc, self.used,
                   self.free, self.bobs, self.bcol, self.f_nis, self.f_c, self.f_stage, self.f_l,
                   state, self.fstate, self.low_rank, self.e_a, self.e_g, self.e_m, self.cum_a,
                   self.cum_g, self.cum_m)
            if state[STATUS] != PAUSED:
                return
            now = time.perf_counter()
            if now >= self.deadline:
                state[TRUNCATED] = 1
                return
            done = max(int(state[NODES]) - first_node, 1)
            fit = 0.5 * (self.deadline - now) * done / max(now - started, 1e-9)
            state[NEXT_PAUSE] = state[NODES] + max(PAUSE_EVERY, int(min(fit, 1e15)))


def _warm_up() -> None:
    from .joint_compatibility import _warm_up_problem
    _warm_up_problem()
    gated, start, columns = gated_candidates(np.array([[3.0, 1.0, 9.0], [1.0, 1.0, 0.5]]), 4.0)
    if start.tolist() != [0, 2, 5] or columns.tolist() != [1, 0, 2, 0, 1]:
        raise RuntimeError(f'gated_candidates warm-up: {start} {columns}')


KERNELS = Kernels(_warm_up)
"""The kernels' availability: compiled (or loaded from the on-disk cache) by searching a tiny
problem the first time it is asked."""


def available() -> bool:
    """True when numba imported and the kernels compiled: compiles them (or loads them from the
    on-disk cache) by searching a tiny problem at the first call; False (and the pure-Python
    search is used) when numba is missing or compilation fails."""
    return KERNELS.available()


def unavailable_reason() -> str:
    """Why the compiled search is not used ('' when it is)."""
    return KERNELS.unavailable_reason()
