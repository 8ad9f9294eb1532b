"""Compiled (numba) forms of AssociationProblem's per-scan arithmetic (core/problem.py defines
each quantity and keeps the numpy form, used without numba and inside jit.compiled(False)):

* range_bearing_predict: the range-bearing model's predictions and Jacobians;
* range_bearing_in_map: range-bearing observations in the map frame with their covariances;
* prediction_covariances: H_j P_j H_j^T (N, m, m), P_j the covariance of [pose, landmark j];
* nis_2d: d2_ij (K, N) for m = 2 from the observations and predictions, angular components
  wrapped, S_ij = H_j P_j H_j^T + R_i (diagonal floored), without the (K, N, m) innovations;
* range_bearing_nis: the three above for range-bearing observations in one call;
* pair_terms: nu and S of chosen pairs only (the JCBB search's candidates);
* is_covariance_matrix, are_spd_2x2: the checks of a joint covariance and of 2 x 2 covariance
  stacks on arrival;
* first_indefinite_block: the first landmark whose [pose, landmark] block of a joint covariance
  is not positive semi-definite (check_definite);
* observations_2d: 2-D observations and their R from the float32 words of a point cloud,
  checked as Observations checks them;
* nearest_within: each row's first smallest NIS and its landmark id, inside a bound;
* gnn_split: gnn's pairs alone in their row and column, and the cost matrix of the others;
* label_columns: the assignment and NIS of chosen columns (associators.base.result).

One pass over the data each instead of a few dozen numpy calls of 1-10 us; the arithmetic is
numpy's (same formulas, same order within nis_2d; the 3 x 3 products may round differently).
"""
from __future__ import annotations

from functools import lru_cache
from typing import Optional

import numpy as np

from .jit import Kernels, njit

TWO_PI = 2.0 * np.pi
INV_TWO_PI = 1.0 / TWO_PI


@njit
def prediction_covariances(h_x, h_m, pose_covariance, landmark_covariances, state, out):
    """out[j] = A_j P_j A_j^T (N, m, m), A_j = [h_x[j] (m, 3), h_m[j] (m, d)]; P_j is the
    block of [pose, landmark j] of `state` ((3 + N d) square) when it has rows, else
    blockdiag(pose_covariance (3, 3), landmark_covariances[j] (d, d))."""
    _, m, d = h_m.shape
    if m == 2 and d == 2:   # constant sizes: the small loops unroll (2x faster, same sums)
        _prediction_covariances(h_x, h_m, pose_covariance, landmark_covariances, state, out, 2, 2)
    else:
        _prediction_covariances(h_x, h_m, pose_covariance, landmark_covariances, state, out, m, d)


@njit
def _prediction_covariances(h_x, h_m, pose_covariance, landmark_covariances, state, out, m, d):
    """prediction_covariances for m-dimensional measurements of d-dimensional landmarks."""
    n = h_m.shape[0]
    width = 3 + d
    joint = state.shape[0] > 0
    block = np.zeros((width, width))
    left = np.empty((m, width))
    if not joint:
        for a in range(3):
            for b in range(3):
                block[a, b] = pose_covariance[a, b]
    for j in range(n):
        if joint:
            for a in range(width):
                row = a if a < 3 else 3 + j * d + a - 3
                for b in range(width):
                    block[a, b] = state[row, b if b < 3 else 3 + j * d + b - 3]
        else:
            for a in range(d):
                for b in range(d):
                    block[3 + a, 3 + b] = landmark_covariances[j, a, b]
        for r in range(m):
            for c in range(width):
                total = 0.0
                for q in range(3):
                    total += h_x[j, r, q] * block[q, c]
                for q in range(d):
                    total += h_m[j, r, q] * block[3 + q, c]
                left[r, c] = total
        for r in range(m):
            for c in range(m):
                total = 0.0
                for q in range(3):
                    total += left[r, q] * h_x[j, c, q]
                for q in range(d):
                    total += left[r, 3 + q] * h_m[j, c, q]
                out[j, r, c] = total


@njit
def _wrap(angle):
    """wrap_angle (models/base.py) of one angle: a - 2 pi floor((a + pi) / (2 pi)), then one
    turn added or taken where rounding left it outside (-pi, pi]."""
    wrapped = angle - TWO_PI * np.floor((angle + np.pi) * INV_TWO_PI)
    if wrapped <= -np.pi:
        wrapped += TWO_PI
    if wrapped > np.pi:
        wrapped -= TWO_PI
    return wrapped


