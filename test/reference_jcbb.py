"""A deliberately straightforward JCBB (Neira & Tardos 2001) to check the fast one against.

Observations in index order, candidates in index order, and at every node the joint innovation
covariance C = H P H^T + blockdiag(R) of all pairs so far is built from full Jacobians and
factorised from scratch.  Same definition of the answer as the fast one: the most pairs, then
the smallest joint NIS, among one-to-one sets of individually compatible pairs passing the
chi-square test of their own dimension.  Pruning (the textbook bound): a branch whose NIS
exceeds the threshold of the largest dimension it could still reach, or that cannot beat the
best, counting as reachable the later observations that still have a free compatible landmark.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from data_association_ros import NEW, UNASSOCIATED
from problem_factory import full_jacobian, innovation, joint_covariance


def reference_jcbb(landmarks, observations, pose, state_covariance, gate_probability=0.99):
    """(assignment (K,), joint NIS, nodes) of the straightforward JCBB."""
    k, n, m = len(observations), len(landmarks), observations.dim
    p = joint_covariance(landmarks, pose, state_covariance)
    jacobians = [full_jacobian(landmarks, observations, pose, j) for j in range(n)]
    nus = [[innovation(landmarks, observations, pose, i, j) for j in range(n)] for i in range(k)]

    def joint_nis(pairs):
        h = np.vstack([jacobians[j] for _, j in pairs])
        c = h @ p @ h.T
        for a, (i, _) in enumerate(pairs):
            c[a * m:(a + 1) * m, a * m:(a + 1) * m] += observations.covariances[i]
        nu = np.concatenate([nus[i][j] for i, j in pairs])
        factor = np.linalg.cholesky(c)
        w = np.linalg.solve(factor, nu)
        return float(w @ w)

    threshold = [chi2.ppf(gate_probability, m * l) if l else 0.0 for l in range(k + 1)]
    compatible = np.zeros((k, n), dtype=bool)
    for i in range(k):
        for j in range(n):
            compatible[i, j] = joint_nis([(i, j)]) <= threshold[1]
    best = {'pairs': [], 'nis': 0.0, 'nodes': 0}

    def search(i, pairs, nis):
        used = {j for _, j in pairs}
        free = [any(compatible[r, j] and j not in used for j in range(n)) for r in range(i, k)]
        reachable = len(pairs) + sum(free)
        if reachable < len(best['pairs']) or (reachable == len(best['pairs'])
                                              and nis >= best['nis']):
            return
        if pairs and nis > threshold[reachable]:
            return
        if i == k:
            return
        for j in range(n):
            if not compatible[i, j] or j in used:
                continue
            best['nodes'] += 1
            trial = pairs + [(i, j)]
            d2 = joint_nis(trial)
            if d2 <= threshold[len(trial)] and (
                    len(trial) > len(best['pairs'])
                    or (len(trial) == len(best['pairs']) and d2 < best['nis'])):
                best['pairs'], best['nis'] = trial, d2
            search(i + 1, trial, d2)
        search(i + 1, pairs, nis)

    search(0, [], 0.0)
    assignment = np.where(compatible.any(axis=1), UNASSOCIATED, NEW)
    for i, j in best['pairs']:
        assignment[i] = landmarks.ids[j]
    return assignment, best['nis'], best['nodes']
