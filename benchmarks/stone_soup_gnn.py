"""Stone Soup's GNNWith2DAssignment on a point_map problem, for comparison with `gnn`.

Tracks are the landmarks (GaussianState, a zero-noise random walk so the prediction is the
prior), detections share one LinearGaussian model with the observations' covariance, the
measure is SquaredMahalanobis (d2 = nu^T S^-1 nu, S = P + R, as ours) and missed_distance is the
chi-square gate.  Both then minimise the same total: sum of d2 over pairs + gate per unpaired
track (Stone Soup) or per unpaired observation (ours), which differ by a constant.
"""
from __future__ import annotations

import datetime

import numpy as np
from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
from stonesoup.hypothesiser.distance import DistanceHypothesiser
from stonesoup.measures import SquaredMahalanobis
from stonesoup.models.measurement.linear import LinearGaussian
from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, RandomWalk
from stonesoup.predictor.kalman import KalmanPredictor
from stonesoup.types.detection import Detection
from stonesoup.types.state import GaussianState
from stonesoup.types.track import Track
from stonesoup.updater.kalman import KalmanUpdater

from data_association_ros.core.gating import chi2_threshold

TIME = datetime.datetime(2026, 1, 1)


class StoneSoupGnn:
    """Stone Soup inputs built once (untimed), associate() timed."""

    def __init__(self, scene, gate_probability: float = 0.99) -> None:
        landmarks, observations = scene.landmarks, scene.observations
        if observations.model != 'point_map':
            raise ValueError('the Stone Soup comparison uses point_map problems')
        if not np.allclose(observations.covariances, observations.covariances[0]):
            raise ValueError('one measurement model: observations must share R')
        transition = CombinedLinearGaussianTransitionModel([RandomWalk(0.0), RandomWalk(0.0)])
        measurement = LinearGaussian(ndim_state=2, mapping=(0, 1),
                                     noise_covar=observations.covariances[0])
        self.associator = GNNWith2DAssignment(DistanceHypothesiser(
            KalmanPredictor(transition), KalmanUpdater(measurement), SquaredMahalanobis(),
            missed_distance=chi2_threshold(gate_probability, 2)))
        self.tracks = [Track([GaussianState(mean.reshape(2, 1), cov, timestamp=TIME)])
                       for mean, cov in zip(landmarks.means, landmarks.covariances)]
        self.detections = [Detection(value.reshape(2, 1), timestamp=TIME,
                                     measurement_model=measurement)
                           for value in observations.values]
        self.track_ids = {id(t): int(i) for t, i in zip(self.tracks, landmarks.ids)}
        self.detection_rows = {id(d): r for r, d in enumerate(self.detections)}

    def associate(self) -> dict:
        """Stone Soup's answer: track -> hypothesis."""
        return self.associator.associate(set(self.tracks), set(self.detections), TIME)

    def pairs(self, answer: dict) -> set[tuple[int, int]]:
        """{(observation row, landmark id)} of an answer."""
        return {(self.detection_rows[id(h.measurement)], self.track_ids[id(track)])
                for track, h in answer.items() if h}
