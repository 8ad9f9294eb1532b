"""Compiled joint compatibility search (numba; optional: without numba, or when it fails to
compile, `available()` is False and joint_compatibility's pure-Python search runs).

The same depth-first branch and bound as joint_compatibility.JointCompatibilitySearch: the same
search order, pruning, tie rule, node count and budget semantics, hence the same answer.  Two
differences of implementation, neither of result:

* the recursion is an explicit per-position state (stage, next candidate, NIS, pairs on entry),
  so the search is resumable: with a deadline it returns to Python after its first node and
  then every PAUSE_EVERY nodes, and the caller reads the clock there (numba has no clock);
* it keeps the Cholesky factor L of the joint innovation covariance C_H (not L^-1) and, per
  candidate landmark a, the block rows X_a = L^-1 Cov(h_H, h_a) already computed, by forward
  substitution  X_a[t] = D_t^-1 (Cov(h_t, h_a) - sum_{q<t} L[t, q] X_a[q]).  A row depends on
  the pairs up to t only, so it is reused while they are unchanged (a version stamp per depth):
  one node costs O(l m^3) instead of O(l^2 m).  With X = X_a:  D = S_ij - X^T X,
  w_new = D_L^-1 (nu_ij - X^T w),  d2_new = d2 + |w_new|^2,  new block row of L = [X^T, D_L].

JIT compilation is cached on disk (numba cache=True) in NUMBA_CACHE_DIR when set, else beside
this module when its directory is writable, else in ~/.cache/data_association_ros/numba (or
$XDG_CACHE_HOME); `warm_up()` compiles (or loads) it ahead of the first search.
"""
from __future__ import annotations

import os
import tempfile
import time
from functools import lru_cache
from pathlib import Path
from typing import Optional

import numpy as np

from ..gating import chi2_threshold

PAUSE_EVERY = 256
"""Nodes between two clock readings by the caller when a deadline is set (about 0.1 ms)."""
RUNNING, DONE, PAUSED = 0, 1, 2
"""Kernel status (istate[STATUS])."""
# istate slots
POS, NPAIRS, BEST_COUNT, NODES, TRUNCATED, PENDING, START, STATUS, NEXT_PAUSE, VERSION = range(10)
ISTATE_SIZE = 10


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
        return True
    except OSError:
        return False


def _choose_cache_dir() -> None:
    """Set NUMBA_CACHE_DIR to a writable user cache directory when it is unset and this
    package's directory is read-only (an installed package); numba reads it at import."""
    if os.environ.get('NUMBA_CACHE_DIR'):
        return
    if _writable(Path(__file__).resolve().parent / '__pycache__'):
        return
    base = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache')
    for directory in (base / 'data_association_ros' / 'numba',
                      Path(tempfile.gettempdir()) / f'data_association_ros_numba_{os.getuid()}'):
        if _writable(directory):
            os.environ['NUMBA_CACHE_DIR'] = str(directory)
            return


_IMPORT_ERROR: Exception | None = None
if os.environ.get('DATA_ASSOCIATION_ROS_NO_JIT', '') not in ('', '0'):
    numba = None
    _IMPORT_ERROR = RuntimeError('DATA_ASSOCIATION_ROS_NO_JIT is set')
else:
    try:
        _choose_cache_dir()
        import numba
    except Exception as error:  # ImportError, or a numba that does not load here
        numba = None
        _IMPORT_ERROR = error


def _njit(function):
    return numba.njit(cache=True, nogil=True)(function) if numba is not None else function


@_njit
def _chol_inverse(matrix, out):
    """out = L^-1 for the Cholesky factor L of the SPD m x m `matrix` (closed form for m = 2,
    as joint_compatibility._inverse_cholesky); False when not positive definite."""
    m = matrix.shape[0]
    if m == 2:
        a = matrix[0, 0]
        if not a > 0.0:
            return False
        l00 = np.sqrt(a)
        l10 = matrix[1, 0] / l00
        d = matrix[1, 1] - l10 * l10
        if not d > 0.0:
            return False
        l11 = np.sqrt(d)
        out[0, 0] = 1.0 / l00
        out[0, 1] = 0.0
        out[1, 0] = -l10 / (l00 * l11)
        out[1, 1] = 1.0 / l11
        return True
    factor = np.zeros((m, m))
    for r in range(m):
        for c in range(r + 1):
            total = matrix[r, c]
            for q in range(c):
                total -= factor[r, q] * factor[c, q]
            if r == c:
                if not total > 0.0:
                    return False
                factor[r, r] = np.sqrt(total)
            else:
                factor[r, c] = total / factor[c, c]
    for c in range(m):  # forward substitution of L out = I, column by column
        for r in range(m):
            total = 1.0 if r == c else 0.0
            for q in range(r):
                total -= factor[r, q] * out[q, c]
            out[r, c] = total / factor[r, r]
    return True


