"""jcbb_points: scan points to an object's estimated boundary points (seed 003, fine association).

1. Individual compatibility: each scan point (observation) takes its smallest-NIS boundary point
   (landmark) inside the chi-square gate.
2. One-to-one: a boundary point taken by two or more scan points is cleared for all of them.
3. Minimal association: while the joint NIS fails chi2(m l, p), drop the pair whose removal
   lowers it most (leave-one-out: d2 - v_k^T (C^-1)_kk^-1 v_k with v = C^-1 nu), at most
   `minimal_iterations` times.
4. Depth-first search from that set, adding pairs of the remaining scan points: most pairs, ties
   by the smallest joint NIS, pruned by the chi-square bound and the best so far, within the
   time/node budget.
Where the seed approximates the joint NIS from rows and columns of one Cholesky factor of all
pairs (about 10x faster, not exact), this uses the exact incremental joint NIS of
joint_compatibility.  Coordinates are those of the measurement model: Cartesian for
point_map/point_robot (the seed's choice), polar for range_bearing.  The result carries the
rigid SE(2) transform mapping the paired scan points onto their boundary points
(extras['transform'], Kabsch or RANSAC) when at least two pairs exist.
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import InvalidInputError
from ..gating import chi2_threshold, nis_gate
from ..parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, ParameterSpec
from ..transforms import estimate_rigid_transform, ransac_rigid_transform
from .base import Associator
from .jcbb import deadline_of, individually_compatible, search_result
from .joint_compatibility import (MAX_NODES, TIME_BUDGET_MS, joint_compatibility_search,
                                  prepare_search, search_order)

MINIMAL_ITERATIONS = ParameterSpec(
    'minimal_iterations', 50, 'cap on the pairs dropped while building the minimal association',
    kind=int, low=0)
TRANSFORM = ParameterSpec(
    'transform_ransac', False, 'estimate the rigid transform by RANSAC (else Kabsch least '
    'squares over all pairs)', kind=bool)
RANSAC_THRESHOLD = ParameterSpec(
    'ransac_inlier_threshold', 0.1, 'RANSAC inlier distance [m]', low=0.0, low_open=True)


def joint_nis_terms(problem, pairs: list[tuple[int, int]]):
    """(d2, leave-one-out d2 of each pair (l,)) of a set of pairs, from C built in full."""
    m = problem.observations.dim
    columns = np.array([j for _, j in pairs])
    rows = np.array([i for i, _ in pairs])
    joint = problem.joint_prediction_covariance(columns)
    l = len(pairs)
    c = joint.transpose(0, 2, 1, 3).reshape(l * m, l * m)
    index = np.arange(l)
    # diagonal blocks: S_ij = H P H^T + R (with the covariance floor), as the search uses
    c.reshape(l, m, l, m)[index, :, index, :] = problem.innovation_covariances[rows, columns]
    nu = problem.innovations_of(rows, columns).reshape(l * m)
    q_nu = np.linalg.solve(c, nu)
    d2 = float(nu @ q_nu)
    inverse = np.linalg.inv(c).reshape(l, m, l, m)
    diagonal = inverse[np.arange(l), :, np.arange(l), :]
    v = q_nu.reshape(l, m)
    drop = np.einsum('lm,lm->l', v, np.linalg.solve(diagonal, v[..., None])[..., 0])
    return d2, d2 - drop


def minimal_association(problem, pairs: list[tuple[int, int]], gate_probability: float,
                        iterations: int) -> list[tuple[int, int]]:
    """Drop the pair whose removal lowers the joint NIS most until the set passes (step 3)."""
    m = problem.observations.dim
    pairs = list(pairs)
    for _ in range(iterations):
        if not pairs:
            break
        d2, without = joint_nis_terms(problem, pairs)
        if d2 <= chi2_threshold(gate_probability, m * len(pairs)):
            break
        pairs.pop(int(np.argmin(without)))
    return pairs


def run(problem, gate_probability: float, min_innovation_variance: float, time_budget_ms: float,
        max_nodes: int, minimal_iterations: int, transform_ransac: bool,
        ransac_inlier_threshold: float):
    """Steps 1-4 of the module docstring, then the rigid transform of the pairs."""
    if problem.observations.model not in ('point_map', 'point_robot', 'range_bearing'):
        raise InvalidInputError(f'observations.model: jcbb_points needs 2-D points, not '
                                f'{problem.observations.model!r}')
    prepare_search()   # a first compilation is not part of the time budget
    started = time.perf_counter()
    gated, candidates, _ = individually_compatible(problem, gate_probability)
    nearest = np.array([c[0] if len(c) else -1 for c in candidates], dtype=np.intp)
    taken, counts = np.unique(nearest[nearest >= 0], return_counts=True)
    doubled = taken[counts > 1]
    initial = [(i, int(j)) for i, j in enumerate(nearest) if j >= 0 and j not in doubled]
    minimal = minimal_association(problem, initial, gate_probability, minimal_iterations) \
        if initial else []
    in_minimal = {i for i, _ in minimal}
    order = search_order(candidates.counts, in_minimal)
    search = joint_compatibility_search(problem, gate_probability, candidates, order,
                                        deadline_of(started, time_budget_ms), max_nodes)
    nis = search.start_from(minimal)
    search.run(0, nis)
    extras = {'minimal_pairs': len(minimal)}
    if len(search.best_pairs) >= 2:
        rows = np.array([i for i, _ in search.best_pairs])
        columns = np.array([j for _, j in search.best_pairs])
        source = problem.observations.values[rows] if problem.observations.model != \
            'range_bearing' else problem.model.inverse(problem.observations.values[rows],
                                                       problem.pose.mean)[0]
        target = problem.landmarks.means[columns]
        try:
            extras['transform'] = ransac_rigid_transform(
                source, target, ransac_inlier_threshold) if transform_ransac else \
                estimate_rigid_transform(source, target)
        except InvalidInputError:
            pass  # degenerate pairs (all scan points coincide): no transform
    return search_result(problem, 'jcbb_points', search, gated, started, **extras)


ASSOCIATOR = Associator(
    gate=lambda observations, p: nis_gate(observations, p['gate_probability']),
    name='jcbb_points', run=run,
    parameters=(GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, TIME_BUDGET_MS, MAX_NODES,
                MINIMAL_ITERATIONS, TRANSFORM, RANSAC_THRESHOLD),
    models=('point_map', 'point_robot', 'range_bearing'),
    summary='seed 003 point matching: one-to-one, minimal association, then JCBB search; '
            'with the rigid transform of the pairs')
