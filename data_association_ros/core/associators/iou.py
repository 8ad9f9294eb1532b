"""iou: boxes matched one-to-one by largest total intersection over union (seed 004, 3.2)."""
import numpy as np
from scipy.optimize import linear_sum_assignment

from ..parameters import ParameterSpec
from ..types import NEW
from .base import NO_LANDMARK, Associator, result

IOU_THRESHOLD = ParameterSpec(
    'iou_threshold', 0.3, 'pairs with IoU below this are rejected', low=0.0, high=1.0)


def iou_matrix(boxes_a: np.ndarray, boxes_b: np.ndarray) -> np.ndarray:
    """IoU (K, N) of boxes (K, 4) and (N, 4) given as (centre x, centre y, width, height);
    0 where the union has no area."""
    half_a, half_b = boxes_a[:, None, 2:] / 2, boxes_b[None, :, 2:] / 2
    low = np.maximum(boxes_a[:, None, :2] - half_a, boxes_b[None, :, :2] - half_b)
    high = np.minimum(boxes_a[:, None, :2] + half_a, boxes_b[None, :, :2] + half_b)
    intersection = np.prod(np.clip(high - low, 0.0, None), axis=-1)
    union = (np.prod(boxes_a[:, 2:], axis=-1)[:, None] + np.prod(boxes_b[:, 2:], axis=-1)[None, :]
             - intersection)
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.where(union > 0, intersection / np.where(union > 0, union, 1.0), 0.0)


def run(problem, iou_threshold: float):
    """Maximise total IoU over one-to-one pairs with IoU >= threshold; unmatched are NEW."""
    overlap = iou_matrix(problem.observations.values, problem.landmarks.means)
    k, n = overlap.shape
    gated = overlap >= iou_threshold
    if iou_threshold == 0.0:
        gated &= overlap > 0.0
    columns = np.full(k, NO_LANDMARK, dtype=np.intp)
    if k and n and gated.any():
        cost = np.full((k, n + k), np.inf)
        cost[:, :n] = np.where(gated, -overlap, np.inf)
        cost[np.arange(k), n + np.arange(k)] = 0.0
        rows, cols = linear_sum_assignment(cost)
        real = cols < n
        columns[rows[real]] = cols[real]
    chosen = np.where(columns >= 0, overlap[np.arange(k), np.maximum(columns, 0)], np.nan) \
        if n else np.full(k, np.nan)
    return result(problem, 'iou', columns, gated, unmatched=NEW, iou=chosen)


ASSOCIATOR = Associator(
    name='iou', run=run, parameters=(IOU_THRESHOLD,), needs_covariances=False, models=('box',),
    summary='bounding boxes: one-to-one by largest IoU above a threshold (Hungarian)')
