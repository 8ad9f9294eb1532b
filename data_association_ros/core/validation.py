"""Checks shared by the core types: finiteness, shapes, symmetric positive-definite matrices."""
from __future__ import annotations

import weakref

import numpy as np

from . import jit
from .errors import InvalidInputError


def as_float64(value, field: str) -> np.ndarray:
    """A float64 copy of `value` (C order)."""
    try:
        return np.array(value, dtype=np.float64, order='C')
    except (TypeError, ValueError) as error:
        raise InvalidInputError(f'{field}: not numeric ({error})') from None


def as_float_array(value, field: str, ndim: int) -> np.ndarray:
    """`value` as a float64 array of `ndim` dimensions with only finite entries."""
    array = as_float64(value, field)
    if array.ndim != ndim:
        raise InvalidInputError(f'{field}: expected {ndim} dimensions, got shape {array.shape}')
    check_finite(array, field)
    return array


def check_finite(array: np.ndarray, field: str) -> None:
    """Raise naming the first index holding NaN or inf."""
    bad = ~np.isfinite(array)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise InvalidInputError(f'{field}[{", ".join(map(str, index))}]: not finite ({array[index]})')


def check_shape(array: np.ndarray, field: str, shape: tuple) -> None:
    """Raise unless `array.shape == shape` (None in `shape` matches any size)."""
    if len(array.shape) != len(shape) or any(
            want is not None and got != want for got, want in zip(array.shape, shape)):
        wanted = '(' + ', '.join('*' if s is None else str(s) for s in shape) + ')'
        raise InvalidInputError(f'{field}: expected shape {wanted}, got {array.shape}')


def check_spd(matrices: np.ndarray, field: str) -> None:
    """Raise naming the first matrix of the (n, d, d) stack that is not symmetric positive definite."""
    if matrices.size == 0:
        return
    scale = 1.0 + np.abs(matrices).max(axis=(-2, -1))
    unit = matrices / scale[..., None, None]   # entries within [-1, 1]: no overflow below
    asym = np.abs(unit - np.swapaxes(unit, -1, -2)).max(axis=(-2, -1))
    bad = np.flatnonzero(asym > 1e-9)   # |M - M^T| > 1e-9 (1 + max |M|)
    if bad.size:
        raise InvalidInputError(f'{field}[{bad[0]}]: not symmetric')
    if matrices.shape[-1] == 2:     # closed form: many small matrices, no LAPACK call each
        a, b, c = unit[:, 0, 0], unit[:, 0, 1], unit[:, 1, 1]
        smallest = 0.5 * (a + c) - np.hypot(0.5 * (a - c), b)
    else:
        smallest = np.linalg.eigvalsh(unit)[..., 0]
    bad = np.flatnonzero(smallest <= 1e-12)
    if bad.size:
        raise InvalidInputError(
            f'{field}[{bad[0]}]: not positive definite (smallest eigenvalue '
            f'{float(smallest[bad[0]]) * float(scale[bad[0]]):.3g})')  # inf, not a warning


_CHECKED: 'weakref.WeakValueDictionary[int, np.ndarray]' = weakref.WeakValueDictionary()
"""Matrices check_covariance_matrix returned (read-only), so a second check is free."""
_DEFINITE: 'weakref.WeakValueDictionary[int, np.ndarray]' = weakref.WeakValueDictionary()
"""Checked matrices that check_positive_semidefinite has also factorised."""


def is_checked_covariance(value) -> bool:
    """True for a matrix check_covariance_matrix returned (it is read-only, so still valid)."""
    return isinstance(value, np.ndarray) and _CHECKED.get(id(value)) is value \
        and not value.flags.writeable


def check_covariance_matrix(value, field: str) -> np.ndarray:
    """A finite, symmetric square matrix with a non-negative diagonal (float64, read-only): the
    checks that cost O(n^2), made once on arrival.  Positive semi-definiteness is checked by
    check_positive_semidefinite on the blocks actually used (a joint covariance of a large map
    is never factorised whole).  A matrix this returned before passes at once."""
    if is_checked_covariance(value):
        return value
    kernels = jit.problem_kernels()
    if kernels is not None:   # one compiled pass; the checks below say what is wrong
        matrix = as_float64(value, field)
        if matrix.ndim == 2 and matrix.shape[0] == matrix.shape[1] and \
                kernels.run_is_covariance_matrix(matrix):
            return _checked(matrix)
    matrix = as_float_array(value, field, 2)
    check_shape(matrix, field, (matrix.shape[0], matrix.shape[0]))
    scale = 1.0 + np.abs(matrix).max(initial=0.0)
    with np.errstate(over='ignore'):   # 1e308 against -1e308 differs by inf: not symmetric
        asymmetry = np.abs(matrix - matrix.T).max(initial=0.0)
    if asymmetry > 1e-9 * scale:
        raise InvalidInputError(f'{field}: not symmetric')
    diagonal = np.diagonal(matrix)
    if np.any(diagonal < 0):
        index = int(np.flatnonzero(diagonal < 0)[0])
        raise InvalidInputError(f'{field}[{index}, {index}]: negative variance {diagonal[index]}')
    return _checked(matrix)


def _checked(matrix: np.ndarray) -> np.ndarray:
    """`matrix`, made read-only and remembered as checked."""
    matrix.flags.writeable = False
    _CHECKED[id(matrix)] = matrix
    return matrix


def check_positive_semidefinite(matrix: np.ndarray, field: str) -> None:
    """Raise unless the symmetric `matrix` (n, n), or every matrix of a stack (k, n, n), is
    positive semi-definite: eigenvalues down to -1e-9 x (1 + max |entry|) are accepted, tested
    by Cholesky of the matrix plus twice that.  Free for a checked matrix that passed before."""
    if _DEFINITE.get(id(matrix)) is matrix and is_checked_covariance(matrix):
        return
    if matrix.size:
        scale = 1.0 + np.abs(matrix).max(axis=(-2, -1), keepdims=True)
        try:
            np.linalg.cholesky(matrix + 2e-9 * scale * np.eye(matrix.shape[-1]))
        except np.linalg.LinAlgError:
            raise InvalidInputError(f'{field}: not positive semi-definite') from None
    if is_checked_covariance(matrix):
        _DEFINITE[id(matrix)] = matrix
