"""gnn: individual chi-square gate, then the one-to-one assignment of least total NIS."""
import numpy as np
from scipy.optimize import linear_sum_assignment

from ..gating import chi2_threshold, nis_gate
from ..parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE
from .base import NO_LANDMARK, Associator, result


def run(problem, gate_probability: float, min_innovation_variance: float):
    """Minimise sum of d2_ij over pairs + chi2(m, p) per unpaired observation (Hungarian)."""
    nis = problem.nis
    k, n = nis.shape
    gate = chi2_threshold(gate_probability, problem.observations.dim)
    gated = nis <= gate
    columns = np.full(k, NO_LANDMARK, dtype=np.intp)
    if k and n and gated.any():
        cost = np.full((k, n + k), np.inf)
        np.copyto(cost[:, :n], nis, where=gated)
        cost[:, n:].flat[::k + 1] = gate   # each observation's own 'unpaired' column
        rows, cols = linear_sum_assignment(cost)
        real = cols < n
        columns[rows[real]] = cols[real]
    return result(problem, 'gnn', columns, gated)


ASSOCIATOR = Associator(
    gate=lambda observations, p: nis_gate(observations, p['gate_probability']),
    name='gnn', run=run, parameters=(GATE_PROBABILITY, MIN_INNOVATION_VARIANCE),
    summary='global nearest neighbour: gate, then least-total-NIS one-to-one assignment')