@njit
def _at_least(value, low):
    """np.maximum(value, low) of one value: NaN stays NaN (Python's max would return low)."""
    return low if value < low else value


@njit
def range_bearing_predict(means, pose, h, h_landmark, h_pose):
    """RangeBearingModel.predict (models/range_bearing.py) into h (N, 2), h_landmark (N, 2, 2)
    and h_pose (N, 2, 3) for landmark means (N, 2) and pose (3,)."""
    for j in range(means.shape[0]):
        dx = means[j, 0] - pose[0]
        dy = means[j, 1] - pose[1]
        q = _at_least(dx * dx + dy * dy, 1e-18)
        r = np.sqrt(q)
        h[j, 0] = r
        h[j, 1] = _wrap(np.arctan2(dy, dx) - pose[2])
        h_landmark[j, 0, 0] = dx / r
        h_landmark[j, 0, 1] = dy / r
        h_landmark[j, 1, 0] = -dy / q
        h_landmark[j, 1, 1] = dx / q
        h_pose[j, 0, 0] = -h_landmark[j, 0, 0]
        h_pose[j, 0, 1] = -h_landmark[j, 0, 1]
        h_pose[j, 0, 2] = 0.0
        h_pose[j, 1, 0] = -h_landmark[j, 1, 0]
        h_pose[j, 1, 1] = -h_landmark[j, 1, 1]
        h_pose[j, 1, 2] = -1.0


@njit
def range_bearing_in_map(values, pose, r, pose_covariance, positions, covariances):
    """RangeBearingModel.in_map (models/range_bearing.py) into positions (K, 2) and covariances
    (K, 2, 2): for z_i = (range, bearing) with R_i = r[i] at pose (3,) of covariance
    pose_covariance (3, 3), x_i = t + range (cos a, sin a), a = yaw + bearing, and
    (G_z R_i) G_z^T + (G_pose P) G_pose^T, each product summed in numpy's order."""
    g_z = np.empty((2, 2))
    g_pose = np.zeros((2, 3))
    g_pose[0, 0] = g_pose[1, 1] = 1.0
    for i in range(values.shape[0]):
        distance = values[i, 0]
        angle = pose[2] + values[i, 1]
        c, s = np.cos(angle), np.sin(angle)
        positions[i, 0] = pose[0] + distance * c
        positions[i, 1] = pose[1] + distance * s
        g_z[0, 0], g_z[0, 1], g_z[1, 0], g_z[1, 1] = c, -distance * s, s, distance * c
        g_pose[0, 2], g_pose[1, 2] = -distance * s, distance * c
        for a in range(2):
            for b in range(2):
                noise = 0.0
                for p in range(2):
                    left = 0.0
                    for q in range(2):
                        left += g_z[a, q] * r[i, q, p]
                    noise += left * g_z[b, p]
                motion = 0.0
                for p in range(3):
                    left = 0.0
                    for q in range(3):
                        left += g_pose[a, q] * pose_covariance[q, p]
                    motion += left * g_pose[b, p]
                covariances[i, a, b] = noise + motion


@njit
def nis_2d(values, predictions, angular, prediction_covariances, r, shared, floor, out):
    """out[i, j] = nu^T S^-1 nu (K, N) with nu = values[i] - predictions[j] ((K, 2), (N, 2);
    component c wrapped when angular[c]) and S = prediction_covariances[j] + r[0 if shared
    else i], its diagonal raised to `floor`; inf where det S <= 0 or the value is not finite
    or negative (problem.nis_2d's closed form, term by term: with a shared R the coefficients
    s_11 / det, -2 s_01 / det, s_00 / det are formed once per landmark, as numpy does)."""
    k, n = out.shape
    pairs = 1 if shared else k
    c0 = np.empty((pairs, n))
    c1 = np.empty((pairs, n))
    c2 = np.empty((pairs, n))
    for i in range(pairs):
        for j in range(n):
            s00 = _at_least(prediction_covariances[j, 0, 0] + r[i, 0, 0], floor)
            s01 = prediction_covariances[j, 0, 1] + r[i, 0, 1]
            s11 = _at_least(prediction_covariances[j, 1, 1] + r[i, 1, 1], floor)
            det = s00 * s11 - s01 * s01
            scale = 1.0 / det if det > 0 else np.nan
            c0[i, j] = s11 * scale
            c1[i, j] = -2.0 * s01 * scale
            c2[i, j] = s00 * scale
    # the loop invariants in locals and the predictions by component: the inner loop vectorises
    wrap_0, wrap_1 = angular[0], angular[1]
    h_0, h_1 = predictions[:, 0].copy(), predictions[:, 1].copy()
    for i in range(k):
        row = 0 if shared else i
        z_0, z_1 = values[i, 0], values[i, 1]
        w_0, w_1, w_2, d2_row = c0[row], c1[row], c2[row], out[i]
        for j in range(n):
            a = z_0 - h_0[j]
            b = z_1 - h_1[j]
            if wrap_0:
                a = _wrap(a)
            if wrap_1:
                b = _wrap(b)
            d2 = a * a * w_0[j]
            d2 += a * b * w_1[j]
            d2 += b * b * w_2[j]
            d2_row[j] = d2 if d2 < np.inf and d2 >= 0 else np.inf


