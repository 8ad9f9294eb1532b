"""The core's data types: landmarks, observations, robot pose and the association result.

Constructors copy their inputs to float64/int64 arrays, validate them and store them read-only;
bad input raises InvalidInputError naming the field and index.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from . import jit
from .errors import InvalidInputError
from .validation import as_float64, as_float_array, check_shape, check_spd

NEW = -1
"""Assignment value: outside every gate, start a new landmark from this observation."""
UNASSOCIATED = -2
"""Assignment value: inside some gate but not accepted; never start a landmark from it."""

MEASUREMENT_DIMENSIONS = {
    'point_map': (2, 3),
    'point_robot': (2,),
    'range_bearing': (2,),
    'box': (4,),
}
"""Allowed observation dimensions m of each measurement model."""


def _empty_as_2d(value, columns: int):
    """An empty input of any shape ([], None-free) as a (0, columns) array; others unchanged."""
    if isinstance(value, np.ndarray) and value.ndim == 2:
        return value
    try:
        if np.size(value) == 0:
            return np.zeros((0, columns))
    except (TypeError, ValueError):
        pass
    return value


def _set_read_only(instance, **fields) -> None:
    """Set the fields of a frozen instance, its arrays read-only: the core's types are
    immutable, so what is derived from them once (a map's spatial index) stays valid and the
    compiled kernels take them as they are."""
    for name, value in fields.items():
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
        object.__setattr__(instance, name, value)


def _covariance_stack(value, field_name: str, count: int, dim: int) -> Optional[np.ndarray]:
    if value is None:
        return None
    kernels = jit.problem_kernels() if dim == 2 else None
    if kernels is not None:   # one compiled pass; the checks below say what is wrong
        covariances = as_float64(value, field_name)
        covariances.flags.writeable = False   # as it is stored (the kernel takes it so)
        if covariances.shape == (count, 2, 2) and kernels.run_are_spd_2x2(covariances):
            return covariances
    covariances = as_float_array(value, field_name, 3)
    check_shape(covariances, field_name, (count, dim, dim))
    check_spd(covariances, field_name)
    return covariances


@dataclass(frozen=True, init=False)
class Landmarks:
    """N known landmarks (or tracked objects) in the map frame.

    ids: (N,) int64, unique, >= 0.  means: (N, d).  covariances: (N, d, d) SPD, or None where
    the algorithm needs none (euclidean_nn, iou).
    """

    ids: np.ndarray
    means: np.ndarray
    covariances: Optional[np.ndarray]

    def __init__(self, ids, means, covariances=None) -> None:
        means = as_float_array(_empty_as_2d(means, 2), 'landmarks.means', 2)
        count = means.shape[0]
        try:
            ids_array = np.asarray(ids)
            if ids_array.size == 0:
                ids_array = np.zeros(0, dtype=np.int64)
            if ids_array.dtype.kind == 'f':
                if not np.all(np.isfinite(ids_array)) or np.any(
                        ids_array != np.round(ids_array)) or np.any(np.abs(ids_array) > 2 ** 62):
                    raise TypeError('ids must be integers')
            if ids_array.dtype.kind not in 'iuf':
                raise TypeError(f'dtype {ids_array.dtype}')
            ids_array = ids_array.astype(np.int64)
        except (TypeError, ValueError) as error:
            raise InvalidInputError(f'landmarks.ids: not integers ({error})') from None
        check_shape(ids_array, 'landmarks.ids', (count,))
        if np.any(ids_array < 0):
            index = int(np.flatnonzero(ids_array < 0)[0])
            raise InvalidInputError(
                f'landmarks.ids[{index}]: negative id {ids_array[index]} (-1 and -2 mean NEW and '
                'UNASSOCIATED)')
        unique, first, counts = np.unique(ids_array, return_index=True, return_counts=True)
        if np.any(counts > 1):
            duplicate = unique[counts > 1][0]
            indices = np.flatnonzero(ids_array == duplicate)
            raise InvalidInputError(
                f'landmarks.ids[{indices[1]}]: duplicate id {duplicate} (also at index {indices[0]})')
        covariances = _covariance_stack(covariances, 'landmarks.covariances', count, means.shape[1])
        _set_read_only(self, ids=ids_array, means=means, covariances=covariances)

    def subset(self, columns: np.ndarray) -> 'Landmarks':
        """The landmarks at `columns` (L,), in that order (already validated: no checks)."""
        part = object.__new__(Landmarks)
        _set_read_only(part, ids=self.ids[columns], means=self.means[columns],
                       covariances=None if self.covariances is None else self.covariances[columns])
        return part

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @property
    def dim(self) -> int:
        """d, the dimension of a landmark."""
        return int(self.means.shape[1])


@dataclass(frozen=True, init=False)
class Observations:
    """K observations of one measurement model.

    values: (K, m); covariances: (K, m, m) SPD (the measurement noise R), or None where the
    algorithm needs none.  model: one of MEASUREMENT_DIMENSIONS.
    """

    values: np.ndarray
    covariances: Optional[np.ndarray]
    model: str

    def __init__(self, values, covariances=None, model: str = 'point_map') -> None:
        if not isinstance(model, str) or model not in MEASUREMENT_DIMENSIONS:
            raise InvalidInputError(
                f'observations.model: unknown model {model!r} (valid: '
                f'{", ".join(MEASUREMENT_DIMENSIONS)})')
        dims = MEASUREMENT_DIMENSIONS[model]
        values = as_float_array(_empty_as_2d(values, dims[0]), 'observations.values', 2)
        if values.shape[1] not in dims:
            raise InvalidInputError(
                f'observations.values: model {model!r} has dimension '
                f'{" or ".join(map(str, dims))}, got shape {values.shape}')
        if model == 'box' and np.any(values[:, 2:] < 0):
            index = int(np.flatnonzero(np.any(values[:, 2:] < 0, axis=1))[0])
            raise InvalidInputError(f'observations.values[{index}]: negative box width or height')
        covariances = _covariance_stack(covariances, 'observations.covariances', values.shape[0],
                                        values.shape[1])
        _set_read_only(self, values=values, covariances=covariances, model=model)

    @classmethod
    def from_float32_columns(cls, words: np.ndarray, columns: np.ndarray, model: str,
                             fallback: np.ndarray) -> 'Observations':
        """2-D observations of `model` from float32 words (K, W) (a point cloud's points seen as
        4-byte words): values (K, 2) = words[:, columns[0:2]]; R (K, 2, 2) =
        [[w[c2], w[c3]], [w[c3], w[c4]]] (w[c3] = 0 when columns[3] < 0), or `fallback` (2, 2)
        for all when columns[2] < 0; columns: 5 word indices.  The same object and the same
        errors as Observations(values, R, model), checked in one compiled pass when it can be."""
        kernels = jit.problem_kernels()
        if kernels is not None:
            values, covariances, first = kernels.run_observations_2d(words, columns, fallback)
            if first < 0 and model in MEASUREMENT_DIMENSIONS and \
                    2 in MEASUREMENT_DIMENSIONS[model]:   # passes every check of __init__
                observations = object.__new__(cls)
                _set_read_only(observations, values=values, covariances=covariances,
                               model=model)
                return observations
        else:
            values = words[:, columns[:2]].astype(np.float64)
            if columns[2] >= 0:
                covariances = np.zeros((len(words), 2, 2))
                covariances[:, 0, 0] = words[:, columns[2]]
                covariances[:, 1, 1] = words[:, columns[4]]
                if columns[3] >= 0:
                    covariances[:, 0, 1] = covariances[:, 1, 0] = words[:, columns[3]]
            else:
                covariances = np.broadcast_to(fallback, (len(words), 2, 2)).copy()
        return cls(values, covariances, model)   # names what is wrong

    def __len__(self) -> int:
        return int(self.values.shape[0])

    @property
    def dim(self) -> int:
        """m, the dimension of an observation."""
        return int(self.values.shape[1])


@dataclass(frozen=True, init=False)
class RobotPose:
    """Robot pose in the map frame: mean (3,) = x [m], y [m], yaw [rad]; covariance (3, 3) PSD."""

    mean: np.ndarray
    covariance: np.ndarray

    def __init__(self, mean, covariance=None) -> None:
        mean = as_float_array(mean, 'pose.mean', 1)
        check_shape(mean, 'pose.mean', (3,))
        covariance = np.zeros((3, 3)) if covariance is None else as_float_array(
            covariance, 'pose.covariance', 2)
        check_shape(covariance, 'pose.covariance', (3, 3))
        if np.abs(covariance - covariance.T).max() > 1e-9 * (1 + np.abs(covariance).max()):
            raise InvalidInputError('pose.covariance: not symmetric')
        if np.linalg.eigvalsh(covariance)[0] < -1e-9 * (1 + np.abs(covariance).max()):
            raise InvalidInputError('pose.covariance: not positive semi-definite')
        _set_read_only(self, mean=mean, covariance=covariance)


@dataclass
class Association:
    """Result of one association.

    assignment: (K,) int64, a landmark id, NEW (-1) or UNASSOCIATED (-2) per observation.
    nis: (K,) float64, individual NIS nu' S^-1 nu of the chosen pair, NaN where none.
    extras: per-algorithm values, e.g. 'joint_nis', 'search_nodes', 'truncated'.
    """

    assignment: np.ndarray
    nis: np.ndarray
    algorithm: str = ''
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def truncated(self) -> bool:
        """True when a time or node budget cut the search short."""
        return bool(self.extras.get('truncated', False))

    def pairs(self) -> dict[int, int]:
        """{observation index: landmark id} of the associated observations."""
        return {int(i): int(j) for i, j in enumerate(self.assignment) if j >= 0}
