"""split_shared: a cluster holding two tracked objects' returns, split by their predicted
rectangles; checked against the object each return was ray-cast from."""
import numpy as np
from hypothesis import given, settings, strategies as st

from data_association_ros.core.lidar.clustering import cluster_consecutive
from data_association_ros.core.lidar.raycast import raycast, rectangle_segments
from data_association_ros.core.lidar.shared_clusters import Boxes, _cuts, split_shared

ANGLES = np.deg2rad(np.arange(-135.0, 135.0, 0.25))
MIN_POINTS = 5


def scan_of(rectangles, angles=ANGLES):
    """(points (K, 2), which rectangle each return hit (K,), -1 none) of a LiDAR at the origin
    seeing rectangles [(centre, yaw, length, width)]."""
    segments = np.concatenate([rectangle_segments(np.asarray(c, float), yaw, length, width)
                               for c, yaw, length, width in rectangles])
    ranges, hit = raycast(np.zeros(2), angles, segments, 30.0)
    ranges = np.where(np.isfinite(ranges), ranges, np.nan)
    points = np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])
    return points, np.where(hit >= 0, hit // 4, -1)


def boxes_of(rectangles, margin=0.05, velocities=None):
    return Boxes(np.array([c for c, _, _, _ in rectangles], float),
                 np.array([yaw for _, yaw, _, _ in rectangles], float),
                 np.array([[length / 2, width / 2] for _, _, length, width in rectangles]),
                 np.zeros((len(rectangles), 2)) if velocities is None else
                 np.asarray(velocities, float),
                 np.full(len(rectangles), margin))


def assert_pieces_are_objects(labels, owner):
    """Every cluster holds one object's returns, and no object's returns are in two clusters."""
    for cluster in np.unique(labels[labels >= 0]):
        assert len(set(owner[labels == cluster])) == 1, (cluster, owner[labels == cluster])
    for obj in np.unique(owner[owner >= 0]):
        assert len(set(labels[owner == obj])) == 1, (obj, labels[owner == obj])


SEED_1013 = [((1.76, -0.15), 0.35, 0.60, 0.32), ((2.44, 0.30), 0.25, 0.55, 0.31)]
"""f1tenth_moving seed 1013 scan 88 about, in the sensor's frame: two cars in a convoy, the
left one 0.8 m ahead, its rear corner hidden behind the near car; the next return after the
near car's far corner is on the far car, 0.2 m away (70 and 32 returns)."""


def test_two_cars_in_a_convoy_are_one_cluster_until_split():
    """Their returns are within the 0.3 m cluster gap (one cluster); the split gives each car
    exactly its own returns.  With a post before them and one after (in scan order), the
    labels come out in scan order: post 0, near car 1, far car 2, post 3."""
    posts = [((2.0, -2.0), 0.0, 0.2, 0.2), ((1.0, 2.5), 0.0, 0.2, 0.2)]
    points, owner = scan_of(SEED_1013 + posts)
    labels = cluster_consecutive(points, 0.3, 3)
    assert len(np.unique(labels[(owner == 0) | (owner == 1)])) == 1  # merged
    split = split_shared(points, labels, boxes_of(SEED_1013), np.zeros(len(points)),
                         MIN_POINTS)
    assert_pieces_are_objects(split, owner)
    assert [split[owner == k][0] for k in (2, 0, 1, 3)] == [0, 1, 2, 3]


def test_a_cluster_of_one_tracked_object_is_left_whole():
    """One box, or a second box far from the cluster, or two boxes on the same object (a
    duplicate track: no return is only one box's): the labels are unchanged."""
    car = ((3.0, 0.0), 0.2, 0.55, 0.3)
    points, owner = scan_of([car])
    labels = cluster_consecutive(points, 0.3, 3)
    offsets = np.zeros(len(points))
    for rectangles in ([car], [car, ((3.0, 4.0), 0.0, 0.55, 0.3)],
                       [car, ((3.02, 0.01), 0.25, 0.55, 0.3)]):
        assert np.array_equal(split_shared(points, labels, boxes_of(rectangles), offsets,
                                           MIN_POINTS), labels)


def test_cuts_by_hand():
    """_cuts on scan-ordered owners: boxes [0, 1], owners 0 0 0 1 0 0 1 1 1 1: the cut at 6
    (one 1 before it, no 0 after it: cost 1; at 3 the cost is 2); boxes [2, 0, 1], owners
    2 2 0 0 0 1 1 1: cuts at 2 and 5 (cost 0)."""
    assert _cuts(np.array([0, 0, 0, 1, 0, 0, 1, 1, 1, 1]), [0, 1]) == [6]
    assert _cuts(np.array([2, 2, 0, 0, 0, 1, 1, 1]), [2, 0, 1]) == [2, 5]


def test_a_box_nearest_to_too_few_returns_gives_way_to_the_others():
    """A face of returns every 2 cm along x from 0 to 1 m (one cluster); box A over x 0-0.5,
    box B over 0.65-0.95 (margins 0.02 m), box C a point at (0.58, 0.08) with a margin of 0.095
    m.  The 5 returns at x 0.54-0.62 are within C's margin only, so all three claim the
    cluster, but each is nearer A or B (0.03-0.07 m) than C (0.08-0.09 m): C is dropped and
    the cluster is split between A and B (without the rule: a claimant with no returns, the
    cluster left whole)."""
    x = np.arange(0.0, 1.0001, 0.02)
    points = np.column_stack([x, np.zeros_like(x)])
    labels = cluster_consecutive(points, 0.3, 3)
    boxes = Boxes(np.array([[0.25, 0.0], [0.8, 0.0], [0.58, 0.08]]), np.zeros(3),
                  np.array([[0.25, 0.05], [0.15, 0.05], [0.0, 0.0]]), np.zeros((3, 2)),
                  np.array([0.02, 0.02, 0.095]))
    split = split_shared(points, labels, boxes, np.zeros(len(points)), MIN_POINTS)
    assert len(np.unique(split)) == 2
    assert len(set(split[x <= 0.52])) == 1 and len(set(split[x >= 0.63])) == 1
    assert split[0] != split[-1]


def test_a_return_is_moved_back_by_its_box_velocity_before_it_is_compared():
    """A box at the origin (0.55 x 0.3, yaw 0) driving at 4 m/s along x: a return 0.08 m past
    its front face taken 0.02 s after the stamp is on the face once moved back (distance 0),
    0.08 m away from a box at rest; a return at the stamp is compared where it is."""
    moving = Boxes(np.zeros((1, 2)), np.zeros(1), np.array([[0.275, 0.15]]),
                   np.array([[4.0, 0.0]]), np.array([0.01]))
    resting = Boxes(moving.centres, moving.yaws, moving.halves, np.zeros((1, 2)),
                    moving.margins)
    points = np.array([[0.355, 0.0], [0.355, 0.0]])
    offsets = np.array([0.02, 0.0])
    assert np.allclose(moving.distances(points, offsets)[:, 0], [0.0, 0.08])
    assert np.allclose(resting.distances(points, offsets)[:, 0], [0.08, 0.08])


@settings(max_examples=200, deadline=None)
@given(st.floats(1.0, 8.0), st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi),
       st.floats(0.1, 0.25), st.floats(-0.5, 0.5), st.floats(0.4, 0.6), st.floats(0.25, 0.35))
