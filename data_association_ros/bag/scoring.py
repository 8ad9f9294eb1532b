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
    landmarks: Optional['NewLandmarkScore'] = None

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
            **(self.landmarks.summary() if self.landmarks is not None else {}),
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
            'latency_p95_ms': float(np.percentile(latencies, 95)) if latencies.size
            else float('nan'),
            'latency_p99_ms': float(np.percentile(latencies, 99)) if latencies.size
            else float('nan'),
        }


class NewLandmarkScore:
    """Landmarks announced on new_landmarks against the truth.

    An object is what the truth's x, y (to the millimetre) identify: a landmark or a clutter
    return.  An announced landmark (one candidate id) is right when most of its confirming
    observations are labelled -1 (not yet in the map) and no earlier announcement was of the
    same object; otherwise it is false (clutter, a mapped landmark, or a duplicate).  The delay
    is the scans from the object's first -1 observation to the announcement.
    """

    def __init__(self, truth: dict[int, np.ndarray], truth_xy: dict[int, np.ndarray]) -> None:
        self.truth = truth
        self.objects = {stamp: [tuple(p) for p in np.round(np.asarray(xy) * 1000).astype(
            np.int64)] for stamp, xy in truth_xy.items()}
        self.scan_of = {stamp: k for k, stamp in enumerate(sorted(truth))}
        self.first_new: dict[tuple, int] = {}
        for stamp in sorted(truth):
            for label, key in zip(truth[stamp], self.objects[stamp]):
                if label == NEW:
                    self.first_new.setdefault(key, self.scan_of[stamp])
        self.announced: set[tuple] = set()
        self.right = 0
        self.false = 0
        self.duplicates = 0
        self.delays: list[int] = []

    def add(self, stamp: int, points: np.ndarray) -> None:
        """One new_landmarks message (its stamp, decoded points with candidate, observation,
        stamp_sec, stamp_nanosec)."""
        for candidate in np.unique(points['candidate']):
            rows = points[points['candidate'] == candidate]
            stamps = rows['stamp_sec'].astype(np.int64) * 1_000_000_000 + rows['stamp_nanosec']
            labels, keys = [], []
            for s, index in zip(stamps.tolist(), rows['observation'].tolist()):
                if s in self.truth and 0 <= index < len(self.truth[s]):
                    labels.append(self.truth[s][index])
                    keys.append(self.objects[s][index])
            new_keys = [k for label, k in zip(labels, keys) if label == NEW]
            key = max(set(new_keys), key=new_keys.count) if new_keys else None
            if key is None or 2 * len(new_keys) <= len(labels) or key in self.announced:
                self.false += 1
                self.duplicates += int(key in self.announced)
                continue
            self.announced.add(key)
            self.right += 1
            self.delays.append(self.scan_of[stamp] - self.first_new[key])

    def summary(self) -> dict[str, float]:
        """landmarks announced right and false (of which duplicates), true new landmarks never
        announced, median delay [scans]."""
        return {'landmarks_right': self.right, 'landmarks_false': self.false,
                'landmarks_duplicate': self.duplicates,
                'landmarks_missed': len(self.first_new) - self.right,
                'confirm_delay_scans': float(np.median(self.delays)) if self.delays
                else float('nan')}