@njit
def _all_equal(matrices):
    """True when every matrix of the stack (K, m, m) equals the first (problem._one_noise)."""
    for k in range(1, matrices.shape[0]):
        for a in range(matrices.shape[1]):
            for b in range(matrices.shape[2]):
                if matrices[k, a, b] != matrices[0, a, b]:
                    return False
    return True


@njit
def range_bearing_nis(means, pose, pose_covariance, landmark_covariances, state, values,
                      angular, r, floor, h, h_landmark, h_pose, prediction_covs, out):
    """range_bearing_predict, prediction_covariances and nis_2d (shared when every R is the
    same) in one call, one dispatch at a scan instead of three: the predictions into h,
    h_landmark, h_pose, their covariances into prediction_covs and the NIS of every pair into
    out (K >= 1)."""
    range_bearing_predict(means, pose, h, h_landmark, h_pose)
    prediction_covariances(h_pose, h_landmark, pose_covariance, landmark_covariances, state,
                           prediction_covs)
    nis_2d(values, h, angular, prediction_covs, r, _all_equal(r), floor, out)


@njit
def pair_terms(values, predictions, angular, prediction_covariances, r, floor, rows, columns,
               nu, s):
    """nu[e] = values[i] - predictions[j] (angular components wrapped) and s[e] =
    prediction_covariances[j] + r[i], its diagonal raised to `floor`, for the pairs
    (i, j) = (rows[e], columns[e])."""
    m = values.shape[1]
    for e in range(rows.shape[0]):
        i = rows[e]
        j = columns[e]
        for c in range(m):
            value = values[i, c] - predictions[j, c]
            nu[e, c] = _wrap(value) if angular[c] else value
            for b in range(m):
                total = prediction_covariances[j, c, b] + r[i, c, b]
                s[e, c, b] = _at_least(total, floor) if b == c else total


@njit
def is_covariance_matrix(matrix):
    """True when the square `matrix` is finite, symmetric within 1e-9 (1 + max |entry|) and
    has no negative diagonal entry (validation.check_covariance_matrix's tests in one pass)."""
    n = matrix.shape[0]
    largest = 0.0
    for a in range(n):
        for b in range(n):
            value = matrix[a, b]
            if not np.isfinite(value):
                return False
            largest = max(largest, abs(value))
        if matrix[a, a] < 0:
            return False
    tolerance = 1e-9 * (1.0 + largest)
    for a in range(n):
        for b in range(a):
            if abs(matrix[a, b] - matrix[b, a]) > tolerance:
                return False
    return True


@njit
def _is_spd_2x2(a, b, b_t, c):
    """True when [[a, b], [b_t, c]] is finite, symmetric within 1e-9 and has its smaller
    eigenvalue (a + c) / 2 - hypot((a - c) / 2, b) above 1e-12, both relative to 1 + max |entry|
    (validation.check_spd's tests; the eigenvalue of the matrix divided by that scale, so that
    no sum overflows)."""
    if not (np.isfinite(a) and np.isfinite(b) and np.isfinite(b_t) and np.isfinite(c)):
        return False
    scale = 1.0 + max(max(abs(a), abs(b)), max(abs(b_t), abs(c)))
    if abs(b - b_t) > 1e-9 * scale:
        return False
    a, b, c = a / scale, b / scale, c / scale
    return 0.5 * (a + c) - np.hypot(0.5 * (a - c), b) > 1e-12


@njit
def are_spd_2x2(matrices):
    """True when every matrix of the (n, 2, 2) stack passes _is_spd_2x2 (validation.check_spd's
    tests in one pass)."""
    for k in range(matrices.shape[0]):
        if not _is_spd_2x2(matrices[k, 0, 0], matrices[k, 0, 1], matrices[k, 1, 0],
                           matrices[k, 1, 1]):
            return False
    return True


