"""maximum_likelihood: largest N(nu; 0, S) per observation, new landmark below alpha (seed 000, 3)."""
import math

from ..gating import likelihood_gate
from ..parameters import MIN_INNOVATION_VARIANCE, ONE_TO_ONE, ParameterSpec
from .base import Associator, nearest_neighbours, result

NEW_LANDMARK_LIKELIHOOD = ParameterSpec(
    'new_landmark_likelihood', 0.01,
    'alpha: likelihood density of the new-landmark hypothesis, in 1/(measurement units): '
    '1/m^2 for 2-D points, 1/(m rad) for range-bearing', low=0.0, low_open=True)


def run(problem, new_landmark_likelihood: float, min_innovation_variance: float,
        one_to_one: bool):
    """c_i = argmax_j N(nu_ij; 0, S_ij); NEW when max_j N(nu_ij; 0, S_ij) < alpha."""
    log_likelihood = problem.log_likelihoods
    gated = log_likelihood >= math.log(new_landmark_likelihood)
    columns = nearest_neighbours(-log_likelihood, gated, one_to_one)
    return result(problem, 'maximum_likelihood', columns, gated)


ASSOCIATOR = Associator(
    gate=lambda observations, p: likelihood_gate(observations, p['new_landmark_likelihood']),
    name='maximum_likelihood', run=run,
    parameters=(NEW_LANDMARK_LIKELIHOOD, MIN_INNOVATION_VARIANCE, ONE_TO_ONE),
    summary='largest Gaussian likelihood (NIS plus log det S); new landmark below alpha')
