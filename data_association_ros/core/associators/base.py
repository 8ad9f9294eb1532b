"""What associators share: the associator record, nearest-neighbour selection and labelling."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Optional

import numpy as np

from .. import jit
from ..gating import Gate
from ..parameters import ParameterSpec
from ..problem import AssociationProblem
from ..types import NEW, UNASSOCIATED, Association, Observations

NO_LANDMARK = -1
"""Column index meaning 'no landmark chosen' inside associators."""


@dataclass(frozen=True)
class Associator:
    """A registered algorithm: run(problem, **parameters) -> Association.

    `parameters` lists every keyword `run` accepts (besides the problem); `needs_covariances`
    says whether S must be computable; `models` are the measurement models it supports.
    `gate(observations, parameters) -> Gate` bounds the pairs it can ever accept (its answer
    depends on those pairs only), so the spatial index may drop every other landmark; None:
    the associator sees every landmark.
    """

    name: str
    run: Callable[..., Association]
    parameters: tuple[ParameterSpec, ...]
    summary: str
    needs_covariances: bool = True
    models: tuple[str, ...] = ('point_map', 'point_robot', 'range_bearing', 'box')
    extras: tuple[str, ...] = field(default=())
    gate: Optional[Callable[[Observations, dict[str, Any]], Gate]] = None


def nearest_neighbours(cost: np.ndarray, gated: np.ndarray, one_to_one: bool) -> np.ndarray:
    """Column of the cheapest gated landmark per row (K,), NO_LANDMARK where none.

    one_to_one: the greedy matching (take the globally cheapest free pair, repeat), computed as
    rounds of locally dominant pairs (row's cheapest free column whose cheapest free row it is),
    which gives the same matching for distinct costs.
    """
    k, n = cost.shape
    masked = np.where(gated, cost, np.inf)
    if not one_to_one:
        best = np.argmin(masked, axis=1) if n else np.zeros(k, dtype=np.intp)
        return np.where(np.isfinite(masked[np.arange(k), best]) if n else False, best,
                        NO_LANDMARK).astype(np.intp)
    chosen = np.full(k, NO_LANDMARK, dtype=np.intp)
    rows_left = np.ones(k, dtype=bool)
    while n and rows_left.any():
        best_column = np.argmin(masked, axis=1)
        finite = np.isfinite(masked[np.arange(k), best_column])
        if not finite.any():
            break
        best_row = np.argmin(masked, axis=0)
        rows = np.flatnonzero(finite & (best_row[best_column] == np.arange(k)))
        chosen[rows] = best_column[rows]
        masked[rows, :] = np.inf
        masked[:, best_column[rows]] = np.inf
        rows_left[rows] = False
    return chosen


def nearest_within(problem: AssociationProblem, name: str, bound: float) -> Association:
    """Each observation paired with its smallest-NIS landmark where that NIS is at most `bound`,
    else NEW: result(problem, name, nearest_neighbours(nis, nis <= bound, False), nis <= bound)
    in seven array operations (the NIS holds no NaN, so the first smallest is the first smallest
    gated one)."""
    nis = problem.nis
    k, n = nis.shape
    if n == 0:
        return Association(np.full(k, NEW, dtype=np.int64), np.full(k, np.nan), name)
    kernels = jit.problem_kernels()
    if kernels is not None:   # the same in one compiled pass
        assignment, smallest = kernels.run_nearest_within(nis, bound, problem.landmarks.ids,
                                                          NEW)
        return Association(assignment=assignment, nis=smallest, algorithm=name)
    best = nis.argmin(axis=1)
    smallest = nis[np.arange(k), best]
    inside = smallest <= bound
    return Association(assignment=np.where(inside, problem.landmarks.ids[best], NEW),
                       nis=np.where(inside, smallest, np.nan), algorithm=name)


def label(problem: AssociationProblem, rows: np.ndarray, columns: np.ndarray,
          gated: np.ndarray, unmatched: int | None = None) -> np.ndarray:
    """Landmark ids (K,) with the rows (P,) paired to the landmark columns (P,); an unpaired row
    is UNASSOCIATED when it is inside some gate (gated (K, N)), else NEW (or `unmatched` for
    every unpaired row when given)."""
    assignment = np.full(len(gated), NEW if unmatched is None else unmatched, dtype=np.int64)
    if unmatched is None and gated.size:
        assignment[gated.any(axis=1)] = UNASSOCIATED
    assignment[rows] = problem.landmarks.ids[columns]
    return assignment


def result(problem: AssociationProblem, name: str, columns: np.ndarray, gated: np.ndarray,
           unmatched: int | None = None, **extras) -> Association:
    """The Association for the chosen column of each row (K,) (NO_LANDMARK: none), with the
    individual NIS of each chosen pair; gated (K, N) as for `label`."""
    rows = (columns >= 0).nonzero()[0]
    chosen = columns[rows]
    nis = np.full(len(columns), np.nan)
    if problem.has_covariances:
        nis[rows] = problem.nis[rows, chosen]
    return Association(assignment=label(problem, rows, chosen, gated, unmatched), nis=nis,
                       algorithm=name, extras=extras)
