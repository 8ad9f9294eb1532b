"""Counters and latency figures the node reports on /diagnostics (no ROS types)."""
from __future__ import annotations

from collections import Counter

import numpy as np

from ..core import NEW, UNASSOCIATED


class WarningThrottle:
    """Lets a warning per cause through at most once per `warn_period_s`."""

    def __init__(self, warn_period_s: float = 5.0) -> None:
        self.warn_period_s = warn_period_s
        self._last_warned: dict[str, float] = {}

    def should_warn(self, cause: str, now_s: float) -> bool:
        """True at most once per `warn_period_s` for each cause (throttled warnings)."""
        last = self._last_warned.get(cause)
        if last is not None and now_s - last < self.warn_period_s:
            return False
        self._last_warned[cause] = now_s
        return True


class AssociationStatistics(WarningThrottle):
    """Answered messages, outcomes per observation, skipped/invalid messages and fallbacks (a
    state_covariance that did not fit the map) by cause, latency."""

    def __init__(self, warn_period_s: float = 5.0) -> None:
        super().__init__(warn_period_s)
        self.answered = 0
        self.outcomes: Counter = Counter()
        self.skipped: Counter = Counter()
        self.invalid: Counter = Counter()
        self.fallbacks: Counter = Counter()   # answered, but with less than was sent
        self.truncated = 0
        self.pose_recoveries = 0
        self.refound = 0   # scans answered from a re-found pose (core/map_refinding.py)
        self.candidates_confirmed = 0
        self.candidates_expired = 0
        self.candidates_pending = 0
        self.latency_last_ms = float('nan')
        self.latency_max_ms = 0.0
        self._latency_sum_ms = 0.0

    def record_answer(self, assignment: np.ndarray, latency_ms: float, truncated: bool,
                      pose_recovered: bool = False) -> None:
        """One observation message answered (pose_recovered: by the widened second pass)."""
        self.answered += 1
        values = assignment.tolist()   # landmark ids (>= 0), NEW or UNASSOCIATED
        new, unassociated = values.count(NEW), values.count(UNASSOCIATED)
        self.outcomes['paired'] += len(values) - new - unassociated
        self.outcomes['new'] += new
        self.outcomes['unassociated'] += unassociated
        self.truncated += int(truncated)
        self.pose_recoveries += int(pose_recovered)
        self.latency_last_ms = latency_ms
        self.latency_max_ms = max(self.latency_max_ms, latency_ms)
        self._latency_sum_ms += latency_ms

    def record_candidates(self, confirmed: int, expired: int, pending: int) -> None:
        """Candidate landmarks after one answered message: confirmed and expired so far, pending
        now."""
        self.candidates_confirmed = confirmed
        self.candidates_expired = expired
        self.candidates_pending = pending

    def key_values(self) -> dict[str, object]:
        """Flat name -> value mapping for diagnostics."""
        mean = self._latency_sum_ms / self.answered if self.answered else float('nan')
        values: dict[str, object] = {
            'messages_answered': self.answered,
            'latency_last_ms': f'{self.latency_last_ms:.3f}',
            'latency_mean_ms': f'{mean:.3f}',
            'latency_max_ms': f'{self.latency_max_ms:.3f}',
            'observations_paired': self.outcomes['paired'],
            'observations_new': self.outcomes['new'],
            'observations_unassociated': self.outcomes['unassociated'],
            'search_truncations': self.truncated,
            'pose_recoveries': self.pose_recoveries,
            'map_refound': self.refound,
            'landmarks_confirmed': self.candidates_confirmed,
            'candidates_expired': self.candidates_expired,
            'candidates_pending': self.candidates_pending,
            'skipped_total': sum(self.skipped.values()),
            'invalid_total': sum(self.invalid.values()),
        }
        values.update({f'skipped_{cause}': n for cause, n in sorted(self.skipped.items())})
        values.update({f'invalid_{cause}': n for cause, n in sorted(self.invalid.items())})
        values.update({f'fallback_{cause}': n for cause, n in sorted(self.fallbacks.items())})
        return values