@_njit
def _extend(e, a, nis, npairs, nu, s, joint, lblk, dinv, w, xc, xstamp, xvalid, lversion,
            ploc, schur, residual, block, w_new):
    """d2 after adding candidate pair e (innovation nu[e] (m,), S = s[e] (m, m), local
    landmark a) to the npairs current pairs, leaving the new diagonal inverse factor in `block`
    and the new whitened block in `w_new`; -1 when the joint covariance is not positive
    definite."""
    m = nu.shape[1]
    # the valid prefix of X_a: rows whose pairs have not changed since they were computed
    t0 = 0
    top = min(xvalid[a], npairs)
    while t0 < top and xstamp[a, t0] == lversion[t0]:
        t0 += 1
    for t in range(t0, npairs):
        for r in range(m):
            for c in range(m):
                total = joint[ploc[t], a, r, c]
                for q in range(t):
                    for u in range(m):
                        total -= lblk[t, q, r, u] * xc[a, q, u, c]
                schur[r, c] = total
        for r in range(m):
            for c in range(m):
                total = 0.0
                for u in range(m):
                    total += dinv[t, r, u] * schur[u, c]
                xc[a, t, r, c] = total
        xstamp[a, t] = lversion[t]
    if xvalid[a] < npairs:
        xvalid[a] = npairs
    for r in range(m):
        total = nu[e, r]
        for t in range(npairs):
            for u in range(m):
                total -= xc[a, t, u, r] * w[t, u]
        residual[r] = total
        for c in range(m):
            total = s[e, r, c]
            for t in range(npairs):
                for u in range(m):
                    total -= xc[a, t, u, r] * xc[a, t, u, c]
            schur[r, c] = total
    if not _chol_inverse(schur, block):
        return -1.0
    added = 0.0
    for r in range(m):
        total = 0.0
        for u in range(m):
            total += block[r, u] * residual[u]
        w_new[r] = total
        added += total * total
    return nis + added


@_njit
def _push(i, j, a, npairs, lblk, dinv, w, xc, lversion, pobs, pcol, ploc, used, free, lptr, lpos,
          block, w_new, istate):
    """Make (i, j, a) the pair at depth npairs: its block row of L, D^-1, w; mark a used."""
    m = w.shape[1]
    for q in range(npairs):
        for r in range(m):
            for c in range(m):
                lblk[npairs, q, r, c] = xc[a, q, c, r]
    for r in range(m):
        w[npairs, r] = w_new[r]
        for c in range(m):
            dinv[npairs, r, c] = block[r, c]
    istate[VERSION] += 1
    lversion[npairs] = istate[VERSION]
    pobs[npairs], pcol[npairs], ploc[npairs] = i, j, a
    used[a] = True
    for e in range(lptr[a], lptr[a + 1]):
        free[lpos[e]] -= 1


@_njit
def _release(a, used, free, lptr, lpos):
    used[a] = False
    for e in range(lptr[a], lptr[a + 1]):
        free[lpos[e]] += 1


@_njit
def _enters(position, nis, npairs, k, free, thresholds, istate, best_nis, nis_ties):
    """True when _search(position, nis) of the Python search gets past its pruning tests."""
    if istate[TRUNCATED]:
        return False
    upper = npairs
    if position < k:
        for t in range(position, k):
            if free[t] > 0:
                upper += 1
    best = istate[BEST_COUNT]
    if upper < best or (upper == best and (nis >= best_nis or not nis_ties)):
        return False
    if nis > thresholds[upper] or position == k:
        return False
    return True


