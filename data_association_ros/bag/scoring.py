"""Scores of answers against ground truth (no ROS): pairing precision and recall, new-landmark
events, clutter accepted, answered messages, latency."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..core import NEW


@dataclass
class Score:
    """Totals over a bag. Truth: id, -1 (not in the map yet), -2 (clutter)."""

    messages: int = 0
    answered: int = 0
    predicted_pairs: int = 0
    correct_pairs: int = 0
    true_pairs: int = 0
    new_events: int = 0
    correct_new: int = 0
    true_new: int = 0
    clutter: int = 0
    clutter_paired: int = 0
    latencies_ms: list = field(default_factory=list)

    def add(self, truth: np.ndarray, answer: Optional[np.ndarray],
            latency_ms: Optional[float] = None) -> None:
        """One observation message: its truth (K,) and the answer (K,) or None if unanswered."""
        self.messages += 1
        self.true_pairs += int((truth >= 0).sum())
        self.true_new += int((truth == NEW).sum())
        self.clutter += int((truth < NEW).sum())
        if answer is None:
            return
        if answer.shape != truth.shape:
            raise ValueError(f'answer has {answer.shape[0]} observations, truth {truth.shape[0]}')
        self.answered += 1
        paired = answer >= 0
        self.predicted_pairs += int(paired.sum())
        self.correct_pairs += int((paired & (answer == truth)).sum())
        self.new_events += int((answer == NEW).sum())
        self.correct_new += int(((answer == NEW) & (truth == NEW)).sum())
        self.clutter_paired += int((paired & (truth < NEW)).sum())
        if latency_ms is not None:
            self.latencies_ms.append(latency_ms)

    def summary(self) -> dict[str, float]:
        """precision, recall, new-landmark figures, clutter paired, answered, latency."""
        latencies = np.array(self.latencies_ms)

        def ratio(a, b):
            return a / b if b else float('nan')
        return {
            'pair_precision': ratio(self.correct_pairs, self.predicted_pairs),
            'pair_recall': ratio(self.correct_pairs, self.true_pairs),
            'new_correct': self.correct_new,
            'new_false': self.new_events - self.correct_new,
            'new_true': self.true_new,
            'clutter_paired': self.clutter_paired,
            'clutter': self.clutter,
            'answered': self.answered,
            'messages': self.messages,
            'latency_median_ms': float(np.median(latencies)) if latencies.size else float('nan'),
            'latency_p99_ms': float(np.percentile(latencies, 99)) if latencies.size
            else float('nan'),
        }