@njit
def observations_2d(words, columns, fallback, values, covariances):
    """values (K, 2) = words[:, columns[0:2]] and R (K, 2, 2) = [[w[c2], w[c3]], [w[c3], w[c4]]]
    (w[c3] = 0 when columns[3] < 0; `fallback` for every R when columns[2] < 0), as float64,
    from float32 words (K, W); returns the first k whose values are not finite or whose R fails
    _is_spd_2x2 (Observations' checks), -1 when none."""
    first = -1
    for k in range(words.shape[0]):
        v0 = np.float64(words[k, columns[0]])
        v1 = np.float64(words[k, columns[1]])
        values[k, 0] = v0
        values[k, 1] = v1
        if columns[2] >= 0:
            a = np.float64(words[k, columns[2]])
            b = np.float64(words[k, columns[3]]) if columns[3] >= 0 else 0.0
            b_t = b
            c = np.float64(words[k, columns[4]])
        else:
            a, b, b_t, c = fallback[0, 0], fallback[0, 1], fallback[1, 0], fallback[1, 1]
        covariances[k, 0, 0] = a
        covariances[k, 0, 1] = b
        covariances[k, 1, 0] = b_t
        covariances[k, 1, 1] = c
        if first < 0 and not (np.isfinite(v0) and np.isfinite(v1)
                              and _is_spd_2x2(a, b, b_t, c)):
            first = k
    return first


@njit
def nearest_within(nis, bound, ids, new, assignment, smallest_nis):
    """Per row k of nis (K, N >= 1): its first smallest entry j (numpy's argmin; nis holds no
    NaN); assignment[k] = ids[j] and smallest_nis[k] = nis[k, j] when that is at most `bound`,
    else `new` and NaN."""
    for k in range(nis.shape[0]):
        best = 0
        smallest = nis[k, 0]
        for j in range(1, nis.shape[1]):
            if nis[k, j] < smallest:
                smallest = nis[k, j]
                best = j
        if smallest <= bound:
            assignment[k] = ids[best]
            smallest_nis[k] = smallest
        else:
            assignment[k] = new
            smallest_nis[k] = np.nan


@njit
def gnn_split(nis, gate, columns):
    """gnn's decomposition of nis (K, N) gated at `gate`: columns[k] = j for each gated pair
    (k, j) alone in its row and its column (else -1); returns (rows (R,), shared (S,), cost
    (R, S + R)): the rows and columns of the other gated pairs, ascending, and the Hungarian
    method's matrix over them (their NIS, inf where not gated, `gate` on the diagonal of the
    last R columns: each row's 'unpaired' column)."""
    k, n = nis.shape
    row_count = np.zeros(k, dtype=np.int64)
    row_first = np.zeros(k, dtype=np.int64)     # the first gated column of each row
    column_count = np.zeros(n, dtype=np.int64)
    for i in range(k):
        for j in range(n):
            if nis[i, j] <= gate:
                if row_count[i] == 0:
                    row_first[i] = j
                row_count[i] += 1
                column_count[j] += 1
    row_index = np.full(k, -1, dtype=np.int64)
    column_index = np.full(n, -1, dtype=np.int64)
    for i in range(k):   # only the rows with two or more gated pairs are read again
        columns[i] = -1
        if row_count[i] == 1:
            j = row_first[i]
            if column_count[j] == 1:
                columns[i] = j
            else:
                row_index[i] = 0
                column_index[j] = 0
        elif row_count[i] > 1:
            row_index[i] = 0
            for j in range(n):
                if nis[i, j] <= gate:
                    column_index[j] = 0
    rows = np.flatnonzero(row_index >= 0)
    shared = np.flatnonzero(column_index >= 0)
    for r in range(rows.shape[0]):
        row_index[rows[r]] = r
    for s in range(shared.shape[0]):
        column_index[shared[s]] = s
    count = rows.shape[0]
    cost = np.full((count, shared.shape[0] + count), np.inf)
    for r in range(count):
        i = rows[r]
        for j in range(n):
            if nis[i, j] <= gate and column_index[j] >= 0:
                cost[r, column_index[j]] = nis[i, j]
        cost[r, shared.shape[0] + r] = gate
    return rows, shared, cost


