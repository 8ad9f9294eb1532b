"""Seed 003's LiDAR multi-object tracker: clusters -> coarse association -> fine point matching
(JCBB) -> rigid correction -> fictitious measurement -> Kalman update.

Per scan (points (K, 2) in scan order, seen from the origin; time t [s]):
1. cluster consecutive points (clustering.cluster_consecutive; a face seen at a grazing angle,
   its returns farther apart than cluster_gap, stays one cluster, unless two of them are farther
   apart than max_size_ratio x the prior length, and not past its far end: clustering.
   ends_receding) and flag each cluster end that
   is an object edge or occluded (clustering.cluster_ends; an end next to no return whose face
   would pass the sensor's range limit at the next beam is neither);
2. predict every track to t, its velocity turning with its yaw rate (measurement.
   turning_prediction, process_noise; with calm_yaw_accel_sigma two such models, calm and
   agile, mixed by an IMM: tracking.interacting_models); a cluster that holds the returns of
   two or more established tracks corrected on the previous scan is split between them by
   their predicted rectangles before its ends are flagged (shared_clusters.split_shared:
   objects side by side);
3. coarse: associate cluster centroids with the tracks' predicted centroids (the last cluster
   centroid in the object frame, moved with the predicted pose; covariance A P A^T +
   coarse_sigma^2 I + extent_covariance: the returns of another part of the object may show)
   by the registry associator `coarse`, the tracks corrected on the previous scan first, then
   the others with the clusters left (_tiers); a cluster left over whose centroid lies
   in a track's predicted rectangle (grown by cluster_gap) joins that track (an object split by
   an occluder is one object); in a full-turn scan, of the two clusters either side of the
   seam (_seam_pair: an object behind the sensor that moved between the scan's last and first
   beams) a track never corrected keeps one (_one_side);
4. fine: match (at most max_match_points of) the track's scan points with the predicted boundary
   points (fine.match: jcbb_points with the boundary's joint covariance, Cartesian or polar jNIS,
   or nearest); fewer than min_pairs pairs: no correction;
5. correct: estimate the rigid correction from the pairs (alignment: point_to_line, kabsch,
   ransac); form the fictitious measurement over the time since the track's last update and its
   noise (measurement); Kalman update with [x, y, yaw] (or, velocity_measurement, all six terms
   as the seed), unless it fails the filter's chi-square gate (with two motion models: that of
   each, InteractingModels.smallest_nis, so a manoeuvre's first measurements pass); its points
   having been moved back to the stamp by the predicted velocity v0, the position it reads is
   p + late (v - v0), late the points' mean offset (beam_time_measurement; a track started at
   rest has the matching covariance); a track with its heading settled and corrected on the
   previous scan also has them turned back by its predicted yaw rate w0 (at_stamp_points), so
   that the heading it reads is yaw + late (w - w0), not the heading at the beams' time; after
   the update they are moved back again with the corrected motion for the shape steps below;
6. the velocity settles the heading (heading_turn): when it points backwards (pi) or across
   (+-pi/2: a rectangle fit is ambiguous by 90 deg) on 3 updates in a row, the rectangle is
   turned round, or fitted anew along the velocity (shape.fit_at); before the heading is
   settled, the cluster's spread across the heading vetoes a turn across that would make the
   object wider than its size class allows, and turns the heading when the cluster already
   spreads across it that wide (plausible_turn); a track is reported only once
   its heading is settled so (or known too slow to tell on 3 updates in a row with its
   returns spreading across the heading within WIDTH_SLACK x the prior width on each, or after
   SETTLE_TIME unless its velocity is voting to turn it or the shape cancelled such a turn on
   its last correction, turning; a track settled as too slow is
   turned as an unsettled one once it moves: DIRECTION_TIME); a settled track's velocity and
   heading are then corrected towards each other (no_slip, slip_sigma); the rectangle grows or
   moves to
   contain the matched points (shape.contain), and is cut back where beams pass through it
   (free_space.carve: a prior longer than the object); once the corrections have turned the
   heading by more than EXTENT_SWING since the rectangle was fitted, it is fitted anew along
   the heading (what was grown and cut was along axes since found wrong);
7. a cluster no track took, or taken by a coasting track that it could not correct, starts a
   track (shape.fit_rectangle; velocity 0, uncertain) if it has min_pairs points, is not larger
   than max_size_ratio x the size class's prior length (walls are background) and is not
   occluded at both ends (a piece of wall seen between two objects' shadows slides with them:
   race seed 521, such a track at 6.8 m/s beside the car whose id it later took); the seam
   pair, both free, starts one track, from the side with more returns (_one_sweep), or, when
   that side starts none, each its own; a track not
   updated at t whose centre lies in the rectangle of one that was is dropped (the same object
   found again; a confirmed one gives its id to a newer track not yet confirmed), as is a
   track not updated for more than max_age seconds (max_hidden_age, for a confirmed track,
   while the beams towards it return from something nearer or it is out of their range:
   free_space.blocked_share, while its position std exceeds its length (vague: where to
   look for it is not known), or while it takes a cluster in the coarse association that it
   cannot correct yet: an object coming back into view at the edge of the field of view shows
   a few returns near its prediction, while the beams beside them pass through the rest);
8. two-point start: a track never corrected, fitted on the previous scan, whose one cluster it
   cannot match (an object that moved farther than the fine association reaches from a start
   at rest) is fitted anew to the cluster with the velocity of its two fitted centres
   (start_velocity, chi-square gated), weighed against the start at rest by the fits' noise
   over the time between them (fused_start_velocity);
9. hand-over: a track started at t within the same-object gate (chi-square on x, y, vx, vy,
   both covariances) of an established track (min_hits updates, or continuing an older id)
   not updated at t, either the coasting one that took its cluster in the coarse association
   but could not correct it or one updated at the previous scan, is that object found again:
   it takes the id and speed (handed_velocity) of the nearest (least d2) such track, which is
   dropped;
10. continuation: a track confirmed at t (its min_hits-th update) within the same-object gate of
   a confirmed track born before it and not updated at t takes that track's id, which is dropped.

Added to the seed (why: README "LiDAR object tracking"): the boundary is a rectangle model with
an estimated extent (completed by the size class's priors on the hidden side) sampled on its
visible faces, instead of accumulated scan points whose bounding box drifts and is not the
object's centre when only part of it was seen; the point_to_line correction; the correction's
covariance in R; the velocity left to the filter by default.  The tracking frame is the caller's:
points and the sensor position (step's `sensor`) in that frame (pipelines.lidar_tracking moves a
moving sensor's scans into the odometry frame); per-point times (`offsets`) move an object's
points back to the scan's stamp with its velocity (and, a settled track corrected on the
previous scan, turn them back with its yaw rate: step 5).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..api import associate
from ..errors import InvalidInputError
from ..gating import chi2_threshold
from ..models.base import wrap_angle
from ..tracking.interacting_models import InteractingModels
from ..tracking.kalman import KalmanFilter
from ..types import Landmarks, Observations
from .alignment import (J, Correction, EdgePoint, point_to_line_correction, rigid_correction)
from .clustering import cluster_consecutive, cluster_ends, on_face, turn_start
from .fine import boundary_covariance, match
from .free_space import (FACE_POINTS, beam_directions, beams, blocked_share, carve,
                         face_end_limit, near)
from .measurement import (fictitious_measurement, lateral_velocity, measurement_covariance,
                          process_noise, turning_prediction)
from .parameters import SIZE_CLASSES, TrackerConfig
from .shape import contain, corners, fit_at, fit_rectangle, rotation, sample_visible
from .shared_clusters import Boxes, split_shared

INITIAL_SIGMAS = (0.3, 0.3, 0.2, 10.0, 10.0, 1.0)
"""Std of a new track's fitted centre x, y (where it was when its points were taken), yaw, vx,
vy, yaw_rate (velocity unknown; _start)."""
FIT_SIGMA_PER_LENGTH = INITIAL_SIGMAS[0] / SIZE_CLASSES['car'][0]
"""Std of a fitted rectangle's centre per metre of prior length (0.3 m for a 4.5 m car, 37 mm
for a 0.55 m F1Tenth car): the two-point start's noise (fused_start_velocity)."""
MOTION = np.array([0, 1, 3, 4])
"""Indices of x, y, vx, vy in the state (the same-object gate's components)."""
MAX_COORDINATE = 1e5
"""Points farther than this [m] on either axis count as no return."""
FLIP_RATE = 0.25
"""Objects faster than this many of their prior lengths per second (1.1 m/s for a car, 0.14 m/s
for an F1Tenth car) are fast enough for their velocity to tell the heading (heading_turn)."""
SIGMAS_TO_TURN, VOTES_TO_TURN = 1.0, 3
"""The heading is turned (or confirmed) when the velocity points elsewhere (or the same way) by
more than 1 of its stds (the filter's velocity std is about 0.7 m/s at 40 Hz with accel_sigma 4,
far more than its actual error) on 3 updates in a row."""
CARVE_SHARE, CARVE_ANGLE = 0.1, np.deg2rad(20.0)
"""A beam cuts the rectangle's length (width) back only when it crosses the length (width) axis
at CARVE_ANGLE or more and its path through the rectangle runs along at least CARVE_SHARE of the
width (length), and 2 point_sigma (free_space.carve): a heading a few degrees off while the
object turns makes a beam along a face look as if it passed through the rectangle."""
EXTENT_SWING = np.deg2rad(20.0)
"""The extent is fitted anew (shape.fit_at, completed by the priors) once the corrections have
turned the heading by more than this since it was last fitted: it was grown and cut back along
axes now known to be wrong (a width cut to 0.06 m under a start heading 131 deg off, 49 deg
off the car's axis, stays so when only the other face is ever seen; a turning car whose yaw
rate lags may be fitted anew too, which costs nothing once it is seen)."""
SIZE_GROWTH = 1.5
"""_same_object: a newer track longer or wider than this times the older track (or the prior,
if larger) is not its object found again (car_static seed 111 object 3, coasting unseen with a
2.5 m position std: its id went to an 8.9 m piece of the wall 4.3 m from its prediction)."""
HIDDEN_SHARE = 0.9
"""A coasting track is hidden (kept up to max_hidden_age) when this share of the beams towards
its predicted rectangle return before reaching it."""
FACE_SIGMAS = 2.0
"""A cluster end is no edge when the next beam's return continues the face within FACE_SIGMAS
point_sigma of its line (clustering.on_face); such returns are one cluster (cluster_consecutive's
face_tolerance)."""
SPLIT_SIGMAS = 3.0
"""A return up to SPLIT_SIGMAS stds (point and predicted position) outside a track's predicted
rectangle may be that track's when a cluster shared by tracks is split (_claims)."""
CORNER_REACH = 1.5
"""point_to_line_correction's reach in boundary spacings with a one-to-one fine matching
(jcbb_points): a pair's face may be any visible face within it of the boundary point, the one
whose line is nearest to the scan point (nearest pairs each scan point with its own nearest
boundary point: no reach)."""
WIDTH_SLACK = 1.25
"""A cluster spread across the heading by more than WIDTH_SLACK x the prior width is no object's
width (car widths 1.6-2.0 m against a 1.8 m prior, F1Tenth 0.27-0.33 m against 0.30 m): a
velocity vote that would turn the heading so is cancelled (plausible_turn), and a track whose
returns spread so is not known to be too slow to tell (_update).  Turning a heading
on the shape alone takes a spread across it beyond the middle of the prior width and length
(3.15 m for a car, 0.425 m for an F1Tenth car): a heading a few degrees off adds a share of the
seen length to the spread across it (race seed 424: 0.38 m across an F1Tenth car 9 deg off).
None applies when WIDTH_SLACK x the prior width is not below the prior length (a
pedestrian's square prior: either axis fits)."""
TRUSTED_COAST_TURN = np.pi / 4
"""A coasting track whose predicted heading turned by more than this [rad] since its last
update no longer tells the axis of the object found again (_hand_over): the yaw rate of a bend
carried on past it (race seeds 0, 226, 609, 704, 1175: 80-167 deg turned over 0.8-1.9 s, the
fit right; the returns fitted again along the coasted heading were 90 deg off), while a
heading that turned 25-33 deg (car_static 1021, race 516, 1128, 1236, 1239) still did."""
SLOW_VOTE = -1.0
"""heading_turn's vote for "too slow to tell" (not a turn it can return)."""
SETTLE_TIME = 0.5
"""A track whose heading the velocity has not settled is reported after this time [s]."""
DIRECTION_TIME = 0.25
"""From this age [s] on, an unsettled track's velocity tells its heading once it exceeds the flip
speed, whatever its std: the filter's velocity std stays near its steady state (about 0.7 m/s,
see SIGMAS_TO_TURN) while the velocity itself holds still, so a slow object (an F1Tenth car at
0.8 m/s, whose flip speed is 0.14 m/s) never passed the 1-std test before SETTLE_TIME and was
reported with the fit's heading, pointing backwards (f1tenth_moving seeds 102 and 108: heading
RMSE 154 and 119 deg).  The same holds for a track settled as too slow to tell, its heading
from the shape alone and pointing either way: an F1Tenth car parked, then pulling away at
1 m/s^2, was turned round 0.7 s after it started, at 0.7 m/s, its heading 180 deg off over the
0.25 m it drove meanwhile (now at 0.15-0.2 m/s; docs/lidar.md "Twenty-ninth round").  Only a
heading the velocity told (ObjectTrack.told) needs the 1-std test to be turned."""

