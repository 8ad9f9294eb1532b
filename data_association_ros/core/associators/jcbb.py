"""jcbb: joint compatibility branch and bound (Neira & Tardos 2001; seed 000, 4.2-4.3).

The most pairs that are jointly compatible, ties by the smallest joint NIS; exact incremental
joint NIS and exact pruning (see joint_compatibility).  Unpaired observations are NEW when
outside every individual gate, else UNASSOCIATED.

Pairs are individually compatible at `gate_probability`; a set of l pairs is jointly compatible
when its joint NIS is within chi2(m l, `joint_gate_probability`) (0: `gate_probability`), so the
two significance levels can differ as in the TTK4250 course's JCBB (individual alpha =
1 - gate_probability, joint alpha = 1 - joint_gate_probability).  `classic_pruning=True,
nis_tie_break=False` is Neira & Tardos' original search.
"""
from __future__ import annotations

import time

import numpy as np

from .. import jit
from ..gating import chi2_threshold, nis_gate
from ..parameters import (GATE_PROBABILITY, JOINT_GATE_PROBABILITY, MIN_INNOVATION_VARIANCE,
                          ParameterSpec)
from .base import NO_LANDMARK, Associator, result
from .joint_compatibility import (MAX_NODES, TIME_BUDGET_MS, CandidateLists,
                                  JointCompatibilitySearch, joint_compatibility_search,
                                  prepare_search, search_order)

CLASSIC_PRUNING = ParameterSpec(
    'classic_pruning', False, 'also prune every node failing its own joint test (faster, may '
    'miss the largest valid set)', kind=bool)
NIS_TIE_BREAK = ParameterSpec(
    'nis_tie_break', True, 'among the sets with the most pairs take the smallest joint NIS '
    '(false: the first found, cutting every branch that cannot give more pairs, as Neira & '
    'Tardos 2001 and the TTK4250 course; faster)', kind=bool)


def individually_compatible(problem, gate_probability: float):
    """(gate mask (K, N), CandidateLists: each observation's gated columns sorted by NIS (ties
    by column), search order: the observations with candidates, fewest candidates first)."""
    nis = problem.nis
    threshold = chi2_threshold(gate_probability, problem.observations.dim)
    from . import jcbb_compiled   # here: importing the core does not import numba
    if jit.enabled() and jcbb_compiled.available():
        gated, start, columns = jcbb_compiled.gated_candidates(nis, threshold)
        candidates = CandidateLists(start, columns)
    else:
        gated = nis <= threshold
        counts = gated.sum(axis=1)
        by_nis = np.argsort(np.where(gated, nis, np.inf), axis=1, kind='stable')
        candidates = CandidateLists.from_counts(
            counts, by_nis[np.arange(nis.shape[1]) < counts[:, None]])
    return gated, candidates, search_order(candidates.counts)


def deadline_of(started: float, time_budget_ms: float):
    """perf_counter deadline of a budget in ms (None: no limit)."""
    return started + time_budget_ms / 1000.0 if time_budget_ms > 0 else None


def search_result(problem, name: str, search: JointCompatibilitySearch, gated, started: float,
                  **extras):
    """The Association of a finished search."""
    columns = np.full(problem.sizes[0], NO_LANDMARK, dtype=np.intp)
    for i, j in search.best_pairs:
        columns[i] = j
    return result(problem, name, columns, gated, joint_nis=search.best_nis,
                  search_nodes=search.nodes, truncated=search.truncated,
                  elapsed_ms=(time.perf_counter() - started) * 1000.0, **extras)


def run(problem, gate_probability: float, joint_gate_probability: float,
        min_innovation_variance: float, time_budget_ms: float, max_nodes: int,
        classic_pruning: bool, nis_tie_break: bool):
    """JCBB over the individually compatible pairs; see the module docstring."""
    prepare_search()   # a first compilation is not part of the time budget
    started = time.perf_counter()
    gated, candidates, order = individually_compatible(problem, gate_probability)
    joint = joint_gate_probability if joint_gate_probability > 0.0 else gate_probability
    search = joint_compatibility_search(problem, joint, candidates, order,
                                        deadline_of(started, time_budget_ms), max_nodes,
                                        classic_pruning, nis_tie_break)
    search.run()
    return search_result(problem, 'jcbb', search, gated, started)


ASSOCIATOR = Associator(
    gate=lambda observations, p: nis_gate(observations, p['gate_probability']),
    name='jcbb', run=run,
    parameters=(GATE_PROBABILITY, JOINT_GATE_PROBABILITY, MIN_INNOVATION_VARIANCE,
                TIME_BUDGET_MS, MAX_NODES, CLASSIC_PRUNING, NIS_TIE_BREAK),
    summary='joint compatibility branch and bound: the largest jointly consistent set of pairs')
