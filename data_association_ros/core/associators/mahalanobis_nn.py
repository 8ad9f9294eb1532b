"""mahalanobis_nn: smallest NIS d2 = nu^T S^-1 nu with S = H P H^T + R (seed 000, 2; seed 004)."""
from ..gating import chi2_threshold, nis_gate
from ..parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, ONE_TO_ONE
from .base import Associator, nearest_neighbours, nearest_within, result


def run(problem, gate_probability: float, min_innovation_variance: float, one_to_one: bool):
    """Greedy (or one-to-one greedy) NN on d2_ij; NEW when d2 > chi2(m, gate_probability)."""
    bound = chi2_threshold(gate_probability, problem.observations.dim)
    if not one_to_one:
        return nearest_within(problem, 'mahalanobis_nn', bound)
    gated = problem.nis <= bound
    return result(problem, 'mahalanobis_nn', nearest_neighbours(problem.nis, gated, True), gated)


ASSOCIATOR = Associator(
    gate=lambda observations, p: nis_gate(observations, p['gate_probability']),
    name='mahalanobis_nn', run=run,
    parameters=(GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, ONE_TO_ONE),
    summary='nearest neighbour by Mahalanobis distance inside the chi-square gate')