__all__ = ['LidarObjectTracker', 'ObjectTrack', 'fictitious_measurement', 'rotation']


@dataclass
class ObjectTrack:
    """A tracked rigid object: id, filter (state [x, y, yaw, vx, vy, yaw_rate] of the rectangle's
    centre), rectangle length and width [m], last cluster centroid in the object frame (anchor),
    update count, time [s] and posterior (x, y, yaw) of the last update, and this scan's matched
    scan points; continues: it took over an older track's id; swung [rad]: the net heading
    change by the corrections since the rectangle was last fitted (EXTENT_SWING); published:
    this track has been reported; settled: its heading is settled (heading_turn), told: by the
    velocity, not as too slow to tell; fitted: the centre (2,) of the rectangle last fitted to a
    cluster, where the object was when those beams were taken (the two-point start's first
    point; last is the posterior at the stamp); disputed: on its last correction the velocity
    voted VOTES_TO_TURN times in a row to turn its heading and the cluster's shape cancelled
    the turn (plausible_turn); it holds while the track coasts."""

    id: int
    filter: KalmanFilter | InteractingModels
    length: float
    width: float
    anchor: np.ndarray
    hits: int = 1
    updated: float = 0.0
    last: np.ndarray = field(default_factory=lambda: np.zeros(3))
    matched: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    settled: bool = False
    told: bool = False
    born: float = 0.0
    vote: float = 0.0
    votes: int = 0
    continues: bool = False
    swung: float = 0.0
    published: bool = False
    fitted: np.ndarray = field(default_factory=lambda: np.zeros(2))
    disputed: bool = False

    def continue_from(self, old: 'ObjectTrack') -> None:
        """Take over old's id (the same object, found again by this track)."""
        self.id, self.continues = old.id, True

    def corners(self, state: Optional[np.ndarray] = None) -> np.ndarray:
        """The rectangle's corners (4, 2) at the track's (or the given) state."""
        x = self.filter.x if state is None else state
        return corners(x[:2], x[2], self.length, self.width)

    def boundary(self, spacing: float, most: int,
                 sensor: np.ndarray = np.zeros(2)) -> np.ndarray:
        """Boundary points (n, 2): the faces visible from the sensor (2,), every <= spacing [m],
        the spacing widened so that there are at most about `most`."""
        perimeter = 2 * (self.length + self.width)
        return sample_visible(self.corners(), max(spacing, perimeter / 2 / most), sensor)

    def anchor_world(self) -> np.ndarray:
        """The predicted cluster centroid (2,)."""
        return self.filter.x[:2] + rotation(self.filter.x[2]) @ self.anchor


