"""Chi-square gates: NIS thresholds for a gate probability and a dimension."""
from __future__ import annotations

from functools import lru_cache

from scipy.stats import chi2


@lru_cache(maxsize=4096)
def chi2_threshold(probability: float, dof: int) -> float:
    """chi2 quantile: the NIS below which a correct pairing of `dof` dimensions falls with
    probability `probability` (0.99, dof 2 -> 9.21)."""
    return float(chi2.ppf(probability, dof))
