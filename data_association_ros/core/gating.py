"""Gates: chi-square NIS thresholds, and what an associator's gate lets through (for the
spatial index, which must never drop a pair the gate would accept)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Optional

import numpy as np
from scipy.special import gammaincinv


@lru_cache(maxsize=4096)
def chi2_threshold(probability: float, dof: int) -> float:
    """chi2 quantile: the NIS below which a correct pairing of `dof` dimensions falls with
    probability `probability` (0.99, dof 2 -> 9.21): 2 P^-1(dof / 2, probability) with P the
    regularised lower incomplete gamma function, scipy.stats.chi2.ppf's own formula (without
    importing scipy.stats, about 1 s of a node's start-up)."""
    return float(2.0 * gammaincinv(0.5 * dof, probability))


@dataclass(frozen=True)
class Gate:
    """What an associator can accept for observation i: pairs with NIS d2_ij <= nis_bound[i]
    (nis_bound (K,)), or pairs with |nu_ij| <= distance in measurement units (Euclidean)."""

    nis_bound: Optional[np.ndarray] = None
    distance: Optional[float] = None


def nis_gate(observations, gate_probability: float) -> Gate:
    """The individual chi-square gate: d2 <= chi2(m, gate_probability) for every observation."""
    bound = chi2_threshold(gate_probability, observations.dim)
    return Gate(nis_bound=np.full(len(observations), bound))


def likelihood_gate(observations, new_landmark_likelihood: float) -> Gate:
    """The gate of log N(nu; 0, S) >= log alpha: since S >= R_i (S = H P H^T + R_i, diagonal
    floored upwards), d2 <= -2 log alpha - m log(2 pi) - log det R_i."""
    m = observations.dim
    _, logdet = np.linalg.slogdet(observations.covariances)
    bound = -2.0 * math.log(new_landmark_likelihood) - m * math.log(2.0 * math.pi) - logdet
    return Gate(nis_bound=np.maximum(bound, 0.0))


def euclidean_gate(distance: float) -> Gate:
    """|z - h| <= distance."""
    return Gate(distance=float(distance))