class LidarObjectTracker:
    """See the module docstring.  `step(points, time)` once per scan; `tracks` holds them all,
    `reported()` those updated on at least min_hits scans."""

    def __init__(self, config: Optional[TrackerConfig] = None) -> None:
        self.config = config or TrackerConfig()
        self.tracks: list[ObjectTrack] = []
        self.time: Optional[float] = None
        self.sensor = np.zeros(2)
        self._next_id = 1
        self._range_known = False
        self._full_turn, self._first_beam = False, 0

    @property
    def _margin(self) -> float:
        """The beams' free lengths end this far [m] before their returns: 2 point_sigma."""
        return 2 * self.config.point_sigma

    @property
    def _largest(self) -> float:
        """The longest object of the size class [m]: max_size_ratio x the larger prior;
        anything longer is background (walls)."""
        return self.config.max_size_ratio * max(self.config.priors())

    def configure(self, config: TrackerConfig) -> None:
        """New parameters, from the next scan (tracks are kept)."""
        self.config = config

    def reset(self) -> None:
        """Forget every track (time jumped backwards, e.g. a bag restarted)."""
        self.tracks, self.time = [], None

    def reported(self) -> list[ObjectTrack]:
        """Tracks updated on at least min_hits scans whose heading is settled (heading_turn) or
        that have been tracked for SETTLE_TIME, unless their velocity is voting to turn them
        or their heading is in dispute (turning: the heading they have is then known to be
        wrong, or may be: f1tenth_moving seed 325 object 2, hidden while its votes were
        counted, was reported pointing backwards)."""
        return [t for t in self.tracks if self._reportable(t, self.time)]

    def _reportable(self, track: ObjectTrack, time: float) -> bool:
        """Whether `track` is reported at `time` [s] (reported's rule)."""
        return track.hits >= self.config.min_hits and (
            track.settled or (time - track.born >= SETTLE_TIME and not turning(track)))

    def step(self, points: np.ndarray, time: float, sensor: Optional[np.ndarray] = None,
             offsets: Optional[np.ndarray] = None,
             directions: Optional[np.ndarray] = None,
             max_range: Optional[float] = None,
             origins: Optional[np.ndarray] = None,
             full_turn: bool = False) -> list[ObjectTrack]:
        """One scan at `time` [s]: points (K, 2) in scan order (non-finite = no return) in the
        tracking frame, seen from `sensor` (2,) (default: the origin), point k taken offsets[k]
        [s] after `time` (default 0; an object's points are moved back by its predicted
        velocity times their offset, and turned back by its yaw rate: _update), a beam without
        a return along the unit vector directions[k] (K, 2) (default:
        free_space.beam_directions; NaN: unknown, it tells nothing; a beam with a return runs
        from the sensor to its point), the sensor's
        range_max `max_range` [m] (None: unknown; a beam without a return is then free up to
        the scan's farthest return only, free_space.beams), origins (K, 2): where the sensor
        was when it took beam k (a moving sensor; default: `sensor` for every beam);
        full_turn: the last beam is followed by the first (a 360 deg scan): the beams are
        taken from clustering.turn_start on, so that an object behind the sensor, where the
        scan starts, is one cluster, and no cluster end counts as cut by the field of view.
        Raises InvalidInputError when time is not after the previous scan's.  Returns the
        reported tracks."""
        if not np.isfinite(time) or (self.time is not None and time <= self.time):
            raise InvalidInputError(f'time: {time!r} is not after the previous scan '
                                    f'({self.time!r})')
        config = self.config
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        self.sensor = np.zeros(2) if sensor is None else np.asarray(sensor, float).reshape(2)
        self._offsets = np.zeros(len(points)) if offsets is None else \
            np.asarray(offsets, float).reshape(len(points))
        with np.errstate(invalid='ignore'):
            points = np.where(np.abs(points) <= MAX_COORDINATE, points, np.nan)
        if directions is not None:
            directions = np.asarray(directions, float)
            if directions.shape != points.shape:
                raise InvalidInputError(f'directions: shape {directions.shape} is not the '
                                        f'points\' {points.shape}')
        self._origins = np.broadcast_to(self.sensor, points.shape) if origins is None else \
            np.asarray(origins, float).reshape(points.shape)
        self._full_turn, self._first_beam = bool(full_turn), 0
        if self._full_turn:  # each beam keeps its own time, origin and direction
            if directions is None:  # from the beam order (free_space.beams), before the turn
                directions = beam_directions(points - self._origins)
            start = turn_start(points, self._largest)
            self._first_beam = (len(points) - start) % max(len(points), 1)
            order = np.roll(np.arange(len(points)), -start)
            points, self._offsets, self._origins, directions = \
                points[order], self._offsets[order], self._origins[order], directions[order]
        self._rays = beams(points, self._origins, directions, self._margin, max_range)
        self._range_known = max_range is not None and bool(np.isfinite(max_range))
        dt = None if self.time is None else time - self.time
        before, self.time = self.time, time
        for track in self.tracks:
            predict(track.filter, dt, config, track.settled)
            track.matched = np.zeros((0, 2))
        labels = cluster_consecutive(points, config.cluster_gap, config.min_cluster_points,
                                     FACE_SIGMAS * config.point_sigma, self._largest,
                                     self.sensor)
        labels = split_shared(points, labels, self._claims(before), self._offsets,
                              config.min_pairs)
        ends, edges, occluded = cluster_ends(points, labels, config.edge_jump, self.sensor,
                                             max_range, self._full_turn)
        seam = self._seam_pair(points, labels)
        self._occluded = occluded
        count = len(ends)
        members = self._coarse(points, labels, count, before)
        free = np.ones(count, dtype=bool)
        if seam is not None:
            self._one_side(members, labels, seam, free)
        lost: dict[int, ObjectTrack] = {}  # cluster -> the established coasting track it failed
        for track_index, clusters in members.items():
            track = self.tracks[track_index]
            coasting = track.updated < before
            try:
                corrected = self._update(track, points, labels, clusters, ends, edges, time,
                                         track.settled and not coasting)
            except (InvalidInputError, np.linalg.LinAlgError):
                corrected = False  # degenerate pairs: no correction this scan
            if corrected:
                track.hits += 1
                track.updated = time
                track.last = track.filter.x[:3].copy()
            elif track.hits == 1 and len(clusters) == 1 and not coasting:  # two-point start
                piece, ends_hidden = self._one_sweep(labels, clusters[0], occluded)
                self._restart(track, points[piece], ends_hidden, time, self._late(piece))
            if track.updated == time or not coasting:
                free[clusters] = False
            elif self._established(track):
                lost.update({cluster: track for cluster in clusters})
        largest = self._largest
        self.tracks = [t for t in self.tracks if max(t.length, t.width) <= largest
                       and np.all(np.isfinite(t.filter.x)) and np.all(np.isfinite(t.filter.p))]
        taking = {id(t) for t in lost.values()}  # coasting, took a cluster it cannot correct
        self.tracks = [t for t in self.tracks if time - t.updated <= config.max_age
                       or (time - t.updated <= config.max_hidden_age and self._established(t)
                           and (id(t) in taking or self._hidden(t)))]
        self._continue_confirmed(time)
        self._drop_duplicates(time)
        paired = seam is not None and bool(free[list(seam)].all())  # the pair as one cluster
        starts = [(int(c), seam[1] if paired and c == seam[0] else None)
                  for c in np.flatnonzero(free) if not (paired and c == seam[1])]
        for cluster, partner in starts:
            started = self._start_from(points, labels, occluded, cluster, partner, time,
                                       before, lost)
            if partner is not None and not started:  # neither side as one: each on its own
                for piece in seam:
                    self._start_from(points, labels, occluded, piece, None, time, before,
                                     lost)
        reported = self.reported()
        for track in reported:
            track.published = True
        return reported

    def _start_from(self, points: np.ndarray, labels: np.ndarray, occluded: np.ndarray,
                    cluster: int, partner: Optional[int], time: float, before: Optional[float],
                    lost: dict) -> bool:
        """Step 7 and the hand-over (9) for one free cluster (with `partner`: the seam pair
        as one, _one_sweep): whether a track was started."""
        member, ends_hidden = self._one_sweep(labels, cluster, occluded, partner)
        whole = occluded[cluster] if partner is None else \
            [occluded[cluster, 0], occluded[partner, 1]]
        if np.count_nonzero(member) < self.config.min_pairs or np.all(whole):
            return False  # too few returns, or maybe background between two shadows
        late = self._late(member)
        started = self._start(points[member], ends_hidden, time, late)
        if started is None:
            return False
        failed = next((lost[c] for c in (cluster, partner) if c in lost), None)
        old = self._found_again(started, time, before, failed)
        if old is not None:
            self._hand_over(old, started, late, points[member], ends_hidden)
        return True

    def _late(self, member: np.ndarray) -> float:
        """How long [s] after this scan's stamp the returns `member` (mask or indices) were
        taken, on average: where a fit or a correction of them reads the object."""
        return float(np.mean(self._offsets[member]))

    def _beyond(self, index: int, count: int) -> Optional[int]:
        """The beam `index` next to a cluster end (one before its first or after its last) of
        a scan of `count` beams: itself inside the scan, round the seam in a full turn, else
        None (outside the field of view)."""
        if self._full_turn and count:
            return index % count
        return index if 0 <= index < count else None

    def _one_side(self, members: dict[int, list], labels: np.ndarray,
                  seam: tuple[int, int], free: np.ndarray) -> None:
        """A track never corrected (hits 1: no velocity to move the late returns back with)
        given both clusters of the seam pair keeps the one with more returns (the early one
        on a tie, as _one_sweep); the other is not free to start a track either."""
        counts = [np.count_nonzero(labels == cluster) for cluster in seam]
        dropped = seam[0] if counts[1] >= counts[0] else seam[1]
        for track_index, clusters in members.items():
            if self.tracks[track_index].hits == 1 and set(seam) <= set(clusters):
                clusters.remove(dropped)
                free[dropped] = False

    def _seam_pair(self, points: np.ndarray, labels: np.ndarray) -> Optional[tuple[int, int]]:
        """(the cluster ending at the seam, the one starting there) of a full-turn scan whose
        returns on either side of the seam (the scan's last and first beams, taken a scan
        period apart) are at most the prior length apart: one object that moved between them
        (at 10 m/s and 10 Hz, 1 m; the cut looks like a jump in range), or two objects side
        by side; else None."""
        first = self._first_beam
        if not first:
            return None
        late, early = int(labels[first - 1]), int(labels[first])
        step = float(np.hypot(*(points[first] - points[first - 1])))
        if late < 0 or early < 0 or late == early or step > self.config.priors()[0]:
            return None
        return late, early

    def _one_sweep(self, labels: np.ndarray, cluster: int, occluded: np.ndarray,
                   partner: Optional[int] = None) -> tuple[np.ndarray, np.ndarray]:
        """(member mask (K,), its ends' occluded flags (2,)) of the returns of `cluster` that a
        new rectangle is fitted to.  In a full-turn scan a cluster over the beam the sensor
        took first (an object behind the sensor) holds returns taken a whole scan period
        apart, between which a moving object moved (10 m/s at 10 Hz: 1 m); a fit to both is
        smeared by that much (car_static seed 2008 object 4 with a 10 Hz 360 deg LiDAR:
        velocity RMSE 1.51 m/s, 0.50 with one side).  Such a cluster gives the side with more
        returns, the end at that beam counted as occluded (completed by the priors); else the
        whole cluster with `occluded[cluster]`.  `partner`: the cluster starting at the seam
        when `cluster` ends there (_seam_pair), taken with it as one such cluster."""
        member = labels == cluster
        hidden = occluded[cluster].copy()
        if partner is not None:
            member |= labels == partner
            hidden[1] = occluded[partner, 1]
        first = self._first_beam
        if first and member[first - 1] and member[first]:
            early = member & (np.arange(len(labels)) >= first)  # taken after the stamp
            late = member & ~early  # at the scan's end
            if np.count_nonzero(early) >= np.count_nonzero(late):
                member, hidden[0] = early, True
            else:
                member, hidden[1] = late, True
        return member, hidden

    def _claims(self, before: Optional[float]) -> Boxes:
        """The predicted rectangles that may split a shared cluster (split_shared): of the
        established tracks corrected on the previous scan (`before`), margin SPLIT_SIGMAS x
        sqrt(point_sigma^2 + the largest variance of the predicted position)."""
        tracks = [t for t in self.tracks if corrected_since(t, before) and self._established(t)]
        states = np.array([t.filter.x for t in tracks]).reshape(-1, 6)
        spread = np.array([np.linalg.eigvalsh(t.filter.p[:2, :2])[-1] for t in tracks])
        return Boxes(states[:, :2], states[:, 2],
                     np.array([[t.length / 2, t.width / 2] for t in tracks]).reshape(-1, 2),
                     states[:, 3:5], SPLIT_SIGMAS * np.sqrt(self.config.point_sigma ** 2 + spread))

    def _found_again(self, new: ObjectTrack, time: float, before: Optional[float],
                     taken: Optional[ObjectTrack]) -> Optional[ObjectTrack]:
        """Of the confirmed tracks not updated at `time` that either took new's cluster in the
        coarse association but could not correct it (`taken`, coasting) or were updated at the
        previous scan `before`, the nearest (least d2) within _same_object's gate of the track
        `new` started at `time`, or None: the object `new` found again.  The one updated the
        scan before counts too (car_static seed 518: a 17.7 m wall-like track coasting for
        1.6 s, with the widest gate, took a car's cluster and handed the car's new track its id,
        while the car's own track, updated the scan before, lay 0.1 m away); a track coasting
        longer that did not take the cluster does not (race seeds 21 and 216: the opponents
        swapped ids)."""
        return self._nearest_same_object(new, [
            t for t in self.tracks if t.updated < time and self._established(t)
            and (t is taken or corrected_since(t, before))])

    def _hand_over(self, old: ObjectTrack, new: ObjectTrack, late: float = 0.0,
                   cluster: Optional[np.ndarray] = None,
                   occluded: Optional[np.ndarray] = None) -> None:
        """The track `new`, started near `old`'s prediction (_found_again) from `cluster` (K, 2;
        `occluded` its ends' flags), is the same object found again: it takes over old's id
        and old's speed, along new's length axis, the way nearer to old's velocity (while it
        coasted, the yaw rate turned old's prediction; the speed is what is left of it), and
        old is dropped.  Its pose and heading are new's fit, its centre moved back by that
        velocity x `late` [s] (where the fitted points were seen after the stamp, as in
        _start).  A fit across the heading old had settled, and not turned by more than
        TRUSTED_COAST_TURN since, is fitted again along old's axis when the cluster allows it
        (refit_along) and that rectangle's centre lies nearer to old's prediction: a few
        returns of a car coming back from behind something fit either axis (car_static seed
        1021 object 1: 5 returns at 29 m fitted 90 deg off, the car's speed handed across it),
        but fit_at extends them away from the sensor, which may be the wrong way
        (f1tenth_moving seed 1000 object 1, 2.4 m from the sensor: 0.5 m off).  Afterwards
        last is the posterior at the stamp and fitted the fit's centre, as after _restart."""
        self.tracks = [t for t in self.tracks if t is not old]
        new.continue_from(old)
        self._next_id -= 1
        if cluster is not None and old.settled and \
                abs(wrap_angle(old.filter.x[2] - old.last[2])) <= TRUSTED_COAST_TURN and \
                refit_along(new.filter.x[2], old.filter.x[2], cluster, self.config.priors()[1]):
            centre, yaw, length, width = fit_at(cluster, old.filter.x[2], *self.config.priors(),
                                                sensor=self.sensor, occluded=occluded)
            predicted = old.filter.x[:2]
            if np.hypot(*(centre - predicted)) < np.hypot(*(new.filter.x[:2] - predicted)):
                new.filter.x[:3] = [centre[0], centre[1], yaw]
                new.length, new.width = length, width
                new.anchor = anchor_in_box(cluster, centre, yaw)
                new.fitted = centre.copy()
        new.filter.x[3:5] = handed_velocity(old.filter.x[3:5], new.filter.x[2])
        new.filter.x[:2] -= late * new.filter.x[3:5]
        new.last = new.filter.x[:3].copy()

    def _established(self, track: ObjectTrack) -> bool:
        """Updated on min_hits scans, or continuing an older track's id (its object was
        reported): such a track coasting is kept while hidden or taking a cluster, and a track
        started from that cluster continues it (_found_again).  f1tenth_static seed 626 object
        1: the track handed its id when the car came back from behind another was corrected
        once (the offset of a fit of 5 returns read as 5.3 m/s for 1.5), then missed the car;
        with 2 updates it was neither kept nor continued, and a third track gave the car a new
        id."""
        return track.hits >= self.config.min_hits or track.continues

    def _same_object(self, old: ObjectTrack, new: ObjectTrack) -> Optional[float]:
        """d2 = e^T (P_old + P_new)^-1 e of e = new - old in (x, y, vx, vy), or None when it is
        outside the chi-square gate (gate_probability, 4 dof) or new's length or width is more
        than SIZE_GROWTH times old's (or the prior's, if larger): the newer track may be the
        older one's object (a coasting track's covariance has grown with its prediction)."""
        if np.any(np.array([new.length, new.width]) > SIZE_GROWTH * np.maximum(
                [old.length, old.width], self.config.priors())):
            return None
        index = np.ix_(MOTION, MOTION)
        error = new.filter.x[MOTION] - old.filter.x[MOTION]
        try:
            d2 = float(error @ np.linalg.solve(old.filter.p[index] + new.filter.p[index], error))
        except np.linalg.LinAlgError:
            return None
        return d2 if d2 <= chi2_threshold(self.config.gate_probability, len(MOTION)) else None

    def _nearest_same_object(self, new: ObjectTrack, candidates: list[ObjectTrack]
                             ) -> Optional[ObjectTrack]:
        """The candidate with the least _same_object d2 to `new` within its gate, or None."""
        gated = [(d2, t) for t in candidates
                 for d2 in [self._same_object(t, new)] if d2 is not None]
        return min(gated, key=lambda pair: pair[0])[1] if gated else None

    def _continue_confirmed(self, time: float) -> None:
        """A track confirmed at `time` (its min_hits-th update), or reported for the first time
        at `time`, not itself continuing another, that is within _same_object's gate of a
        confirmed track born before it and not updated at `time` continues it: it takes the
        nearest (least d2) such track's id, and that track is dropped (a young track started
        beside a coasting one took the object's returns when they came back).  The first report
        counts too: a track whose heading is still voting is not reported, so its id has not
        been seen (car_static seeds 1098 object 4 and 1106 object 4: a car's front face coming
        out of an occlusion, or its returns thinning at the range limit, was fitted 90 deg off,
        its centre 2 m from the coasting track's at confirmation; turned by its velocity two
        scans later, it lay on the old track, which it dropped as a duplicate, and the car took
        the new id)."""
        config = self.config
        for young in [t for t in self.tracks if t.updated == time and not t.continues
                      and self._id_still_open(t, time)]:
            old = self._nearest_same_object(young, [
                t for t in self.tracks
                if t.updated < time and t.born < young.born and t.hits >= config.min_hits])
            if old is not None:
                young.continue_from(old)
                self.tracks = [t for t in self.tracks if t is not old]

    def _id_still_open(self, track: ObjectTrack, time: float) -> bool:
        """Whether `track`, updated at `time`, may still continue an older track's id
        (_continue_confirmed): it has never been reported, and this is its min_hits-th update
        or its first report (a reported track keeps its id, also when min_hits is raised at
        run time or a min_hits 1 track is restarted)."""
        return not track.published and (track.hits == self.config.min_hits
                                         or self._reportable(track, time))

    def _hidden(self, track: ObjectTrack) -> bool:
        """Whether the track's predicted rectangle is hidden in this scan: at least
        HIDDEN_SHARE of the beams towards it end before it (something nearer hides it, or it
        is beyond max_range: free_space.blocked_share), none points at it (outside the
        field of view, or a scan whose beams without a return have no known direction), or
        its prediction is too vague to be looked for (vague).  f1tenth_static seed 416 object
        2: coasting 1.3 s out of the field of view, position std 3.7 m, its predicted
        rectangle came back into view 0.3 s before the car, 0.2 m ahead of it; the beams
        through the rectangle's corner dropped the track, and the car got a new id."""
        if vague(track):
            return True
        half = np.array([track.length, track.width]) / 2
        origins, directions, free, returned = self._body_rays(track, half)
        share = blocked_share(origins, directions, free, returned, self._range_known, -half,
                              half, self._margin)
        return share is None or share >= HIDDEN_SHARE

    def _body_rays(self, track: ObjectTrack, half: np.ndarray,
                   velocity: Optional[np.ndarray] = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(origins, directions (R, 2), free lengths, returned (R,)) of this scan's beams that
        can meet the track's rectangle (half extents `half` (2,)), in its frame; with
        `velocity` (vx, vy, w, cx, cy) each beam moved back by (vx, vy) x its time offset and
        turned back about (cx, cy) by -w x that offset, as the object's points are
        (at_stamp_points; free_space.near's circle grown by the largest move)."""
        x = track.filter.x
        r = rotation(x[2])
        directions, free, returned = self._rays
        moves = np.zeros((len(free), 2)) if velocity is None else \
            self._offsets[:, None] * velocity[:2]
        reach = float(np.hypot(*half)) + float(np.max(np.hypot(*moves.T), initial=0.0))
        rays = near(self._origins, directions, x[:2], reach)
        origins, directions = (self._origins[rays], directions[rays]) if velocity is None \
            else self._beams_at_stamp(rays, velocity)
        return (origins - x[:2]) @ r, directions @ r, free[rays], returned[rays]

    def _beams_at_stamp(self, index: np.ndarray, motion: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
        """(origins, directions) (n, 2) of the beams `index` (n,) moved back as the points of
        an object with `motion` (vx, vy, w, cx, cy) are: at_stamp_points about (cx, cy), the
        directions turned by -w x each beam's offset (with w 0, moved back only)."""
        late, directions = self._offsets[index], self._rays[0][index]
        if not motion[2]:
            return self._origins[index] - late[:, None] * motion[:2], directions
        return (at_stamp_points(self._origins[index], late, motion[3:5], motion[:3]),
                rotate(directions, -late * motion[2]))

    def _drop_duplicates(self, time: float) -> None:
        """Drop each track not updated at `time` whose centre lies in the rectangle of a track
        that was (the same object, found again by a newer track); a confirmed one dropped for a
        track not yet confirmed (nor continuing another) gives it its id."""
        updated = [t for t in self.tracks if t.updated == time]
        if not updated:
            return
        keep = []
        for track in self.tracks:
            if track.updated != time:
                inside = [other for other in updated
                          if np.all(np.abs((track.filter.x[:2] - other.filter.x[:2])
                                           @ rotation(other.filter.x[2]))
                                    <= [other.length / 2, other.width / 2])]
                if inside:
                    young = inside[0]
                    if track.hits >= self.config.min_hits and not self._established(young):
                        young.continue_from(track)
                    continue
            keep.append(track)
        self.tracks = keep

    def _coarse(self, points: np.ndarray, labels: np.ndarray, count: int,
                before: Optional[float]) -> dict[int, list]:
        """{track index: [cluster indices]} (step 3 of the module docstring; assigned tier by
        tier, _tiers)."""
        if not self.tracks or not count:
            return {}
        config = self.config
        sums = np.zeros((count, 2))
        inside = labels >= 0
        np.add.at(sums, labels[inside], points[inside])
        centroids = sums / np.bincount(labels[inside], minlength=count)[:, None]
        means, covariances = [], []
        for track in self.tracks:
            x = track.filter.x
            a = np.hstack([np.eye(2), (J @ rotation(x[2]) @ track.anchor)[:, None]])
            means.append(track.anchor_world())
            covariances.append(a @ track.filter.p[:3, :3] @ a.T
                               + config.coarse_sigma ** 2 * np.eye(2)
                               + extent_covariance(x[2], track.length, track.width))
        means, covariances = np.array(means), np.array(covariances)
        assignment = np.full(count, -1)
        for tier in self._tiers(before):
            open_clusters = np.flatnonzero(assignment < 0)
            if not len(tier) or not len(open_clusters):
                continue
            landmarks = Landmarks(tier, means[tier], covariances[tier])
            observations = Observations(centroids[open_clusters], np.broadcast_to(
                config.point_sigma ** 2 * np.eye(2), (len(open_clusters), 2, 2)), 'point_map')
            assignment[open_clusters] = associate(
                landmarks, observations, config.coarse,
                gate_probability=config.gate_probability).assignment
        members: dict[int, list] = {}
        for cluster, track_index in enumerate(assignment):
            if track_index >= 0:
                members.setdefault(int(track_index), []).append(cluster)
        leftover = np.flatnonzero(assignment < 0)
        if leftover.size:
            states = np.array([t.filter.x for t in self.tracks])
            halves = np.array([[t.length / 2, t.width / 2] for t in self.tracks]) \
                + config.cluster_gap
            delta = centroids[leftover][:, None, :] - states[None, :, :2]  # (L, T, 2)
            c, s = np.cos(states[:, 2]), np.sin(states[:, 2])
            body = np.stack([c * delta[..., 0] + s * delta[..., 1],
                             -s * delta[..., 0] + c * delta[..., 1]], axis=-1)
            within = np.all(np.abs(body) <= halves[None], axis=-1)
            distance = np.where(within, np.hypot(delta[..., 0], delta[..., 1]), np.inf)
            for row, cluster in enumerate(leftover):
                if within[row].any():
                    members.setdefault(int(np.argmin(distance[row])), []).append(int(cluster))
        return members

    def _tiers(self, before: Optional[float]) -> list[np.ndarray]:
        """Track indices in the order the coarse association serves them: the tracks corrected
        on the previous scan (`before`) first, then the others with the clusters left (a
        matching cascade: a prediction one scan old is the sharpest).  A track never corrected
        has a velocity std of 10 m/s, so after a few scans its predicted centroid gates anything
        within metres, and in one assignment with the rest (least total NIS, an unpaired
        cluster costing the gate) it took a car's cluster while the car's track took a wall's
        (f1tenth_moving seed 1025 object 1: the new track was restarted onto the car at 9 m/s
        and took its id).  A confirmed track coasting is not served first: its prediction is as
        vague (f1tenth_static seed 1060 object 3, out of view behind the sensor, would take
        another car's cluster and hand that car its id)."""
        recent = np.array([corrected_since(t, before) for t in self.tracks], dtype=bool)
        return [np.flatnonzero(recent), np.flatnonzero(~recent)]

    def _edges(self, points: np.ndarray, labels: np.ndarray, clusters: list,
               ends: np.ndarray, edges: np.ndarray) -> list[EdgePoint]:
        """EdgePoint of each cluster end flagged as an object edge, unless the face goes on
        there: the next beam out belongs to another of the object's clusters, or its return
        continues the face (on_face: a face seen at a grazing angle has its returns farther
        apart than cluster_gap and farther in range than edge_jump); and unless the end's last
        step is longer than cluster_gap (a grazing face kept in the cluster by the face rule:
        its last return lies up to a step short of the corner, and an edge there would pull a
        rectangle of the prior length back instead of telling the length)."""
        result = []
        for cluster in clusters:
            first, last = ends[cluster]
            if last - first < 1:
                continue
            for end, inner, outer, flagged in (
                    (first, first + 1, first - 1, edges[cluster, 0]),
                    (last, last - 1, last + 1, edges[cluster, 1])):
                if not flagged:
                    continue
                outer = self._beyond(outer, len(labels))
                inside = outer is not None
                if inside and labels[outer] in clusters:
                    continue
                step = points[end] - points[inner]
                spacing = float(np.hypot(*step))
                if spacing <= 0 or spacing > self.config.cluster_gap:
                    continue
                if inside and on_face(points[end], step / spacing, spacing, points[outer],
                                      FACE_SIGMAS * self.config.point_sigma):
                    continue
                result.append(EdgePoint(points[end], step / spacing, spacing))
        return result

    def _update(self, track: ObjectTrack, points: np.ndarray, labels: np.ndarray,
                clusters: list, ends: np.ndarray, edges: np.ndarray, time: float,
                turned: bool = False) -> bool:
        """Steps 4-6 for one track; False when the scan could not correct it (too few pairs,
        or the measurement outside the filter's gate); InvalidInputError or LinAlgError when
        the pairs are degenerate.  `turned`: the points are turned back by the yaw rate too,
        the predicted one for the correction, the corrected one for the shape steps (step
        passes it for a track settled and corrected on the previous scan:
        before the heading settles the yaw rate is a guess tens of deg/s off, and after
        coasting late^2 var(w) widened the gate enough to take a correction 40 deg off, read
        as 220 deg/s, car_static seed 2008 object 4 seen by 360_10hz)."""
        config = self.config
        x = track.filter.x
        compensation = motion_back(x, turned)
        member = np.isin(labels, clusters)
        moving = bool(np.any(self._offsets[member]))  # the object moved while the beam turned
        if moving:
            taken = points[member]
            points = points.copy()
            points[member] = at_stamp_points(taken, self._offsets[member], x[:2], compensation)
        scan = points[member]
        pick = evenly(len(scan), config.max_match_points)
        sample = scan[pick]
        boundary = track.boundary(config.boundary_spacing, config.max_boundary_points,
                                  self.sensor)
        low, high = sample.min(axis=0) - 1.0, sample.max(axis=0) + 1.0
        close = np.all((boundary >= low) & (boundary <= high), axis=1)
        boundary = boundary[close]
        joint = boundary_covariance(boundary, x[:2], track.filter.p[:3, :3], config.point_sigma)
        pairs = match(sample, boundary, joint, config.fine, config.jnis, config.point_sigma,
                      config.bearing_sigma, config.nearest_cutoff, config.gate_probability,
                      config.time_budget_ms, config.max_nodes, self.sensor)
        if len(pairs) < config.min_pairs:
            return False
        correction = self._correction(track, sample, boundary, pairs, points, labels,
                                      clusters, ends, edges)
        elapsed = time - track.updated
        z = fictitious_measurement(x[:2], x[2], track.last[:2], track.last[2], correction,
                                   elapsed)
        z[2] = x[2] + wrap_angle(z[2] - x[2])
        rows = slice(None) if config.velocity_measurement else slice(0, 3)
        # the points were moved back by the predicted velocity (and turned back by the
        # predicted yaw rate): z reads the pose at the stamp plus (v - predicted v, w -
        # predicted w) x the beams' mean offset (beam_time_measurement)
        h = beam_time_measurement(self._late(member), elapsed, turned)[rows]
        track.filter.h = h
        track.filter.r = measurement_covariance(correction.covariance, elapsed,
                                                config.measurement_sigmas())[rows, rows]
        measured = z[rows] + h @ x - x[rows]  # its innovation at x: z - x
        if isinstance(track.filter, InteractingModels):  # any model would take it
            nis = track.filter.smallest_nis(measured)
        else:
            innovation = z[rows] - x[rows]
            nis = innovation @ np.linalg.solve(track.filter.innovation_covariance(), innovation)
        if nis > chi2_threshold(config.gate_probability, len(measured)):
            return False
        before = x[2]
        track.filter.update(measured)
        x = track.filter.x
        if moving:  # moved back again, with the corrected motion
            compensation = motion_back(x, turned)
            points[member] = at_stamp_points(taken, self._offsets[member], x[:2], compensation)
            scan = points[member]
            sample = scan[pick]
        track.swung += wrap_angle(x[2] - before)
        prior_length, prior_width = config.priors()
        flip_speed = FLIP_RATE * max(prior_length, prior_width)
        turn, settled = heading_turn(x, track.filter.p[3:5, 3:5], flip_speed,
                                     SIGMAS_TO_TURN if track.told
                                     or time - track.born < DIRECTION_TIME else 0.0)
        # the velocity told (else: known to be too slow to tell)
        told = settled and (turn != 0.0 or np.hypot(x[3], x[4]) >= flip_speed)
        if settled and not told and WIDTH_SLACK * prior_width < prior_length and \
                across_spread(scan, x[2]) > WIDTH_SLACK * prior_width:
            # no object of the size class is that wide: its "width" may be its length coming
            # into view while it moves, so it is not known to be slow (car_static seed 6101
            # object 5)
            settled = False
        if settled:  # a turn, or too slow to tell, must hold on VOTES_TO_TURN updates in a row
            vote = turn if told else SLOW_VOTE
            track.votes = track.votes + 1 if vote == track.vote else 1
            track.vote = vote
            if track.votes < VOTES_TO_TURN:
                turn, settled = 0.0, False
        else:
            track.votes = 0
        shaped = plausible_turn(scan, x[2], x[3:5], turn, track.settled, prior_length,
                                prior_width)
        # a turn the velocity voted for and the shape cancelled: the heading is in dispute
        track.disputed = bool(turn) and not shaped
        if shaped != turn:  # the cluster's shape overrules the velocity's votes
            turn, settled, track.votes = shaped, False, 0
        track.settled = track.settled or settled
        track.told = track.told or (settled and told)
        track.matched = sample[pairs[:, 0]]
        if abs(turn) > 3:  # pointing backwards: the same rectangle, turned round
            x[2] += np.pi
            track.anchor = -track.anchor
        elif turn or abs(track.swung) > EXTENT_SWING:
            # the axes were mistaken, or the extent was cut along a heading since corrected:
            # the rectangle anew along the velocity (or the heading)
            hidden = self._occluded[clusters[0]] if len(clusters) == 1 else None
            centre, yaw, length, width = fit_at(scan, x[2] + turn, prior_length, prior_width,
                                                sensor=self.sensor, occluded=hidden,
                                                directed=True)
            x[:3] = [centre[0], centre[1], yaw]
            track.length, track.width, track.swung = length, width, 0.0
        x[2] = wrap_angle(x[2])
        if track.settled and not turn and config.slip_sigma > 0:
            no_slip(track.filter, config.slip_sigma)
        self._grow(track, track.matched, scan, compensation,
                   self._face_ends(points, labels, clusters, ends))
        return True

    def _correction(self, track: ObjectTrack, sample: np.ndarray, boundary: np.ndarray,
                    pairs: np.ndarray, points: np.ndarray, labels: np.ndarray,
                    clusters: list, ends: np.ndarray, edges: np.ndarray) -> Correction:
        config = self.config
        x = track.filter.x
        if config.transform == 'point_to_line':
            return point_to_line_correction(
                sample, boundary, pairs, track.corners(),
                self._edges(points, labels, clusters, ends, edges),
                x[:2], track.filter.p[:3, :3], config.point_sigma, sensor=self.sensor,
                reach=CORNER_REACH * config.boundary_spacing if config.fine != 'nearest' else 0.0)
        return rigid_correction(sample, boundary, pairs, x[:2], config.transform == 'ransac',
                                config.ransac_threshold)

    def _face_ends(self, points: np.ndarray, labels: np.ndarray, clusters: list,
                   ends: np.ndarray) -> list[tuple[np.ndarray, int]]:
        """(the returns next to a cluster end (m, 2), the end's last; the beam index past
        it) for each end of the track's clusters whose next beam is in the scan and is not
        one of the track's own clusters (face_end_limit's inputs)."""
        result = []
        for cluster in clusters:
            first, last = ends[cluster]
            member = np.flatnonzero(labels == cluster)
            if len(member) < 3:
                continue
            for outer, face in ((first - 1, member[:FACE_POINTS][::-1]),
                                (last + 1, member[-FACE_POINTS:])):
                outer = self._beyond(outer, len(labels))
                if outer is not None and labels[outer] not in clusters:
                    result.append((points[face], int(outer)))
        return result

    def _grow(self, track: ObjectTrack, matched: np.ndarray, scan: np.ndarray,
              compensation: np.ndarray, face_ends: list[tuple[np.ndarray, int]]) -> None:
        """Step 6: contain the matched points, then cut back what beams pass through
        (free_space.carve; the beams moved back with `compensation` (vx, vy, w, cx, cy), the
        motion the scan points were moved back with and the centre they were turned about) and
        where the beam past a face's end crosses its line (free_space.face_end_limit,
        `face_ends` from _face_ends); the anchor becomes this scan's centroid."""
        x = track.filter.x
        r = rotation(x[2])
        body = (matched - x[:2]) @ r
        shift, track.length, track.width = contain(body, track.length, track.width,
                                                   (self.sensor - x[:2]) @ r,
                                                   2 * self.config.point_sigma)
        x[:2] = x[:2] + r @ shift
        body = (scan - x[:2]) @ r
        seen_low, seen_high = body.min(axis=0), body.max(axis=0)
        half = np.array([track.length, track.width]) / 2
        origins, directions, free, returned = self._body_rays(track, half, compensation)
        low, high = carve(-half, half, seen_low, seen_high, origins, directions, free,
                          min_depth=self._margin, share=CARVE_SHARE,
                          min_sine=np.sin(CARVE_ANGLE), returned=returned,
                          margin=self._margin)
        beam_free = self._rays[1]
        for face, outer in face_ends:
            origin, direction = self._beams_at_stamp(np.array([outer]), compensation)
            found = face_end_limit((face - x[:2]) @ r, (origin[0] - x[:2]) @ r,
                                   direction[0] @ r, beam_free[outer], self.config.point_sigma)
            if found is not None:
                k, side, limit = found
                if side:
                    high[k] = max(min(high[k], limit), seen_high[k])
                else:
                    low[k] = min(max(low[k], limit), seen_low[k])
        track.length, track.width = high - low
        x[:2] = x[:2] + r @ ((low + high) / 2)
        track.anchor = anchor_in_box(scan, x[:2], x[2])

    def _fit(self, cluster: np.ndarray, occluded: np.ndarray
             ) -> Optional[tuple[np.ndarray, float, float, float, np.ndarray]]:
        """(centre (2,), yaw, length, width, anchor (2,)) of a new object from one cluster
        (shape.fit_rectangle), or None when it is background (longer than max_size_ratio x the
        prior length)."""
        config = self.config
        prior_length, prior_width = config.priors()
        largest = self._largest
        if np.hypot(*(cluster[-1] - cluster[0])) > np.sqrt(2) * largest:
            return None  # its ends are farther apart than the diagonal of any object this size
        centre, yaw, length, width = fit_rectangle(cluster, prior_length, prior_width,
                                                   sensor=self.sensor, occluded=occluded)
        if max(length, width) > largest:
            return None  # a wall or a building, not an object of this size class
        return centre, yaw, length, width, anchor_in_box(cluster, centre, yaw)

    def _start(self, cluster: np.ndarray, occluded: np.ndarray, time: float, late: float = 0.0
               ) -> Optional[ObjectTrack]:
        """A new track from one cluster, or None (background).  At rest; its points were taken
        `late` [s] after `time` (their mean offset), so the fitted centre c is the position at
        time + late, p + late v: with B = beam_time_measurement(late), x = B^-1 (c, 0) and P =
        B^-1 diag(INITIAL_SIGMAS^2) B^-T (var(x) = 0.3^2 + late^2 10^2, cov(x, vx) = -late 10^2)."""
        fit = self._fit(cluster, occluded)
        if fit is None:
            return None
        centre, yaw, length, width, anchor = fit
        x0, p0 = at_stamp(np.array([centre[0], centre[1], yaw, 0.0, 0.0, 0.0]),
                          np.square(INITIAL_SIGMAS), late)
        track = ObjectTrack(self._next_id, motion_filter(x0, p0, self.config), length, width,
                            anchor, updated=time, last=x0[:3].copy(), born=time,
                            fitted=np.array(centre, float))
        self.tracks.append(track)
        self._next_id += 1
        return track

    def _restart(self, track: ObjectTrack, cluster: np.ndarray, occluded: np.ndarray,
                 time: float, late: float = 0.0) -> None:
        """Two-point initialisation of a track never corrected (its start at rest could not
        be matched to the moved object) and fitted on the previous scan: fitted anew to
        `cluster`, velocity = the change of the fitted centre since the last fit / the time
        since (start_velocity), fused with the start at rest (fused_start_velocity), the
        initial covariance with the fused velocity variance.  Left as it is when the fit is
        background or the change is outside the gate.  step calls it only for a track fitted
        on the scan before: a fit from longer ago tells no velocity (car_static seed 3009
        object 1: a track that took over a coasting track's id was not corrected for 0.9 s,
        then took the car coming back into view 21 m from its fit, read as 22.8 m/s; the
        car's velocity RMSE was 5.10 m/s, 0.34 without the restart, the cluster then starting
        a track that _found_again hands the id).  The cluster's points were taken `late` [s]
        after `time` (their mean offset), so, as in _start, the fit reads the centre at time +
        late: x = B^-1 (centre, yaw, v, 0), P = B^-1 diag(variances) B^-T, B =
        beam_time_measurement(late) (an F1Tenth car at 5.8 m/s seen 50 ms into a 10 Hz scan
        is 0.29 m ahead of its fit's centre at the stamp: farther than nearest_cutoff, so
        without it the next scan could not be matched and the track restarted on every scan,
        never reported); the velocity is read from fit to fit (track.fitted)."""
        fit = self._fit(cluster, occluded)
        if fit is None:
            return
        centre, yaw, length, width, anchor = fit
        velocity = start_velocity(track.fitted, centre, time - track.updated,
                                  self.config.gate_probability)
        if velocity is None:
            return
        variances = np.square(INITIAL_SIGMAS)
        velocity, variances[3:5] = fused_start_velocity(
            velocity, time - track.updated, FIT_SIGMA_PER_LENGTH * max(self.config.priors()),
            INITIAL_SIGMAS[3])
        track.filter.x, track.filter.p = at_stamp(
            np.array([centre[0], centre[1], yaw, velocity[0], velocity[1], 0.0]), variances, late)
        track.length, track.width, track.anchor = length, width, anchor
        track.updated, track.last = time, track.filter.x[:3].copy()
        track.fitted = np.array(centre, float)
        track.votes = 0


def across_spread(points: np.ndarray, yaw: float) -> float:
    """The points' (K, 2) extent [m] across the heading yaw: ptp of points . (-sin yaw, cos yaw),
    the left normal (rotation(yaw)'s second column)."""
    return float(np.ptp(points @ rotation(yaw)[:, 1]))


def anchor_in_box(points: np.ndarray, centre: np.ndarray, yaw: float) -> np.ndarray:
    """The centroid of `points` (K, 2) in the frame of a rectangle at `centre` (2,) heading
    `yaw` [rad]: R(yaw)^T (mean - centre) (2,) [m], a track's anchor."""
    return (points.mean(axis=0) - centre) @ rotation(yaw)


def refit_along(yaw: float, old_yaw: float, cluster: np.ndarray, prior_width: float) -> bool:
    """Whether a rectangle fitted at `yaw` [rad] to `cluster` (K, 2) is to be fitted again along
    `old_yaw`, the settled heading of the track it continues (_hand_over): their axes more than
    45 deg apart (|wrap(2 (yaw - old_yaw))| > pi / 2; an axis, not a direction), the fit
    ambiguous (the cluster's extent along yaw, across_spread(yaw + pi / 2), within prior_width
    [m]: the fit could as well have taken it for the width) and the cluster's spread across
    old_yaw within WIDTH_SLACK x prior_width (race seed 1159: 5 returns 0.42 m along an
    F1Tenth car's side, its length, were fitted again as its end along a heading coasted
    0.8 s round a bend)."""
    return abs(wrap_angle(2 * (yaw - old_yaw))) > np.pi / 2 and \
        across_spread(cluster, yaw + np.pi / 2) <= prior_width and \
        across_spread(cluster, old_yaw) <= WIDTH_SLACK * prior_width


def plausible_turn(points: np.ndarray, yaw: float, velocity: np.ndarray, turn: float,
                   settled: bool, prior_length: float, prior_width: float) -> float:
    """The heading turn [rad] the cluster's points (K, 2) allow a track whose heading is not
    `settled` yet (WIDTH_SLACK): a turn across (+-pi/2) after which the points would spread
    across the heading wider than WIDTH_SLACK x prior_width is cancelled (0: a few returns of a
    car's side, fitted along its length, then voted across by a velocity whose early estimate is
    the fits' noise); when the points spread across the heading `yaw` beyond (prior_length +
    prior_width) / 2, and across yaw +- pi/2 within WIDTH_SLACK x prior_width, the heading is
    turned there, the way nearer to its velocity (2,) (a car coming out from behind something,
    its side fitted as its end: the growing side was read as a growing width, not as motion,
    and the track settled as too slow, its box 90 deg off).  Otherwise `turn` (a settled
    track's velocity, within its std, outweighs the shape: on lidar_two_cars with the polar
    jNIS a car whose box was 45 deg off was kept from turning)."""
    limit = WIDTH_SLACK * prior_width
    if settled or limit >= prior_length or abs(turn) > 3 or len(points) < 2:
        return turn
    if turn:
        return turn if across_spread(points, yaw + turn) <= limit else 0.0
    if across_spread(points, yaw) <= (prior_length + prior_width) / 2 or \
            across_spread(points, yaw + np.pi / 2) > limit:
        return turn
    return float(np.copysign(np.pi / 2, rotation(yaw)[:, 1] @ velocity))


def corrected_since(track: ObjectTrack, time: Optional[float]) -> bool:
    """Whether the track was updated at `time` [s] or later (the previous scan's time in
    step; None, no previous scan: False)."""
    return time is not None and track.updated >= time


def vague(track: ObjectTrack) -> bool:
    """Whether the track's predicted position is more uncertain than the track is large: the
    largest standard deviation of its (x, y) covariance [m] exceeds max(length, width).  Beams
    through its predicted rectangle then say little about where the object is."""
    return float(np.sqrt(np.linalg.eigvalsh(track.filter.p[:2, :2])[-1])) \
        > max(track.length, track.width)


def turning(track: ObjectTrack) -> bool:
    """Whether the track's last velocity votes (heading_turn, not yet VOTES_TO_TURN in a row)
    are for turning its heading, or its heading is in dispute (ObjectTrack.disputed: the votes
    were all cast and the shape cancelled the turn; f1tenth_static seed 5020 object 1 seen by
    360_10hz_coarse, a box fitted 0.47 x 0.43 m to a 0.55 x 0.30 m car, was reported at
    SETTLE_TIME 98 deg off while its velocity, 2.9 m/s with std 0.7, pointed within 10 deg of
    the truth; turned on the next scan)."""
    return not track.settled and (track.disputed or (
        track.votes > 0 and track.vote not in (0.0, SLOW_VOTE)))


def motion_filter(x: np.ndarray, p: np.ndarray, config: TrackerConfig
                  ) -> KalmanFilter | InteractingModels:
    """A new track's filter at (x (6,), P (6, 6)): one Kalman filter, or with
    calm_yaw_accel_sigma an IMM of the calm and the yaw_accel_sigma model, equally likely."""
    if config.calm_yaw_accel_sigma > 0:
        return InteractingModels(x, p, (0.5, 0.5), config.model_switch_time, angles=(2,))
    return KalmanFilter(x, p, np.eye(6), np.eye(6), np.eye(6), np.eye(6))


def predict(motion: KalmanFilter | InteractingModels, dt: float, config: TrackerConfig,
            settled: bool = True) -> None:
    """Predict the filter over dt [s]: the velocity turning with the yaw rate
    (turning_prediction), white (angular) acceleration (process_noise) of accel_sigma and
    yaw_accel_sigma (and the IMM's calm model: calm_yaw_accel_sigma, and, once the heading is
    `settled` (by the velocity, or as too slow to tell), calm_lateral_accel_sigma across it: a
    box still 90 deg off would hold the velocity back along its true direction)."""
    if isinstance(motion, InteractingModels):
        lateral = (config.calm_lateral_accel_sigma or None) if settled else None
        calm = process_noise(dt, config.accel_sigma, config.calm_yaw_accel_sigma, lateral,
                             motion.x[2])
        motion.predict(lambda x: turning_prediction(x, dt),
                       [calm, process_noise(dt, config.accel_sigma, config.yaw_accel_sigma)], dt)
        return
    predicted, motion.f = turning_prediction(motion.x, dt)
    motion.q = process_noise(dt, config.accel_sigma, config.yaw_accel_sigma)
    motion.predict()
    motion.x = predicted


def extent_covariance(yaw: float, length: float, width: float) -> np.ndarray:
    """(2, 2) R(yaw) diag((length/2)^2, (width/2)^2) R(yaw)^T [m^2]: the spread of where a
    cluster's centroid can lie about the track's anchor (the centroid of the returns last seen)
    when another part of the rectangle shows (the far end of a car, 4.5 m along it, seen after
    its near end: without it that cluster leaves the gate while a coasting track whose position
    std grew to metres takes it)."""
    r = rotation(yaw)
    return r @ np.diag([(length / 2) ** 2, (width / 2) ** 2]) @ r.T


def no_slip(motion: KalmanFilter | InteractingModels, sigma: float) -> None:
    """Correct with the pseudo-measurement that the velocity has no component across the
    heading (measurement.lateral_velocity: an object drives along its length axis), std sigma
    [m/s]: an EKF update with its full Jacobian, so heading, velocity and yaw rate move
    towards each other by their variances (a few returns of one face tell the heading to
    5-15 deg, the velocity of a car moving at speed tells it better; docs/lidar.md
    "Twenty-sixth round")."""
    r = np.array([[sigma ** 2]])
    if isinstance(motion, InteractingModels):
        motion.correct(lateral_velocity, r)
    else:
        motion.correct(*lateral_velocity(motion.x), r)


def handed_velocity(velocity: np.ndarray, yaw: float) -> np.ndarray:
    """The speed |velocity| (2,) along the axis yaw, forwards or backwards, whichever is nearer
    to velocity's direction (an object moves along its length axis)."""
    axis = np.array([np.cos(yaw), np.sin(yaw)])
    return float(np.hypot(*velocity)) * (1.0 if axis @ velocity >= 0 else -1.0) * axis


def rotate(vectors: np.ndarray, angles) -> np.ndarray:
    """Each vector (n, 2) (or one (2,)) turned by its angle (n,) (or one) [rad]: R(angle) v."""
    c, s = np.cos(angles), np.sin(angles)
    v = np.asarray(vectors, float)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def motion_back(x: np.ndarray, turned: bool) -> np.ndarray:
    """(vx, vy, w, cx, cy) of state x (6,) that a track's points are moved back with
    (at_stamp_points): its velocity, its yaw rate when `turned` (else 0) and its centre."""
    return np.array([x[3], x[4], x[5] if turned else 0.0, x[0], x[1]])


def at_stamp_points(points: np.ndarray, late: np.ndarray, centre: np.ndarray,
                    motion: np.ndarray) -> np.ndarray:
    """Points (n, 2) of an object taken `late` (n,) [s] after the stamp, moved to where they
    are on it at the stamp: c + R(-w late)(p - c - v late), for its centre c (2,) at the stamp
    and motion (vx, vy, w) [m/s, rad/s]."""
    late = np.asarray(late, float)
    return centre + rotate(points - centre - late[:, None] * motion[:2], -late * motion[2])


def beam_time_measurement(late: float, elapsed: float = np.inf, turned: bool = False
                          ) -> np.ndarray:
    """H (6, 6) of the fictitious measurement of a track whose points were taken `late` [s]
    after the stamp (their mean offset) and moved back by the predicted velocity v0: its
    position reads z = p + late (v - v0), i.e. z + late v0 = H x with H = I, H[0, 3] = H[1, 4]
    = late; its velocity (z - last) / elapsed (velocity_measurement; `elapsed` [s] since the
    last update) reads v + late (v - v0) / elapsed: H[3, 3] = H[4, 4] = 1 + late / elapsed.
    Without it (H = I), the start reads the object ahead by v late (its points not moved
    back); as the predicted velocity grows they are moved back more and the object seems to
    move less than it does (a car at 9.5 m/s seen 16 ms into the scan: 6.4 m/s after 2
    updates; with it 8.5; the same car scanned at one instant 9.3).  `turned`: the points were
    turned back by the predicted yaw rate w0 too, so the heading reads yaw + late (w - w0):
    H[2, 5] = late (and H[5, 5] = 1 + late / elapsed).  Without it a car turning at w is
    reported w late behind its heading (an F1Tenth car circling at 69 deg/s behind a 10 Hz
    scanner, late ~ 0.09 s: 4-6 deg); points turned back but H[2, 5] = 0 feed w0 back into
    the heading read, and the yaw rate of a car driving straight rang: -18, 39, -54, 73, -84
    deg/s on 5 scans (car_static seed 100 object 1 seen by 360_10hz)."""
    h = np.eye(6)
    h[0, 3] = h[1, 4] = late
    h[3, 3] = h[4, 4] = 1.0 + late / elapsed
    if turned:
        h[2, 5] = late
        h[5, 5] = 1.0 + late / elapsed
    return h


def at_stamp(fitted: np.ndarray, variances: np.ndarray, late: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """(x (6,), P (6, 6)) at the stamp of a state read from a fit (6,) of points taken `late`
    [s] after it, with independent variances (6,): x = B^-1 fitted, P = B^-1 diag(variances)
    B^-T, B = beam_time_measurement(late) (the fit's centre is p + late v)."""
    back = np.linalg.inv(beam_time_measurement(late))
    return back @ np.asarray(fitted, float), back @ np.diag(variances) @ back.T


def start_velocity(previous: np.ndarray, centre: np.ndarray, dt: float,
                   gate_probability: float) -> Optional[np.ndarray]:
    """Two-point velocity (2,) = (centre - previous) / dt of two fitted centres dt [s] apart,
    or None when the change is outside the chi-square gate of two independent fits (std
    INITIAL_SIGMAS[0] each) and a velocity of std INITIAL_SIGMAS[3] (a change no object of
    the prior's speeds makes)."""
    change = np.asarray(centre, float) - np.asarray(previous, float)
    variance = 2 * INITIAL_SIGMAS[0] ** 2 + (INITIAL_SIGMAS[3] * dt) ** 2
    if dt <= 0 or change @ change > chi2_threshold(gate_probability, 2) * variance:
        return None
    return change / dt


def fused_start_velocity(velocity: np.ndarray, dt: float, fit_sigma: float,
                         prior_sigma: float) -> tuple[np.ndarray, float]:
    """(velocity (2,) [m/s], its variance per axis [m^2/s^2]): the two-point velocity, whose
    noise is that of two fits fit_sigma [m] apart over dt [s], 2 fit_sigma^2 / dt^2, fused with
    the start at rest, 0 +- prior_sigma: gain g = prior_sigma^2 / (prior_sigma^2 + 2
    fit_sigma^2 / dt^2), velocity g v, variance (1 - g) prior_sigma^2.  Two fits of a car 25 ms
    apart tell its velocity to 17 m/s: a cluster growing as the car comes out from behind
    another moved the fitted centre 1.3 m, read as 53 m/s (car_static seed 112 object 4)."""
    prior = prior_sigma ** 2
    gain = prior / (prior + 2 * fit_sigma ** 2 / dt ** 2)
    return gain * np.asarray(velocity, float), (1 - gain) * prior


def heading_turn(state: np.ndarray, velocity_covariance: np.ndarray,
                 flip_speed: float = 1.0, sigmas: float = 3.0) -> tuple[float, bool]:
    """(turn, settled) from the velocity state[3:5] (covariance (2, 2)) in the rectangle's axes:
    v_u along the heading state[2], v_n across it, their stds s_u, s_n.  The larger component
    tells the turn: v_u > 0 none, v_u < 0 pi (pointing backwards), v_n +-pi/2 (the axes were
    mistaken: a rectangle fit is ambiguous by 90 deg, a car does not drive sideways); it counts
    when it exceeds flip_speed [m/s] and `sigmas` of its stds, else the turn is 0.  settled: the
    velocity told the heading, or the object is known to be too slow to tell (speed plus
    `sigmas` of its larger std below flip_speed: the shape is all there is).  A speed below
    flip_speed alone is not known to be slow: a track started at rest whose velocity is still
    rising to the object's (car_static seed 1126 object 1: 0.45, 0.68, 0.98 m/s with std 1.0
    on the 6th-8th updates, a 2.8 m/s car fitted 90 deg off) settled as too slow and was
    reported across its heading, 2.1 m off, until the velocity turned it 3 updates later."""
    c, s = np.cos(state[2]), np.sin(state[2])
    u, n = np.array([c, s]), np.array([-s, c])
    v_u, v_n = float(u @ state[3:5]), float(n @ state[3:5])
    s_u = float(np.sqrt(max(u @ velocity_covariance @ u, 0.0)))
    s_n = float(np.sqrt(max(n @ velocity_covariance @ n, 0.0)))
    along = abs(v_u) >= abs(v_n)
    value, sigma = (v_u, s_u) if along else (v_n, s_n)
    if abs(value) <= max(flip_speed, sigmas * sigma):
        slow = np.hypot(v_u, v_n) + sigmas * max(s_u, s_n) < flip_speed
        return 0.0, bool(slow)
    if along:
        return (0.0 if value > 0 else np.pi), True
    return float(np.copysign(np.pi / 2, value)), True


def evenly(count: int, most: int) -> np.ndarray:
    """Indices of at most `most` of `count` items, evenly spaced, first and last included."""
    if count <= most:
        return np.arange(count)
    return np.unique(np.linspace(0, count - 1, most).round().astype(int))
