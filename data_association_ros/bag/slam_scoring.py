"""Scores of a SLAM run against the bag's truth (no ROS).

Every landmark of the final slam_map has an identity: the true label of the observation it was
started from (its origin_stamp / origin_observation; CLUTTER or unknown for false landmarks).
Per scan and observation with certain truth t and answer a:
- a pairing (a >= 0) is correct when identity(a) == t >= 0;  recall's denominator counts the
  observations whose true landmark was in the map before the scan;
- a NEW answer is false when its landmark was already in the map (a NEW clutter return is
  right: nothing explains it; M-of-N confirmation keeps it out of the map, see `false`);
- correct / wrong / missed [% of the observations of the answered scans; `answered` says how
  many scans were], as the TTK4250 harness counts: correct =
  paired with its landmark, or not paired when its landmark is not in the map (clutter
  included); wrong = paired with another landmark; missed = not paired although its landmark is
  in the map.
Map: landmarks with a true identity seen first (right), again (duplicates), of clutter or
unknown origin (false); true landmarks observed but never mapped (missed).  With true landmark
positions: RMSE after the least-squares rigid alignment (Kabsch) of the right landmarks.  With
true poses: RMSE of the posterior positions after the rigid alignment of the trajectory.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Optional

import numpy as np

from ..core import NEW
from ..core.transforms import estimate_rigid_transform
from .datasets.sequence import CLUTTER
from .slam_run import SlamRun

NS_PER_S = 1_000_000_000


@dataclass
class SlamTruth:
    """The truth of a bag: per scan stamp the labels (K,) and certainty (K,) in time order,
    true landmark positions (id -> (2,)) and true poses (stamp -> (3,)) when known."""

    labels: dict[int, np.ndarray]
    certain: dict[int, np.ndarray]
    landmarks: dict[int, np.ndarray]
    poses: dict[int, np.ndarray]


def identities(final_map: Optional[np.ndarray], truth: SlamTruth) -> dict[int, tuple[int, int]]:
    """SLAM landmark id -> (true identity, origin stamp); identity CLUTTER when unknown."""
    out: dict[int, tuple[int, int]] = {}
    if final_map is None:
        return out
    for point in final_map:
        stamp = int(point['origin_stamp_sec']) * NS_PER_S + int(point['origin_stamp_nanosec'])
        index = int(point['origin_observation'])
        labels = truth.labels.get(stamp)
        label = int(labels[index]) if labels is not None and 0 <= index < len(labels) \
            else CLUTTER
        out[int(point['id'])] = (label, stamp)
    return out


def answer_identities(run: SlamRun, truth: SlamTruth) -> dict[int, tuple[int, int]]:
    """`identities` of the final map, plus those of the landmarks merged or dropped before
    the end (run.origins), so a pair with one of them is scored by what it was started from."""
    out = identities(run.final_map, truth)
    for landmark, (stamp, index) in run.origins.items():
        if landmark not in out:
            labels = truth.labels.get(stamp)
            label = int(labels[index]) if labels is not None and 0 <= index < len(labels) \
                else CLUTTER
            out[landmark] = (label, stamp)
    return out


def first_landmark_stamps(ids: dict[int, tuple[int, int]]) -> dict[int, int]:
    """True identity -> creation stamp of its first landmark."""
    first_of: dict[int, int] = {}
    for _, (label, stamp) in sorted(ids.items(), key=lambda item: item[1][1]):
        if label >= 0:
            first_of.setdefault(label, stamp)
    return first_of


def _scan_masks(stamp: int, labels: np.ndarray, answer: np.ndarray,
                ids: dict[int, tuple[int, int]], first_of: dict[int, int]):
    """(mapped, identity) per observation: its true landmark was in the map before the scan;
    the true identity of the landmark it was paired with (CLUTTER when none)."""
    mapped = np.array([label >= 0 and first_of.get(int(label), stamp) < stamp
                       for label in labels], dtype=bool)
    identity = np.array([ids.get(int(a), (CLUTTER, 0))[0] if a >= 0 else CLUTTER
                         for a in answer])
    return mapped, identity


def scan_outcomes(run: SlamRun, truth: SlamTruth) -> dict[int, tuple[int, int]]:
    """Per answered scan stamp: (wrong pairs, missed pairs) among its certain observations, as
    counted by `score_run`."""
    ids = answer_identities(run, truth)
    first_of = first_landmark_stamps(ids)
    out: dict[int, tuple[int, int]] = {}
    for stamp in sorted(truth.labels):
        labels, certain = truth.labels[stamp], truth.certain[stamp]
        answer = run.answers.get(stamp)
        if answer is None or len(answer) != len(labels):
            continue
        mapped, identity = _scan_masks(stamp, labels, answer, ids, first_of)
        is_pair = (answer >= 0) & certain
        wrong = int(is_pair.sum()) - int((is_pair & (identity == labels) & (labels >= 0)).sum())
        out[stamp] = (wrong, int(((answer < 0) & certain & mapped).sum()))
    return out


def score_run(run: SlamRun, truth: SlamTruth,
              rmse_exclude: Iterable[int] = ()) -> dict[str, float]:
    """The score table row of one run (see the module doc)."""
    every = answer_identities(run, truth)
    first_of = first_landmark_stamps(every)
    ids = identities(run.final_map, truth)
    paired = correct = in_map = new_false = clutter_paired = answered = observations = 0
    right_unpaired = missed = 0
    for stamp in sorted(truth.labels):
        labels, certain = truth.labels[stamp], truth.certain[stamp]
        answer = run.answers.get(stamp)
        if answer is None or len(answer) != len(labels):
            continue
        answered += 1
        observations += int(certain.sum())
        mapped, identity = _scan_masks(stamp, labels, answer, every, first_of)
        is_pair = (answer >= 0) & certain
        paired += int(is_pair.sum())
        correct += int((is_pair & (identity == labels) & (labels >= 0)).sum())
        in_map += int((mapped & certain).sum())
        new_false += int(((answer == NEW) & certain & mapped).sum())
        clutter_paired += int((is_pair & (labels == CLUTTER)).sum())
        unpaired = (answer < 0) & certain
        right_unpaired += int((unpaired & ~mapped).sum())
        missed += int((unpaired & mapped).sum())
    observed = {int(label) for stamp in truth.labels
                for label, sure in zip(truth.labels[stamp], truth.certain[stamp])
                if sure and label >= 0}
    labels_of_map = [label for label, _ in ids.values()]
    right = len({label for label in labels_of_map if label >= 0})
    false_landmarks = sum(1 for label in labels_of_map if label < 0)
    times = np.array(list(run.times_ms.values()))
    return {
        'pair_precision': correct / paired if paired else float('nan'),
        'pair_recall': correct / in_map if in_map else float('nan'),
        'new_false': new_false, 'clutter_paired': clutter_paired,
        'correct_percent': percent(correct + right_unpaired, observations),
        'wrong_percent': percent(paired - correct, observations),
        'missed_percent': percent(missed, observations),
        'answered': answered, 'scans': len(truth.labels),
        'landmarks': len(ids), 'landmarks_true': len(observed),
        'landmarks_right': right,
        'landmarks_duplicate': sum(1 for label in labels_of_map if label >= 0) - right,
        'landmarks_false': false_landmarks,
        'landmarks_missed': len(observed - set(labels_of_map)),
        'map_rmse_m': map_rmse(run.final_map, ids, truth.landmarks, set(rmse_exclude)),
        'pose_rmse_m': pose_rmse(run.poses, truth.poses),
        'time_median_ms': float(np.median(times)) if times.size else float('nan'),
        'time_p95_ms': float(np.percentile(times, 95)) if times.size else float('nan'),
    }


def percent(count: int, total: int) -> float:
    """100 count / total (NaN when total is 0)."""
    return 100.0 * count / total if total else float('nan')


def map_rmse(final_map: Optional[np.ndarray], ids: dict[int, tuple[int, int]],
             true_landmarks: dict[int, np.ndarray], exclude: set[int]) -> float:
    """RMSE [m] of the first landmark of each true identity after rigid alignment to the true
    map (NaN without a true map or with fewer than 3 landmarks)."""
    if final_map is None or not true_landmarks:
        return float('nan')
    chosen: dict[int, tuple[int, np.ndarray]] = {}
    for point in final_map:
        label, stamp = ids[int(point['id'])]
        if label in true_landmarks and label not in exclude and \
                (label not in chosen or stamp < chosen[label][0]):
            chosen[label] = (stamp, np.array([point['x'], point['y']], dtype=float))
    if len(chosen) < 3:
        return float('nan')
    labels = sorted(chosen)
    estimated = np.array([chosen[label][1] for label in labels])
    true = np.array([true_landmarks[label] for label in labels], dtype=float)
    transform = estimate_rigid_transform(estimated, true)
    residual = transform.apply(estimated) - true
    return float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1))))


def pose_rmse(poses: dict[int, np.ndarray], true_poses: dict[int, np.ndarray]) -> float:
    """RMSE [m] of the posterior robot positions over the scans with a true pose, after the
    least-squares rigid alignment of the whole trajectory (the absolute trajectory error: the
    map's anchor, fixed by the first landmarks' initialisation, is not observable)."""
    common = sorted(s for s in poses if s in true_poses)
    if len(common) < 3:
        return float('nan')
    estimated = np.array([poses[s][:2] for s in common])
    true = np.array([true_poses[s][:2] for s in common])
    residual = estimate_rigid_transform(estimated, true).apply(estimated) - true
    return float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1))))
