"""The multi-hypothesis experiment of Shelly & Indelman (RA-L 2022) on its ten-step scenario,
over many seeds: prints a markdown table and writes PNG figures.

    python benchmarks/multi_hypothesis_experiment.py [--seeds 20] [--out benchmarks/results/multi_hypothesis]

(a) hypotheses and their weights at k = 10, pruned (threshold 0.005) and pruned + merged;
(b) weight of the correct k = 1 hypothesis: w_{1|1}, and w_{1|10} from the tree sum and from the
    particle filter (S = 100, 1000); entropy of w_{1|j}, j = 1..10;
(c) run time of the sampled re-evaluation done at every step, naive versus incremental,
    cumulative up to p = 1..9 (S = 100);
(d) leaves before and after enhanced pruning with the sampled w_{1|10} (S = 1000).
Choices the paper leaves open: nearest landmark within 3 m observed (none beyond), field of view
3 m, prior covariance = the motion noise, merge threshold 1 (squared Mahalanobis).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from data_association_ros.core.multi_hypothesis import (HypothesisTree, ParticleReevaluation,
                                                        reevaluate_naive)
from data_association_ros.core.multi_hypothesis.scenario import (LANDMARKS, MEASUREMENT_NOISE,
                                                                 MOTION_NOISE, SENSING_RANGE,
                                                                 simulate)
from run_benchmarks import machine_line, table

ROOT = Path(__file__).resolve().parents[1]
PAPER = {'M1': 4, 'M10 pruned': 28, 'M10 merged': 4, 'w11': 0.33, 'w110': 0.97,
         'naive p=9 s': 24.0, 'incremental p=9 s': 5.0, 'pruning': '14 -> 10'}


def build(seed: int, merge: float = 0.0) -> tuple[HypothesisTree, list[int]]:
    poses, increments, observations, truth = simulate(seed)
    tree = HypothesisTree(LANDMARKS, poses[0], MOTION_NOISE, MOTION_NOISE, MEASUREMENT_NOISE,
                          fov_range=SENSING_RANGE, prune_threshold=0.005, merge_threshold=merge)
    for u, z in zip(increments, observations):
        tree.step(u, z)
    return tree, truth


def correct(tree: HypothesisTree, truth: list[int], weights: dict[int, float]) -> float:
    """Weight of the step-1 hypothesis that made the true decision (0 if it was pruned)."""
    return sum(w for q, w in weights.items() if tree.nodes[q].decision == truth[0])


def entropy(weights: dict[int, float]) -> float:
    w = np.array([v for v in weights.values() if v > 0])
    return float(-(w * np.log(w)).sum())


def partial(seed: int, steps: int) -> HypothesisTree:
    """The tree after `steps` steps (for w_{1|j})."""
    poses, increments, observations, _ = simulate(seed)
    tree = HypothesisTree(LANDMARKS, poses[0], MOTION_NOISE, MOTION_NOISE, MEASUREMENT_NOISE,
                          fov_range=SENSING_RANGE, prune_threshold=0.005)
    for u, z in list(zip(increments, observations))[:steps]:
        tree.step(u, z)
    return tree


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', type=int, default=20)
    parser.add_argument('--out', type=Path, default=ROOT / 'benchmarks' / 'results' /
                        'multi_hypothesis')
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = {k: [] for k in ('M1', 'M10', 'M10m', 'w11', 'w110', 'pf100', 'pf1000', 'before',
                            'after')}
    entropies = []
    naive_t = np.zeros((args.seeds, 9))
    incremental_t = np.zeros((args.seeds, 9))
    for seed in range(args.seeds):
        tree, truth = build(seed)
        rows['M1'].append(len(tree.at_step(1)))
        rows['M10'].append(len(tree.leaves))
        rows['M10m'].append(len(build(seed, merge=1.0)[0].leaves))
        rows['w11'].append(correct(tree, truth, {q: tree.nodes[q].weight
                                                 for q in tree.at_step(1)}))
        rows['w110'].append(correct(tree, truth, tree.reevaluate_exact(1)))
        for samples, key in ((100, 'pf100'), (1000, 'pf1000')):
            rows[key].append(correct(tree, truth, reevaluate_naive(tree, 1, 10, samples, seed)))
        entropies.append([entropy(partial(seed, j).reevaluate_exact(1)) for j in range(1, 11)])
        # re-evaluating at every step k = 2..10: cumulative time up to p = k - 1
        incremental = ParticleReevaluation(tree, 1, 100, seed)
        naive_total = incremental_total = 0.0
        for p in range(1, 10):
            started = time.perf_counter()
            reevaluate_naive(tree, 1, 1 + p, 100, seed)
            naive_total += time.perf_counter() - started
            naive_t[seed, p - 1] = naive_total
            started = time.perf_counter()
            incremental.advance_to(1 + p)
            incremental.weights()
            incremental_total += time.perf_counter() - started
            incremental_t[seed, p - 1] = incremental_total
        sampled = reevaluate_naive(tree, 1, 10, 1000, seed)
        rows['before'].append(len(tree.leaves))
        tree.prune_descendants(sampled, 0.005)
        rows['after'].append(len(tree.leaves))

    def spread(values, fmt='{:.2f}'):
        v = np.array(values, dtype=float)
        return f'{fmt.format(np.median(v))} ({fmt.format(v.min())}-{fmt.format(v.max())})'
    data = [
        ['hypotheses at k = 1', spread(rows['M1'], '{:.0f}'), PAPER['M1']],
        ['hypotheses at k = 10, pruned', spread(rows['M10'], '{:.0f}'), PAPER['M10 pruned']],
        ['hypotheses at k = 10, pruned + merged', spread(rows['M10m'], '{:.0f}'),
         PAPER['M10 merged']],
        ['correct k = 1 hypothesis: w_{1|1}', spread(rows['w11']), f'~{PAPER["w11"]}'],
        ['w_{1|10}, tree sum', spread(rows['w110']), f'~{PAPER["w110"]}'],
        ['w_{1|10}, particle filter S = 100', spread(rows['pf100']), ''],
        ['w_{1|10}, particle filter S = 1000', spread(rows['pf1000']), f'~{PAPER["w110"]}'],
        ['leaves before / after enhanced pruning (S = 1000)',
         f'{spread(rows["before"], "{:.0f}")} / {spread(rows["after"], "{:.0f}")}',
         PAPER['pruning']],
        ['re-evaluating at every step up to p = 9, naive / incremental (S = 100, ms)',
         f'{np.median(naive_t[:, 8]) * 1e3:.1f} / {np.median(incremental_t[:, 8]) * 1e3:.1f}',
         f'{PAPER["naive p=9 s"]:.0f} s / {PAPER["incremental p=9 s"]:.0f} s (Matlab)'],
    ]
    text = table(f'Multi-hypothesis re-evaluation, {args.seeds} seeds: median (min-max)',
                 ['quantity', 'ours', 'paper'], data)
    print(text)
    plot(args.out, np.array(entropies), naive_t, incremental_t, rows, build(0))
    sensitivity_text = sensitivity(args.seeds)
    print(sensitivity_text)
    (args.out / 'results.md').write_text(text + '\n' + sensitivity_text)
    return 0


def sensitivity(seeds: int) -> str:
    """How the unstated choices (prior sigma, field of view) move M_1, M_10, w_{1|1}, w_{1|10}."""
    data = []
    for prior in (0.5, 1.0, 2.0):
        for fov in (3.0, 4.0, 5.0):
            m1, m10, w11, w110 = [], [], [], []
            for seed in range(seeds):
                poses, increments, observations, truth = simulate(seed)
                tree = HypothesisTree(LANDMARKS, poses[0], np.diag([prior ** 2, prior ** 2, 1e-6]),
                                      MOTION_NOISE, MEASUREMENT_NOISE, fov_range=fov,
                                      prune_threshold=0.005)
                for u, z in zip(increments, observations):
                    tree.step(u, z)
                m1.append(len(tree.at_step(1)))
                m10.append(len(tree.leaves))
                w11.append(correct(tree, truth, {q: tree.nodes[q].weight
                                                 for q in tree.at_step(1)}))
                w110.append(correct(tree, truth, tree.reevaluate_exact(1)))
            data.append([prior, fov, float(np.median(m1)), float(np.median(m10)),
                         float(np.median(w11)), float(np.median(w110))])
    return table(f'Sensitivity to the choices the paper leaves open ({seeds} seeds, medians)',
                 ['prior sigma m', 'field of view m', 'M_1', 'M_10', 'w_{1|1}', 'w_{1|10}'],
                 data)


def plot(out: Path, entropies, naive_t, incremental_t, rows, single) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(2, 2, figsize=(10, 7.5))
    tree, truth = single
    weights = sorted((tree.nodes[i].weight for i in tree.leaves), reverse=True)
    axes[0, 0].bar(range(len(weights)), weights)
    axes[0, 0].set(title=f'(a) seed 0: {len(weights)} hypotheses at k = 10', xlabel='hypothesis',
                   ylabel='weight')
    axes[0, 1].boxplot([rows['w11'], rows['w110'], rows['pf100'], rows['pf1000']])
    axes[0, 1].set_xticks([1, 2, 3, 4], ['w1|1', 'w1|10 tree', 'w1|10 S=100', 'w1|10 S=1000'])
    axes[0, 1].set(title='(b) weight of the correct k = 1 hypothesis', ylim=(0, 1.05))
    j = np.arange(1, 11)
    axes[1, 0].plot(j, np.median(entropies, axis=0), marker='o')
    axes[1, 0].fill_between(j, entropies.min(axis=0), entropies.max(axis=0), alpha=0.2)
    axes[1, 0].set(title='(b) entropy of w_{1|j} (tree sum)', xlabel='j', ylabel='nats')
    p = np.arange(1, 10)
    axes[1, 1].plot(p, np.median(naive_t, axis=0) * 1e3, marker='o', label='naive (cumulative)')
    axes[1, 1].plot(p, np.median(incremental_t, axis=0) * 1e3, marker='o',
                    label='incremental (cumulative)')
    axes[1, 1].set(title='(c) re-evaluation time, S = 100', xlabel='p', ylabel='ms')
    axes[1, 1].legend()
    figure.suptitle(f'Multi-hypothesis re-evaluation ({machine_line()})', fontsize=9)
    figure.tight_layout()
    figure.savefig(out / 'experiment.png', dpi=100)
    plt.close(figure)


if __name__ == '__main__':
    sys.exit(main())