@njit
def label_columns(nis, columns, rows, shared, picked_rows, picked, ids, gate, new, unassociated,
                  assignment, chosen_nis):
    """columns (K,) completed by the Hungarian method's answer on gnn_split's cost matrix
    (picked_rows[e] paired with column picked[e]: row rows[picked_rows[e]] takes landmark
    shared[picked[e]] when picked[e] < len(shared)); then assignment[k] = ids[columns[k]] and
    chosen_nis[k] = nis[k, columns[k]] where columns[k] >= 0, else UNASSOCIATED when a NIS of
    row k is at most `gate` (gated), NEW when none is, and NaN."""
    for e in range(picked_rows.shape[0]):
        if picked[e] < shared.shape[0]:
            columns[rows[picked_rows[e]]] = shared[picked[e]]
    for k in range(nis.shape[0]):
        column = columns[k]
        if column >= 0:
            assignment[k] = ids[column]
            chosen_nis[k] = nis[k, column]
            continue
        assignment[k] = new
        chosen_nis[k] = np.nan
        for j in range(nis.shape[1]):
            if nis[k, j] <= gate:
                assignment[k] = unassociated
                break


@njit
def first_indefinite_block(state, n, d):
    """The first j < n whose block of [pose (3), landmark j (d)] of `state` ((3 + n d) square)
    is not positive semi-definite, -1 when none: Cholesky of the block plus 2e-9 (1 + max |entry|)
    on the diagonal, as validation.check_positive_semidefinite."""
    width = 3 + d
    block = np.empty((width, width))
    factor = np.zeros((width, width))
    for j in range(n):
        largest = 0.0
        for a in range(width):
            row = a if a < 3 else 3 + j * d + a - 3
            for b in range(width):
                value = state[row, b if b < 3 else 3 + j * d + b - 3]
                block[a, b] = value
                largest = max(largest, abs(value))
        jitter = 2e-9 * (1.0 + largest)
        for a in range(width):
            for b in range(a + 1):
                total = block[a, b] + (jitter if a == b else 0.0)
                for q in range(b):
                    total -= factor[a, q] * factor[b, q]
                if a == b:
                    if not total > 0.0:
                        return j
                    factor[a, a] = np.sqrt(total)
                else:
                    factor[a, b] = total / factor[b, b]
    return -1


def _read_only(array, dtype=np.float64) -> np.ndarray:
    """`array` when it is a read-only C-contiguous `dtype` array (the core's types store theirs
    so), else a read-only C-contiguous view of it as `dtype` (a copy only when it is not
    C-contiguous `dtype`)."""
    if type(array) is np.ndarray and array.dtype == dtype and not array.flags.writeable \
            and array.flags.c_contiguous:
        return array
    view = np.ascontiguousarray(array, dtype=dtype).view()
    view.flags.writeable = False
    return view


# Every input goes to a kernel as a read-only C-contiguous view (_read_only), every output is a
# fresh array, so numba compiles one version of each kernel, in _warm_up, and never at a scan.
_NO_STATE = _read_only(np.zeros((0, 0)))
_ZERO_POSE = _read_only(np.zeros((3, 3)))


@lru_cache(maxsize=16)
def _angular_flags(m: int, angular: tuple[int, ...]) -> np.ndarray:
    """(m,) bool, True at the angular components."""
    return _read_only([c in angular for c in range(m)], np.bool_)


def _floor(min_variance: float) -> float:
    """The kernels' floor on S's diagonal: min_variance, -inf when it is 0 (no floor)."""
    return float(min_variance) if min_variance > 0 else -np.inf


