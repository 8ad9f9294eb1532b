"""The numba kernels of the compiled joint compatibility search (jcbb_compiled.py says what they
compute); numba is optional (core/jit.py): without it the kernels are plain Python functions,
which jcbb_compiled does not use.
"""
from __future__ import annotations

import numpy as np

from ..jit import njit as _njit

PAUSE_EVERY = 64
"""Nodes between two clock readings by the caller when a deadline is set (0.05-0.3 ms)."""
RUNNING, DONE, PAUSED = 0, 1, 2
"""Kernel status (istate[STATUS])."""
# istate slots
POS, NPAIRS, BEST_COUNT, NODES, TRUNCATED, PENDING, START, STATUS, NEXT_PAUSE, VERSION = range(10)
ISTATE_SIZE = 10


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


@_njit
def gated_candidates(nis, threshold):
    """(gated (K, N): nis <= threshold, start (K + 1,), columns (E,)): row i's gated columns
    are columns[start[i]:start[i + 1]], sorted by NIS, ties by column (a stable insertion sort:
    numpy's stable argsort of the gated NIS)."""
    k, n = nis.shape
    gated = np.empty((k, n), dtype=np.bool_)
    start = np.zeros(k + 1, dtype=np.int64)
    columns = np.empty(k * n, dtype=np.int64)
    e = 0
    for i in range(k):
        first = e
        for j in range(n):
            value = nis[i, j]
            inside = value <= threshold
            gated[i, j] = inside
            if inside:
                q = e
                while q > first and nis[i, columns[q - 1]] > value:
                    columns[q] = columns[q - 1]
                    q -= 1
                columns[q] = j
                e += 1
        start[i + 1] = e
    return gated, start, columns[:e].copy()


@_njit
def search_layout(order, start, columns, n):
    """The search's index arrays for the observations `order` (k,) with candidate lists
    (start, columns) (CSR over K observations, landmark columns < n): cptr (k + 1,) and per
    entry (E = cptr[k]) ccols, rows (its observation) and cloc (its local landmark); local
    (L,): the landmarks that are anyone's candidate, position_of (n,): their local index (-1:
    none); lptr (L + 1,), lpos: the positions searching each local landmark (CSR, ascending)."""
    k = order.shape[0]
    cptr = np.zeros(k + 1, dtype=np.int64)
    for t in range(k):
        cptr[t + 1] = cptr[t] + start[order[t] + 1] - start[order[t]]
    total = cptr[k]
    ccols = np.empty(total, dtype=np.int64)
    rows = np.empty(total, dtype=np.int64)
    for t in range(k):
        i = order[t]
        for e in range(cptr[t], cptr[t + 1]):
            ccols[e] = columns[start[i] + e - cptr[t]]
            rows[e] = i
    position_of = np.full(n, -1, dtype=np.int64)
    for c in columns:
        position_of[c] = 0
    count = 0
    for j in range(n):
        if position_of[j] == 0:
            position_of[j] = count
            count += 1
    local = np.empty(count, dtype=np.int64)
    for j in range(n):
        if position_of[j] >= 0:
            local[position_of[j]] = j
    cloc = np.empty(total, dtype=np.int64)
    lptr = np.zeros(count + 1, dtype=np.int64)
    for e in range(total):
        cloc[e] = position_of[ccols[e]]
        lptr[cloc[e] + 1] += 1
    for a in range(count):
        lptr[a + 1] += lptr[a]
    fill = lptr[:count].copy()
    lpos = np.empty(total, dtype=np.int64)
    for t in range(k):
        for e in range(cptr[t], cptr[t + 1]):
            lpos[fill[cloc[e]]] = t
            fill[cloc[e]] += 1
    return cptr, ccols, rows, cloc, local, position_of, lptr, lpos