@_njit
def _extend_low_rank(e, npairs, e_a, e_g, e_m, cum_a, cum_g, cum_m, g_new, m_new):
    """d2 after adding candidate entry e to the npairs current pairs when
    C_H = blockdiag(B_t) + G_H U U^T G_H^T (no state covariance: the pose is the only
    correlation; Woodbury): d2 = a - h^T (I + M)^-1 h with a = sum nu_t^T B_t^-1 nu_t,
    h = sum (G_t U)^T B_t^-1 nu_t, M = sum (G_t U)^T B_t^-1 G_t U; leaves h, M in g_new, m_new."""
    r = e_g.shape[1]
    for u in range(r):
        g_new[u] = cum_g[npairs, u] + e_g[e, u]
        for v in range(r):
            m_new[u, v] = cum_m[npairs, u, v] + e_m[e, u, v]
    factor = np.zeros((r, r))   # Cholesky factor of I + M (SPD)
    for u in range(r):
        for v in range(u + 1):
            total = m_new[u, v] + (1.0 if u == v else 0.0)
            for q in range(v):
                total -= factor[u, q] * factor[v, q]
            if u == v:
                if not total > 0.0:
                    return -1.0
                factor[u, u] = np.sqrt(total)
            else:
                factor[u, v] = total / factor[v, v]
    reduction = 0.0
    y = np.zeros(r)
    for u in range(r):
        total = g_new[u]
        for q in range(u):
            total -= factor[u, q] * y[q]
        y[u] = total / factor[u, u]
        reduction += y[u] * y[u]
    return max(cum_a[npairs] + e_a[e] - reduction, 0.0)


@_njit
def _push_low_rank(e, npairs, e_a, cum_a, cum_g, cum_m, g_new, m_new):
    """Make entry e the pair at depth npairs (low-rank sums)."""
    cum_a[npairs + 1] = cum_a[npairs] + e_a[e]
    cum_g[npairs + 1] = g_new
    cum_m[npairs + 1] = m_new


@_njit
def search(nu, s, joint, order, cptr, ccols, cloc, lptr, lpos, thresholds, classic, nis_ties,
           max_nodes, pause, lblk, dinv, w, xc, xstamp, xvalid, lversion, pobs, pcol, ploc, used,
           free, bobs, bcol, f_nis, f_c, f_stage, f_l, istate, fstate, low_rank, e_a, e_g, e_m,
           cum_a, cum_g, cum_m):
    """Run (or resume) the search; istate[STATUS] DONE when finished or truncated by
    max_nodes, PAUSED at node istate[NODES] (counted, not yet extended) when `pause`.
    low_rank: joint NIS from the per-entry sums e_a, e_g, e_m (_extend_low_rank), else from
    the Cholesky factor (_extend)."""
    m = nu.shape[1]
    k = order.shape[0]
    schur = np.empty((m, m))
    residual = np.empty(m)
    block = np.empty((m, m))
    w_new = np.empty(m)
    g_new = np.empty(e_g.shape[1])
    m_new = np.empty((e_g.shape[1], e_g.shape[1]))
    start = istate[START]
    pos = istate[POS]
    if istate[STATUS] == RUNNING:  # a fresh start: enter the root frame
        if not _enters(pos, fstate[1], istate[NPAIRS], k, free, thresholds, istate, fstate[0],
                       nis_ties):
            istate[STATUS] = DONE
            return
        f_nis[pos], f_c[pos], f_stage[pos], f_l[pos] = fstate[1], cptr[pos], 0, istate[NPAIRS]
    istate[STATUS] = RUNNING
    returned = False   # True: the frame at pos+1 has just returned to pos
    while True:
        if returned:
            returned = False
            l = f_l[pos]
            if f_stage[pos] == 1:
                _release(ploc[l], used, free, lptr, lpos)
                istate[NPAIRS] = l
                f_stage[pos] = 0
                if istate[TRUNCATED]:
                    break
            else:   # the skip branch returned: this frame returns too
                if pos == start:
                    break
                pos -= 1
                returned = True
                continue
        l = f_l[pos]
        i = order[pos]
        descended = False
        while f_c[pos] < cptr[pos + 1]:
            e = f_c[pos]
            a = cloc[e]
            if not istate[PENDING]:
                if used[a]:
                    f_c[pos] = e + 1
                    continue
                istate[NODES] += 1
                if max_nodes > 0 and istate[NODES] >= max_nodes:
                    istate[TRUNCATED] = 1
                    break
                if pause and istate[NODES] >= istate[NEXT_PAUSE]:
                    istate[PENDING] = 1
                    istate[POS] = pos
                    istate[STATUS] = PAUSED
                    return
            istate[PENDING] = 0
            f_c[pos] = e + 1
            j = ccols[e]
            if low_rank:
                new_nis = _extend_low_rank(e, l, e_a, e_g, e_m, cum_a, cum_g, cum_m, g_new,
                                           m_new)
            else:
                new_nis = _extend(e, a, f_nis[pos], l, nu, s, joint, lblk, dinv, w, xc,
                                  xstamp, xvalid, lversion, ploc, schur, residual, block, w_new)
            if new_nis < 0.0:
                continue
            passes = new_nis <= thresholds[l + 1]
            if passes and (l + 1 > istate[BEST_COUNT] or (
                    nis_ties and l + 1 == istate[BEST_COUNT] and new_nis < fstate[0])):
                for t in range(l):
                    bobs[t], bcol[t] = pobs[t], pcol[t]
                bobs[l], bcol[l] = i, j
                istate[BEST_COUNT] = l + 1
                fstate[0] = new_nis
            if passes or not classic:
                if low_rank:
                    _push_low_rank(e, l, e_a, cum_a, cum_g, cum_m, g_new, m_new)
                    pobs[l], pcol[l], ploc[l] = i, j, a
                    used[a] = True
                    for q in range(lptr[a], lptr[a + 1]):
                        free[lpos[q]] -= 1
                else:
                    _push(i, j, a, l, lblk, dinv, w, xc, lversion, pobs, pcol, ploc, used,
                          free, lptr, lpos, block, w_new, istate)
                istate[NPAIRS] = l + 1
                f_stage[pos] = 1
                if _enters(pos + 1, new_nis, l + 1, k, free, thresholds, istate, fstate[0],
                           nis_ties):
                    pos += 1
                    f_nis[pos], f_c[pos], f_stage[pos], f_l[pos] = new_nis, cptr[pos], 0, l + 1
                    descended = True
                    break
                _release(a, used, free, lptr, lpos)
                istate[NPAIRS] = l
                f_stage[pos] = 0
            if istate[TRUNCATED]:
                break
        if istate[TRUNCATED]:
            break
        if descended:
            continue
        # the candidates are done: the branch without a pair for this observation
        f_stage[pos] = 2
        if _enters(pos + 1, f_nis[pos], l, k, free, thresholds, istate, fstate[0], nis_ties):
            pos += 1
            f_nis[pos], f_c[pos], f_stage[pos], f_l[pos] = f_nis[pos - 1], cptr[pos], 0, l
            continue
        if pos == start:
            break
        pos -= 1
        returned = True
    istate[POS] = pos
    istate[STATUS] = DONE


