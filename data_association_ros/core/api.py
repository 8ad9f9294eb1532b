"""associate(): the one entry point of the core."""
from __future__ import annotations

from functools import lru_cache
from typing import Optional

from .associators import REGISTRY
from .errors import InvalidInputError
from .parameters import GATE_PROBABILITY, MIN_INNOVATION_VARIANCE, resolve
from .problem import AssociationProblem
from .spatial_index import landmark_index, search_radii, wants_index
from .types import Association, Landmarks, Observations, RobotPose


def available_algorithms() -> tuple[str, ...]:
    """The registered algorithm names, the valid values of `algorithm`."""
    return tuple(REGISTRY)


def associate(landmarks: Landmarks, observations: Observations, algorithm: str = 'mahalanobis_nn',
              pose: Optional[RobotPose] = None, state_covariance=None,
              gate_probability: float = GATE_PROBABILITY.default,
              spatial_index: Optional[bool] = None, **algorithm_params) -> Association:
    """Associate K observations with N landmarks by `algorithm`.

    state_covariance: joint covariance ((3 + N d), (3 + N d)) of [x, y, yaw, landmark 0, ...] in
    the order of `landmarks.ids`; None: blockdiag(pose covariance, landmark covariances).  Only
    the rows and columns of the pose and of the landmarks that can pass a gate are read (and
    checked positive semi-definite); the whole matrix is checked finite, symmetric and with a
    non-negative diagonal unless it came from check_covariance_matrix.
    spatial_index: only the landmarks that can pass some observation's gate take part (exact,
    see core/spatial_index.py; the answer is the same); None: spatial_index.wants_index (maps of
    at least INDEX_BUILD_MIN_LANDMARKS, or INDEX_MIN_LANDMARKS when their index exists already),
    True: always, False: never.  The index is built at the first call and kept with the
    `landmarks` object for the next calls.
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
    parameters = _resolve(algorithm, given)
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
    return associator.run(_local_problem(problem, associator, parameters, spatial_index),
                          **parameters)


def _resolve(algorithm: str, given: dict) -> dict:
    """resolve() of the algorithm's parameters, checked once per set of values (and of their
    types: True is not 1 here); a copy each call."""
    try:
        return dict(_resolved(algorithm, tuple(given.items()), tuple(map(type, given.values()))))
    except TypeError:   # an unhashable value: resolve names what is wrong with it
        return resolve(REGISTRY[algorithm].parameters, given, algorithm)


@lru_cache(maxsize=64)
def _resolved(algorithm: str, given: tuple, types: tuple) -> dict:
    return resolve(REGISTRY[algorithm].parameters, dict(given), algorithm)


def _local_problem(problem: AssociationProblem, associator, parameters: dict,
                   spatial_index: Optional[bool]) -> AssociationProblem:
    """The problem over the landmarks the associator's gate can accept (all of them without
    an index)."""
    n = len(problem.landmarks)
    wanted = wants_index(problem.landmarks, problem.state_covariance) if spatial_index is None \
        else bool(spatial_index)
    if associator.gate is None or not wanted or n == 0 or len(problem.observations) == 0:
        problem.check_definite()
        return problem
    gate = associator.gate(problem.observations, parameters)
    index = landmark_index(problem.landmarks, problem.state_covariance)
    pose_mean = None if problem.pose is None else problem.pose.mean
    points, radius_of = search_radii(problem.model.name, problem.observations, pose_mean,
                                     problem.pose_covariance, gate,
                                     problem.min_innovation_variance)
    return problem.restricted(index.candidates(points, radius_of))