def run_range_bearing_predict(means: np.ndarray, pose: np.ndarray
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(h (N, 2), dh/dm (N, 2, 2), dh/dpose (N, 2, 3)) by range_bearing_predict."""
    n = means.shape[0]
    out = np.empty((n, 2)), np.empty((n, 2, 2)), np.empty((n, 2, 3))
    range_bearing_predict(_read_only(means), _read_only(pose), *out)
    return out


def run_range_bearing_in_map(values: np.ndarray, covariances: np.ndarray, pose: np.ndarray,
                             pose_covariance: Optional[np.ndarray]
                             ) -> tuple[np.ndarray, np.ndarray]:
    """(positions (K, 2), covariances (K, 2, 2)) by range_bearing_in_map for measurements
    (K, 2) with covariances (K, 2, 2) at pose (3,) of covariance (3, 3) (None: no pose term)."""
    count = values.shape[0]
    out = np.empty((count, 2)), np.empty((count, 2, 2))
    range_bearing_in_map(_read_only(values), _read_only(pose), _read_only(covariances),
                         _ZERO_POSE if pose_covariance is None else _read_only(pose_covariance),
                         *out)
    return out


def run_prediction_covariances(h_x: np.ndarray, h_m: np.ndarray, pose_covariance: np.ndarray,
                               landmark_covariances: Optional[np.ndarray],
                               state: Optional[np.ndarray]) -> np.ndarray:
    """prediction_covariances (N, m, m) from h_x (N, m, 3), h_m (N, m, d) and either the joint
    covariance `state` or the pose covariance (3, 3) and Cov(m_j) (N, d, d)."""
    n, m, d = h_m.shape
    out = np.empty((n, m, m))
    prediction_covariances(_read_only(h_x), _read_only(h_m),
                           *_covariance_inputs(pose_covariance, landmark_covariances, state, d),
                           out)
    return out


def _covariance_inputs(pose_covariance: np.ndarray, landmark_covariances: Optional[np.ndarray],
                       state: Optional[np.ndarray], d: int) -> tuple[np.ndarray, ...]:
    """(pose covariance, landmark covariances, joint covariance) as prediction_covariances reads
    them: the joint covariance and stand-ins for the others when it is given, else the pose's
    and landmarks' covariances and an empty joint one."""
    if state is not None:
        return _ZERO_POSE, _read_only(np.zeros((0, d, d))), _read_only(state)
    return _read_only(pose_covariance), _read_only(landmark_covariances), _NO_STATE


def run_range_bearing_nis(means: np.ndarray, pose: np.ndarray, pose_covariance: np.ndarray,
                          landmark_covariances: Optional[np.ndarray], state: Optional[np.ndarray],
                          values: np.ndarray, r: np.ndarray, floor: float
                          ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], np.ndarray,
                                     np.ndarray]:
    """((h (N, 2), dh/dm (N, 2, 2), dh/dpose (N, 2, 3)), H P H^T (N, 2, 2), nis (K, N)) by
    range_bearing_nis for landmark means (N, 2), pose (3,), the covariances as for
    run_prediction_covariances and K >= 1 observations (K, 2) with R (K, 2, 2); floor <= 0:
    none."""
    n = means.shape[0]
    prediction = np.empty((n, 2)), np.empty((n, 2, 2)), np.empty((n, 2, 3))
    covariances, nis = np.empty((n, 2, 2)), np.empty((values.shape[0], n))
    range_bearing_nis(_read_only(means), _read_only(pose),
                      *_covariance_inputs(pose_covariance, landmark_covariances, state, 2),
                      _read_only(values), _angular_flags(2, (1,)), _read_only(r),
                      _floor(floor), *prediction, covariances, nis)
    return prediction, covariances, nis


def run_nis_2d(values: np.ndarray, predictions: np.ndarray, angular: tuple[int, ...],
               prediction_covs: np.ndarray, r: np.ndarray, shared: bool,
               floor: float) -> np.ndarray:
    """nis_2d (K, N) for values (K, 2), predictions (N, 2), the angular components' indices,
    H P H^T (N, 2, 2) and R (K, 2, 2) (shared: every R is r[0]); floor <= 0: none."""
    out = np.empty((values.shape[0], predictions.shape[0]))
    nis_2d(_read_only(values), _read_only(predictions), _angular_flags(2, angular),
           _read_only(prediction_covs), _read_only(r), bool(shared), _floor(floor), out)
    return out