@_njit
def _joint_blocks(h_x, h_m, state_covariance, local, out):
    """out[a, b] = Cov(h_local[a], h_local[b]) = A_a P[i_a, i_b] A_b^T (L, L, m, m) with
    A = [dh/dpose, dh/dlandmark] (m, 3 + d) and i_a = the pose's and landmark a's rows of the
    state covariance P ((3 + N d) square)."""
    count, m, d = local.shape[0], h_x.shape[1], h_m.shape[2]
    width = 3 + d
    jac = np.zeros((count, m, width))
    rows = np.zeros((count, width), dtype=np.int64)
    for a in range(count):
        for r in range(m):
            for c in range(3):
                jac[a, r, c] = h_x[local[a], r, c]
            for c in range(d):
                jac[a, r, 3 + c] = h_m[local[a], r, c]
        for c in range(3):
            rows[a, c] = c
        for c in range(d):
            rows[a, 3 + c] = 3 + local[a] * d + c
    size = state_covariance.shape[0]
    left = np.zeros((m, size))
    for a in range(count):
        left[:] = 0.0   # left = A_a P[i_a, :]
        for r in range(m):
            for q in range(width):
                coefficient = jac[a, r, q]
                row = rows[a, q]
                for c in range(size):
                    left[r, c] += coefficient * state_covariance[row, c]
        for b in range(count):
            for r in range(m):
                for c in range(m):
                    total = 0.0
                    for q in range(width):
                        total += left[r, rows[b, q]] * jac[b, c, q]
                    out[a, b, r, c] = total


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


