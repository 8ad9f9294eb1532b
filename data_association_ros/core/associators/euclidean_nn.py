"""euclidean_nn: nearest landmark in measurement space, c_i = argmin_j |z_i - h_j| (seed 000, 1)."""
from ..gating import euclidean_gate
from ..parameters import ONE_TO_ONE, ParameterSpec
from .base import Associator, nearest_neighbours, result

EUCLIDEAN_GATE = ParameterSpec(
    'euclidean_gate', 1.0, 'distance |z - h| beyond which an observation is NEW (measurement '
    'units: metres for points)', low=0.0, low_open=True)


def run(problem, euclidean_gate: float, one_to_one: bool):
    """Greedy (or one-to-one greedy) NN on |nu_ij|; NEW beyond `euclidean_gate`."""
    distance = problem.euclidean_distances
    gated = distance <= euclidean_gate
    return result(problem, 'euclidean_nn', nearest_neighbours(distance, gated, one_to_one), gated)


ASSOCIATOR = Associator(
    gate=lambda observations, p: euclidean_gate(p['euclidean_gate']),
    name='euclidean_nn', run=run, parameters=(EUCLIDEAN_GATE, ONE_TO_ONE), needs_covariances=False,
    summary='nearest neighbour by Euclidean distance in measurement space; ignores uncertainty')
