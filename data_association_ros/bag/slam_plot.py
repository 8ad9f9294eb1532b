"""Pictures of a SLAM run (da_slam_eval --plot DIR): one PNG per bag, algorithm and mode.

Left panel: the final map and the trajectory.  When the bag has a true landmark map the
estimate is moved onto it by the least-squares rigid transform of its right landmarks (the one
the map RMSE uses); else, with true poses, by the rigid transform of the trajectory; else it is
drawn in its own frame.  Black circles: true landmarks; green dots: right landmarks (the first
of a true identity); orange crosses: duplicates (a second landmark of one true one); red
crosses: false landmarks (started from clutter); grey line: the true trajectory; blue line: the
posterior trajectory; red dots on it: the robot where a scan paired an observation with a wrong
landmark.  Right panel: wrong and missed pairs and duplicates, cumulative over the scans.

matplotlib (installed in the venv with trackeval) is imported only here, with the Agg backend.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from ..core.transforms import estimate_rigid_transform
from .slam_run import SlamRun
from .slam_scoring import SlamTruth, identities, scan_outcomes

MIN_ALIGNMENT_POINTS = 3


def alignment(run: SlamRun, truth: SlamTruth, ids: dict[int, tuple[int, int]],
              exclude: Iterable[int] = ()):
    """The rigid transform that takes the run's map frame onto the truth's (None when the bag
    has neither a true map nor true poses, or too few common points)."""
    exclude = set(exclude)
    if run.final_map is not None and truth.landmarks:
        first: dict[int, tuple[int, np.ndarray]] = {}
        for point in run.final_map:
            label, stamp = ids[int(point['id'])]
            if label in truth.landmarks and label not in exclude and \
                    (label not in first or stamp < first[label][0]):
                first[label] = (stamp, np.array([point['x'], point['y']], dtype=float))
        if len(first) >= MIN_ALIGNMENT_POINTS:
            labels = sorted(first)
            return estimate_rigid_transform(np.array([first[k][1] for k in labels]),
                                            np.array([truth.landmarks[k] for k in labels]))
    common = sorted(s for s in run.poses if s in truth.poses)
    if len(common) >= MIN_ALIGNMENT_POINTS:
        return estimate_rigid_transform(np.array([run.poses[s][:2] for s in common]),
                                        np.array([truth.poses[s][:2] for s in common]))
    return None


def plot_run(run: SlamRun, truth: SlamTruth, path: Path, title: str,
             exclude: Iterable[int] = ()) -> Path:
    """Write the picture of one run to `path` (PNG) and return it."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    ids = identities(run.final_map, truth)
    transform = alignment(run, truth, ids, exclude)

    def moved(points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return transform.apply(points) if transform is not None and len(points) else points

    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 5), dpi=80,
                                         gridspec_kw={'width_ratios': [1.4, 1]})
    if truth.poses:
        stamps = sorted(truth.poses)
        path_true = np.array([truth.poses[s][:2] for s in stamps])
        left.plot(path_true[:, 0], path_true[:, 1], color='0.6', lw=0.8, label='true path')
    stamps = sorted(run.poses)
    estimated_path = moved(np.array([run.poses[s][:2] for s in stamps]))
    if len(estimated_path):
        left.plot(estimated_path[:, 0], estimated_path[:, 1], color='tab:blue', lw=0.6,
                  label='estimated path')
    outcomes = scan_outcomes(run, truth)
    wrong_stamps = [s for s in stamps if outcomes.get(s, (0, 0))[0] > 0]
    if wrong_stamps:
        where = moved(np.array([run.poses[s][:2] for s in wrong_stamps]))
        left.plot(where[:, 0], where[:, 1], '.', color='red', ms=3,
                  label=f'wrong pair ({len(wrong_stamps)} scans)')
    if truth.landmarks:
        true_map = np.array(list(truth.landmarks.values()), dtype=float)
        left.plot(true_map[:, 0], true_map[:, 1], 'o', mfc='none', mec='k', ms=6,
                  label=f'true map ({len(true_map)})')
    if run.final_map is not None and len(run.final_map):
        means = moved(np.column_stack([run.final_map['x'], run.final_map['y']]))
        first: dict[int, int] = {}
        for landmark, (label, stamp) in sorted(ids.items(), key=lambda item: item[1][1]):
            if label >= 0:
                first.setdefault(label, landmark)
        kind = np.array(['false' if ids[int(i)][0] < 0 else
                         'right' if first[ids[int(i)][0]] == int(i) else 'duplicate'
                         for i in run.final_map['id']])
        for name, style, colour in (('right', '.', 'tab:green'), ('duplicate', 'x', 'orange'),
                                    ('false', 'x', 'red')):
            chosen = means[kind == name]
            if len(chosen):
                left.plot(chosen[:, 0], chosen[:, 1], style, color=colour, ms=5,
                          label=f'{name} ({len(chosen)})')
    left.set_aspect('equal', adjustable='datalim')
    left.set_xlabel('x [m]' + ('' if transform is not None else ' (estimate frame)'))
    left.set_ylabel('y [m]')
    left.legend(fontsize=7, loc='best', framealpha=0.7)
    left.set_title(title, fontsize=9)
    scan_stamps = sorted(truth.labels)
    wrong = np.cumsum([outcomes.get(s, (0, 0))[0] for s in scan_stamps])
    missed = np.cumsum([outcomes.get(s, (0, 0))[1] for s in scan_stamps])
    duplicates_at = sorted(stamp for landmark, (label, stamp) in ids.items()
                           if label >= 0 and first.get(label) != landmark) \
        if run.final_map is not None else []
    scan_index = {s: k for k, s in enumerate(scan_stamps)}
    right.plot(wrong, color='red', label='wrong pairs')
    right.plot(missed, color='tab:purple', label='missed pairs')
    right.plot([scan_index.get(s, 0) for s in duplicates_at],
               np.arange(1, len(duplicates_at) + 1), color='orange', label='duplicates')
    right.set_xlabel('scan')
    right.set_ylabel('cumulative count')
    right.legend(fontsize=7)
    right.grid(alpha=0.3)
    figure.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path)
    plt.close(figure)
    return path


def plot_name(bag: str, algorithm: str, mode: str, directory: Optional[Path] = None) -> Path:
    """DIR/<bag>_<algorithm>_<oracle|closed>.png"""
    name = f'{bag}_{algorithm}_{"oracle" if mode == "ground_truth" else "closed"}.png'
    return Path(directory) / name if directory is not None else Path(name)