def pair_terms(problem, rows: np.ndarray, columns: np.ndarray):
    """(nu (E, m), S (E, m, m)) of the pairs (rows[e], columns[e]): the problem's innovations
    and innovation covariances H P H^T + R floored at min_innovation_variance, for these pairs
    only."""
    s = problem.prediction_covariances[columns] + problem.observations.covariances[rows]
    if problem.min_innovation_variance > 0:
        diagonal = np.einsum('...ii->...i', s)
        diagonal[...] = np.maximum(diagonal, problem.min_innovation_variance)
    return np.ascontiguousarray(problem.innovations[rows, columns]), s


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
    nu = problem.innovations[rows, columns]
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

    def __init__(self, problem, gate_probability: float, candidates: list[np.ndarray],
                 order: list[int], deadline: Optional[float], max_nodes: int,
                 classic: bool = False, nis_ties: bool = True) -> None:
        m = problem.observations.dim
        self.problem = problem
        k, most = len(order), len(candidates)
        self.order = np.asarray(order, dtype=np.int64)
        sizes = np.fromiter((len(candidates[i]) for i in order), dtype=np.int64, count=k)
        self.cptr = np.zeros(k + 1, dtype=np.int64)
        np.cumsum(sizes, out=self.cptr[1:])
        self.ccols = np.concatenate([candidates[i] for i in order]).astype(np.int64) if k \
            else np.zeros(0, dtype=np.int64)
        marked = np.zeros(problem.sizes[1], dtype=np.int64)
        if most:   # every candidate landmark (start_from's pairs too)
            marked[np.concatenate(candidates).astype(np.intp)] = 1
        self.local = np.flatnonzero(marked)
        count = len(self.local)
        self.position_of = np.cumsum(marked) - 1    # local index of each marked landmark
        self.cloc = self.position_of[self.ccols]
        # positions searching each local landmark (CSR by landmark)
        positions = np.repeat(np.arange(k, dtype=np.int64), sizes)
        self.lpos = positions[np.argsort(self.cloc, kind='stable')]
        self.lptr = np.zeros(count + 1, dtype=np.int64)
        np.cumsum(np.bincount(self.cloc, minlength=count), out=self.lptr[1:])
        self.thresholds = _thresholds(gate_probability, m, most)
        self.classic, self.nis_ties = bool(classic), bool(nis_ties)
        self.max_nodes, self.deadline = int(max_nodes), deadline
        self.depth = depth = max(most, 1)
        self.pobs, self.pcol, self.ploc, self.bobs, self.bcol = np.zeros((5, depth),
                                                                         dtype=np.int64)
        self.used = np.zeros(count, dtype=np.bool_)
        self.free = sizes
        self.f_nis = np.zeros(k + 1)
        self.f_c, self.f_stage, self.f_l = np.zeros((3, k + 1), dtype=np.int64)
        self.istate = np.zeros(ISTATE_SIZE, dtype=np.int64)
        self.fstate = np.zeros(2)   # best NIS, NIS at the root
        self.rows = self.order[positions]    # the observation of each candidate entry
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
            pair_terms(problem, self.rows, self.ccols)
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
            nu, s = pair_terms(self.problem, np.array([i for i, _ in pairs]),
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
        the first node and every PAUSE_EVERY nodes when a deadline is set."""
        state = self.istate
        state[POS] = state[START] = position
        state[STATUS] = RUNNING
        state[NEXT_PAUSE] = 1
        self.fstate[1] = nis
        pause = self.deadline is not None
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
            if time.perf_counter() >= self.deadline:
                state[TRUNCATED] = 1
                return
            state[NEXT_PAUSE] = state[NODES] + PAUSE_EVERY


_COMPILE_ERROR: Exception | None = None


def available() -> bool:
    """True when numba imported and the kernel compiled (compiling or loading it now if
    needed: see warm_up)."""
    return numba is not None and warm_up()


_WARM = False


def warm_up() -> bool:
    """Compile (or load from the on-disk cache) the kernel by searching a tiny problem; False
    (and the pure-Python search is used) when numba is missing or compilation fails."""
    global _WARM, _COMPILE_ERROR, numba
    if _WARM or numba is None:
        return _WARM
    try:
        from .joint_compatibility import _warm_up_problem
        _warm_up_problem()
        _WARM = True
    except Exception as error:  # a numba/llvmlite that cannot compile here
        _COMPILE_ERROR = error
        numba = None
    return _WARM


def unavailable_reason() -> str:
    """Why the compiled search is not used ('' when it is)."""
    error = _COMPILE_ERROR or _IMPORT_ERROR
    return '' if error is None else f'{type(error).__name__}: {error}'