def test_split_matches_the_ray_cast_objects(distance, bearing, yaw, gap, shift, length, width):
    """Two parallel cars side by side (`gap` [m] between them, one shifted along its length by
    `shift`) anywhere around the sensor (about one draw in five gives a shared cluster): whenever
    a cluster holds at least min_points returns of each, splitting it by the true rectangles
    (margin 0.05 m, at most half the gap) gives
    every return to the car it was cast from (brute force: the ray caster's segment index), and
    the other clusters are unchanged."""
    centre = distance * np.array([np.cos(bearing), np.sin(bearing)])
    across = (width + gap) * np.array([-np.sin(yaw), np.cos(yaw)])
    along = shift * np.array([np.cos(yaw), np.sin(yaw)])
    rectangles = [(tuple(centre), yaw, length, width),
                  (tuple(centre + across + along), yaw, length, width)]
    points, owner = scan_of(rectangles)
    labels = cluster_consecutive(points, 0.3, 3)
    split = split_shared(points, labels, boxes_of(rectangles), np.zeros(len(points)),
                         MIN_POINTS)
    for cluster in np.unique(labels[labels >= 0]):
        inside = labels == cluster
        counts = np.bincount(owner[inside & (owner >= 0)], minlength=2)
        if np.all(counts >= MIN_POINTS):   # shared: split by object
            for obj in (0, 1):
                assert len(set(split[inside & (owner == obj)])) == 1
            assert split[inside & (owner == 0)][0] != split[inside & (owner == 1)][0]
        else:                              # one object's: whole, nothing added to it
            assert len(set(split[inside])) == 1
            assert np.array_equal(split == split[inside][0], inside)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_reaching_keeps_every_box_a_cluster_return_lies_within(seed):
    """Boxes.reaching against brute force: random clusters and boxes (some moving, returns
    taken up to 25 ms after the stamp); every box that holds a moved-back return of a cluster
    within its margin (distances) is kept for that cluster, and a box is kept exactly when its
    centre lies within the cluster's circle grown as the docstring says."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(-3.0, 3.0, size=(60, 2))
    labels = rng.integers(-1, 4, size=60)
    offsets = rng.uniform(0.0, 0.025, size=60)
    boxes = Boxes(rng.uniform(-3.0, 3.0, size=(5, 2)), rng.uniform(-np.pi, np.pi, 5),
                  rng.uniform(0.1, 1.0, size=(5, 2)), rng.normal(0.0, 5.0, size=(5, 2)),
                  rng.uniform(0.0, 0.3, 5))
    count = int(labels.max()) + 1
    reaching = boxes.reaching(points, labels, offsets, count)
    assert reaching.shape == (count, 5)
    near = boxes.distances(points, offsets) <= boxes.margins[None]
    for cluster in range(count):
        member = labels == cluster
        if not member.any():
            continue
        assert np.all(reaching[cluster] >= near[member].any(axis=0))
        mean = points[member].mean(axis=0)
        reach = np.max(np.hypot(*(points[member] - mean).T)) + np.hypot(*boxes.halves.T) \
            + boxes.margins + np.hypot(*boxes.velocities.T) * np.max(offsets[member])
        gap = np.hypot(*(boxes.centres - mean).T)
        decided = np.abs(gap - reach) > 1e-9
        assert np.array_equal(reaching[cluster][decided], (gap <= reach)[decided])