def run_pair_terms(values: np.ndarray, predictions: np.ndarray, angular: tuple[int, ...],
                   prediction_covs: np.ndarray, r: np.ndarray, floor: float, rows: np.ndarray,
                   columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(nu (E, m), S (E, m, m)) of the pairs (rows[e], columns[e]) by pair_terms; floor <= 0:
    none."""
    count, m = len(rows), values.shape[1]
    nu, s = np.empty((count, m)), np.empty((count, m, m))
    pair_terms(_read_only(values), _read_only(predictions), _angular_flags(m, angular),
               _read_only(prediction_covs), _read_only(r), _floor(floor),
               _read_only(rows, np.int64), _read_only(columns, np.int64), nu, s)
    return nu, s


def run_is_covariance_matrix(matrix: np.ndarray) -> bool:
    """is_covariance_matrix of a square float64 matrix."""
    return bool(is_covariance_matrix(_read_only(matrix)))


def run_are_spd_2x2(matrices: np.ndarray) -> bool:
    """are_spd_2x2 of a float64 (n, 2, 2) stack."""
    return bool(are_spd_2x2(_read_only(matrices)))


def run_observations_2d(words: np.ndarray, columns: np.ndarray, fallback: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, int]:
    """(values (K, 2), R (K, 2, 2), first bad k or -1) by observations_2d from float32 words
    (K, W), the 5 word indices `columns` (int64) and the fallback R (2, 2)."""
    count = words.shape[0]
    values, covariances = np.empty((count, 2)), np.empty((count, 2, 2))
    first = observations_2d(_read_only(words, np.float32), _read_only(columns, np.int64),
                            _read_only(fallback), values, covariances)
    return values, covariances, int(first)


def run_nearest_within(nis: np.ndarray, bound: float, ids: np.ndarray, new: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(assignment (K,) int64, NIS of the pair or NaN (K,)) by nearest_within for nis (K, N),
    N >= 1, and the landmark ids (N,) int64."""
    count = nis.shape[0]
    assignment, smallest = np.empty(count, dtype=np.int64), np.empty(count)
    nearest_within(_read_only(nis), float(bound), _read_only(ids, np.int64), int(new),
                   assignment, smallest)
    return assignment, smallest


def run_gnn_split(nis: np.ndarray, gate: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(columns (K,) intp, rows (R,), shared (S,), cost (R, S + R)) by gnn_split."""
    columns = np.empty(nis.shape[0], dtype=np.intp)
    rows, shared, cost = gnn_split(_read_only(nis), float(gate), columns)
    return columns, rows, shared, cost


def run_label_columns(nis: np.ndarray, columns: np.ndarray, rows: np.ndarray,
                      shared: np.ndarray, picked_rows: np.ndarray, picked: np.ndarray,
                      ids: np.ndarray, gate: float, new: int, unassociated: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(assignment (K,) int64, NIS of the chosen pairs or NaN (K,)) by label_columns; columns:
    run_gnn_split's (completed in place)."""
    count = nis.shape[0]
    assignment, chosen = np.empty(count, dtype=np.int64), np.empty(count)
    label_columns(_read_only(nis), columns, _read_only(rows, np.intp),
                  _read_only(shared, np.intp), _read_only(picked_rows, np.intp),
                  _read_only(picked, np.intp), _read_only(ids, np.int64), float(gate), int(new),
                  int(unassociated), assignment, chosen)
    return assignment, chosen


def run_first_indefinite_block(state: np.ndarray, n: int, d: int) -> int:
    """first_indefinite_block of a joint covariance of n landmarks of dimension d."""
    return int(first_indefinite_block(_read_only(state), int(n), int(d)))


def _warm_up() -> None:
    """Run every kernel through its run_ function (with and without a joint covariance) on a
    tiny input and check the values against their closed forms."""
    h_x = np.zeros((2, 2, 3))
    h_x[:, :, :2] = -np.eye(2)
    h_m = np.tile(np.eye(2), (2, 1, 1))
    h, jacobian, pose_jacobian = run_range_bearing_predict(np.array([[3.0, 4.0]]),
                                                           np.array([0.0, 0.0, np.pi / 2]))
    if not (np.allclose(h, [[5.0, np.arctan2(4.0, 3.0) - np.pi / 2]])
            and np.allclose(jacobian, [[[0.6, 0.8], [-0.16, 0.12]]])
            and np.allclose(pose_jacobian, [[[-0.6, -0.8, 0.0], [0.16, -0.12, -1.0]]])):
        raise RuntimeError(f'range_bearing_predict warm-up: {h} {jacobian} {pose_jacobian}')
    positions, covariances = run_range_bearing_in_map(  # G_z = [[0, -2], [1, 0]]
        np.array([[2.0, np.pi / 2]]), np.diag([1.0, 0.25])[None], np.array([1.0, 0.0, 0.0]),
        np.eye(3) * 0.5)
    if not (np.allclose(positions, [[1.0, 2.0]])
            and np.allclose(covariances, [[[3.5, 0.0], [0.0, 1.5]]])):
        raise RuntimeError(f'range_bearing_in_map warm-up: {positions} {covariances}')
    blocks = run_prediction_covariances(h_x, h_m, np.eye(3) * 0.5,
                                        np.tile(np.eye(2) * 0.25, (2, 1, 1)), None)
    joint = run_prediction_covariances(h_x, h_m, np.zeros((3, 3)), None, np.eye(7) * 0.5)
    if not (np.allclose(blocks, 0.75 * np.eye(2)) and np.allclose(joint, np.eye(2))):
        raise RuntimeError('prediction_covariances warm-up: wrong values')
    if not run_is_covariance_matrix(np.eye(3)) or \
            run_is_covariance_matrix(np.array([[1.0, 2.0], [0.0, 1.0]])):
        raise RuntimeError('is_covariance_matrix warm-up: wrong answer')
    if not run_are_spd_2x2(np.tile(np.eye(2), (3, 1, 1))) or \
            run_are_spd_2x2(np.array([[[1.0, 2.0], [2.0, 1.0]]])):
        raise RuntimeError('are_spd_2x2 warm-up: wrong answer')
    if run_first_indefinite_block(np.eye(7), 2, 2) != -1 or \
            run_first_indefinite_block(-np.eye(7), 2, 2) != 0:
        raise RuntimeError('first_indefinite_block warm-up: wrong answer')
    words = np.array([[3.0, 0.5, 0.25, 0.0, 0.01], [np.nan, 0.0, 1.0, 0.0, 1.0]], np.float32)
    values, covariances, first = run_observations_2d(words, np.array([0, 1, 2, 3, 4]),
                                                     np.eye(2))
    _, fallback_covariances, _ = run_observations_2d(words[:1], np.array([0, 1, -1, -1, -1]),
                                                     np.eye(2))
    if not (first == 1 and np.allclose(values[0], [3.0, 0.5])
            and np.allclose(covariances[0], np.diag([0.25, 0.01]))
            and np.array_equal(fallback_covariances[0], np.eye(2))):
        raise RuntimeError(f'observations_2d warm-up: {values} {covariances} {first}')
    assignment, smallest = run_nearest_within(np.array([[4.0, 1.0], [9.0, 8.0]]), 5.0,
                                              np.array([7, 9]), -1)
    if not (assignment.tolist() == [9, -1] and smallest[0] == 1.0 and np.isnan(smallest[1])):
        raise RuntimeError(f'nearest_within warm-up: {assignment} {smallest}')
    columns, rows, shared_columns, cost = run_gnn_split(
        np.array([[1.0, 20.0, 20.0], [20.0, 2.0, 3.0], [20.0, 4.0, 20.0]]), 9.0)
    if not (columns.tolist() == [0, -1, -1] and rows.tolist() == [1, 2]
            and shared_columns.tolist() == [1, 2]
            and np.array_equal(cost, [[2.0, 3.0, 9.0, np.inf], [4.0, np.inf, np.inf, 9.0]])):
        raise RuntimeError(f'gnn_split warm-up: {columns} {rows} {shared_columns} {cost}')
    nis = np.array([[1.0, 20.0], [5.0, 20.0], [20.0, 20.0], [20.0, 3.0]])
    picked = np.array([0, 1])   # row rows[0] = 3 takes shared[0] = 1, row 1 its own column
    assignment, smallest = run_label_columns(
        nis, np.array([0, -1, -1, -1]), np.array([3, 1]), np.array([1]), np.array([0, 1]),
        picked, np.array([7, 9]), 9.0, -1, -2)
    if not (assignment.tolist() == [7, -2, -1, 9] and smallest.tolist()[::3] == [1.0, 3.0]
            and np.isnan(smallest[1:3]).all()):
        raise RuntimeError(f'label_columns warm-up: {assignment} {smallest}')
    r = np.tile(np.eye(2), (1, 1, 1))
    for shared in (True, False):   # nu = (1, 0), S = 1 + 1
        nis = run_nis_2d(np.array([[1.0, 0.0]]), np.zeros((2, 2)), (1,), joint, r, shared, 0.0)
        if not np.allclose(nis, 0.5):
            raise RuntimeError(f'nis_2d warm-up: {nis} instead of 0.5')
    prediction, covariances, fused = run_range_bearing_nis(
        np.array([[3.0, 4.0]]), np.array([0.0, 0.0, np.pi / 2]), np.eye(3) * 0.5, None,
        np.eye(5) * 0.25, np.array([[5.0, 0.5]]), r, 0.0)
    separate = run_nis_2d(np.array([[5.0, 0.5]]), h, (1,),
                          run_prediction_covariances(pose_jacobian, jacobian, np.zeros((3, 3)),
                                                     None, np.eye(5) * 0.25), r, True, 0.0)
    if not (np.array_equal(prediction[0], h) and np.array_equal(fused, separate)):
        raise RuntimeError(f'range_bearing_nis warm-up: {prediction} {covariances} {fused}')
    nu, s = run_pair_terms(np.array([[1.0, 4.0]]), np.zeros((2, 2)), (1,), joint, r, 2.5,
                           np.array([0]), np.array([1]))
    if not (np.allclose(nu, [[1.0, 4.0 - 2.0 * np.pi]]) and np.allclose(s, 2.5 * np.eye(2))):
        raise RuntimeError(f'pair_terms warm-up: {nu} {s}')


KERNELS = Kernels(_warm_up)
"""These kernels' availability (compiled or loaded from the cache at the first use)."""
