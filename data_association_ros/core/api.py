"""associate(): the one entry point of the core."""
from __future__ import annotations

from typing import Optional

from .associators import REGISTRY
from .errors import InvalidInputError
from .parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, resolve
from .problem import AssociationProblem
from .types import Association, Landmarks, Observations, RobotPose


def available_algorithms() -> tuple[str, ...]:
    """The registered algorithm names, the valid values of `algorithm`."""
    return tuple(REGISTRY)


def associate(landmarks: Landmarks, observations: Observations, algorithm: str = 'mahalanobis_nn',
              pose: Optional[RobotPose] = None, state_covariance=None,
              gate_probability: float = GATE_PROBABILITY.default,
              **algorithm_params) -> Association:
    """Associate K observations with N landmarks by `algorithm`.

    state_covariance: joint covariance ((3 + N d), (3 + N d)) of [x, y, yaw, landmark 0, ...] in
    the order of `landmarks.ids`; None: blockdiag(pose covariance, landmark covariances).
    Returns an Association whose assignment (K,) holds landmark ids, NEW or UNASSOCIATED.
    Raises InvalidInputError on bad input, unknown algorithm or bad parameters.
    """
    if not isinstance(algorithm, str) or algorithm not in REGISTRY:
        raise InvalidInputError(
            f'algorithm: unknown {algorithm!r} (valid: {", ".join(REGISTRY)})')
    associator = REGISTRY[algorithm]
    given = dict(algorithm_params)
    if any(spec.name == GATE_PROBABILITY.name for spec in associator.parameters):
        given[GATE_PROBABILITY.name] = gate_probability
    else:
        GATE_PROBABILITY.check(gate_probability)
    parameters = resolve(associator.parameters, given, algorithm)
    if observations.model not in associator.models if isinstance(observations, Observations) \
            else False:
        raise InvalidInputError(
            f'observations.model: {algorithm!r} supports {", ".join(associator.models)}, '
            f'not {observations.model!r}')
    problem = AssociationProblem(
        landmarks, observations, pose, state_covariance,
        parameters.get(MIN_INNOVATION_VARIANCE.name, 0.0))
    if associator.needs_covariances:
        problem.require_covariances(algorithm)
    return associator.run(problem, **parameters)
