"""Compiled (numba) packing of output clouds: one pass instead of a structured array filled
field by field, its bytes and a NaN scan (msg_adapters/outputs.py keeps the numpy form, used
without numba and inside core.jit.compiled(False)).

* correspondence_words: the correspondences points (CORRESPONDENCE_DTYPE: observation,
  landmark as int32, nis, probability, x, y as float32) of one association.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from data_association_ros.core import jit
from data_association_ros.core.jit import Kernels, njit


@njit
def correspondence_words(assignment, nis, probabilities, positions, integers, floats):
    """Row k of integers / floats (two (K, 6) views of one buffer): k, assignment[k] (int32),
    then nis[k], probabilities[k] (1 when probabilities is empty), positions[k, 0:2] (float32,
    numpy's casts); returns True when one of the float32 values is NaN."""
    has_nan = False
    given = probabilities.shape[0] > 0
    for k in range(assignment.shape[0]):
        integers[k, 0] = k
        integers[k, 1] = assignment[k]
        floats[k, 2] = nis[k]
        floats[k, 3] = probabilities[k] if given else 1.0
        floats[k, 4] = positions[k, 0]
        floats[k, 5] = positions[k, 1]
        for column in range(2, 6):
            if np.isnan(floats[k, column]):
                has_nan = True
    return has_nan


_NONE = np.zeros(0)
_NONE.flags.writeable = False


def run_correspondence_words(assignment: np.ndarray, nis: np.ndarray,
                             probabilities: Optional[np.ndarray], positions: np.ndarray
                             ) -> tuple[bytes, bool]:
    """(the K packed correspondences points, whether one of their float fields is NaN) for
    assignment (K,) int64, nis (K,), probabilities (K,) or None (all 1), positions (K, 2)."""
    words = np.empty((len(assignment), 6), dtype=np.float32)
    has_nan = correspondence_words(
        _contiguous(assignment, np.int64), _contiguous(nis),
        _NONE if probabilities is None else _contiguous(probabilities),
        _contiguous(positions), words.view(np.int32), words)
    return words.tobytes(), bool(has_nan)


def _contiguous(array: np.ndarray, dtype=np.float64) -> np.ndarray:
    """A read-only C-contiguous `dtype` view of `array` (a copy only when needed), so that
    numba compiles one version of the kernel."""
    view = np.ascontiguousarray(array, dtype=dtype).view()
    view.flags.writeable = False
    return view


def _warm_up() -> None:
    data, has_nan = run_correspondence_words(np.array([7, -1]), np.array([0.5, np.nan]), None,
                                             np.array([[1.0, 2.0], [3.0, 4.0]]))
    words = np.frombuffer(data, dtype=np.float32).reshape(2, 6)
    if not (has_nan and words.view(np.int32)[:, :2].tolist() == [[0, 7], [1, -1]]
            and words[0, 2:].tolist() == [0.5, 1.0, 1.0, 2.0]):
        raise RuntimeError(f'correspondence_words warm-up: {words} {has_nan}')


KERNELS = Kernels(_warm_up)
"""These kernels' availability (compiled or loaded from the cache at the first use)."""


def available() -> bool:
    """True when the compiled kernels are on (core.jit.compiled) and available (else
    outputs.py's numpy code answers)."""
    return jit.enabled() and KERNELS.available()
