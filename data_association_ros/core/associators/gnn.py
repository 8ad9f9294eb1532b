"""gnn: individual chi-square gate, then the one-to-one assignment of least total NIS."""
import numpy as np
from scipy.optimize import linear_sum_assignment

from .. import jit
from ..gating import chi2_threshold, nis_gate
from ..parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE
from ..types import NEW, UNASSOCIATED, Association
from .base import NO_LANDMARK, Associator, result


def run(problem, gate_probability: float, min_innovation_variance: float):
    """Minimise sum of d2_ij over pairs + chi2(m, p) per unpaired observation (Hungarian).

    A gated pair whose observation and landmark are in no other gated pair is paired on its own
    (its d2 is at most the gate); the Hungarian method (scipy's linear_sum_assignment, O(k^2 n)
    on k rows, n columns) runs only on the observations and landmarks that compete, in their
    order, so the optimum is the same; where several pairings tie, it may be another of them
    than on the whole matrix (2 x 8 NIS rows [10, 1, 1, 1, 1, 1, 1, 0]: the second observation
    to the fourth landmark instead of the first), the compiled and numpy forms the same one."""
    nis = problem.nis
    k, n = nis.shape
    gate = chi2_threshold(gate_probability, problem.observations.dim)
    kernels = jit.problem_kernels() if k and n else None
    if kernels is not None:   # the same steps in two compiled passes around scipy's
        columns, rows, shared, cost = kernels.run_gnn_split(nis, gate)
        picked_rows, picked = linear_sum_assignment(cost) if len(rows) else (rows, rows)
        assignment, chosen = kernels.run_label_columns(
            nis, columns, rows, shared, picked_rows, picked, problem.landmarks.ids, gate, NEW,
            UNASSOCIATED)
        return Association(assignment=assignment, nis=chosen, algorithm='gnn')
    gated = nis <= gate
    columns = np.full(k, NO_LANDMARK, dtype=np.intp)
    pair_rows, pair_columns = np.divmod(np.flatnonzero(gated), n)   # 2-D nonzero: 10x slower
    # a pair whose row and column have no other gated pair: decided on its own
    alone = (np.bincount(pair_rows, minlength=k)[pair_rows] == 1) & \
        (np.bincount(pair_columns, minlength=n)[pair_columns] == 1)
    columns[pair_rows[alone]] = pair_columns[alone]
    if not alone.all():
        pair_rows, pair_columns = pair_rows[~alone], pair_columns[~alone]
        rows, shared = _members(pair_rows, k), _members(pair_columns, n)
        cost = np.full((len(rows), len(shared) + len(rows)), np.inf)
        cost[rows.searchsorted(pair_rows), shared.searchsorted(pair_columns)] = \
            nis[pair_rows, pair_columns]
        cost[:, len(shared):].flat[::len(rows) + 1] = gate   # each one's 'unpaired' column
        picked_rows, picked = linear_sum_assignment(cost)
        real = picked < len(shared)
        columns[rows[picked_rows[real]]] = shared[picked[real]]
    return result(problem, 'gnn', columns, gated)


def _members(indices: np.ndarray, size: int) -> np.ndarray:
    """The distinct values of `indices` (all in [0, size)), ascending."""
    present = np.zeros(size, dtype=bool)
    present[indices] = True
    return np.flatnonzero(present)


ASSOCIATOR = Associator(
    gate=lambda observations, p: nis_gate(observations, p['gate_probability']),
    name='gnn', run=run, parameters=(GATE_PROBABILITY, MIN_INNOVATION_VARIANCE),
    summary='global nearest neighbour: gate, then least-total-NIS one-to-one assignment')
