"""LiDAR ray casting and clustering against hand-computed scenes."""
import numpy as np

from data_association_ros.core.lidar import cluster_consecutive, raycast, rectangle_segments


def test_ray_hits_the_near_side_of_a_rectangle_and_misses_beyond_range():
    box = rectangle_segments(np.array([5.0, 0.0]), 0.0, length=2.0, width=1.0)
    ranges, hit = raycast(np.zeros(2), np.array([0.0, np.pi, np.arctan2(0.5, 4.0)]), box, 10.0)
    assert ranges[0] == 4.0 and np.isinf(ranges[1]) and hit[1] == -1
    assert ranges[2] == np.hypot(4.0, 0.5)  # the corner (4, 0.5)
    short, _ = raycast(np.zeros(2), np.array([0.0]), box, 3.0)
    assert np.isinf(short[0])


def test_rotated_rectangle_corners():
    box = rectangle_segments(np.array([1.0, 2.0]), np.pi / 2, length=4.0, width=2.0)
    corners = box[:, 0, :]
    np.testing.assert_allclose(sorted(map(tuple, np.round(corners, 9))),
                               sorted([(0, 0), (2, 0), (0, 4), (2, 4)]), atol=1e-9)


def test_nearest_of_two_walls_wins():
    walls = np.array([[[3.0, -5], [3.0, 5]], [[6.0, -5], [6.0, 5]]])
    ranges, hit = raycast(np.zeros(2), np.array([0.0, np.pi / 4]), walls, 20.0)
    np.testing.assert_allclose(ranges, [3.0, 3.0 * np.sqrt(2)])
    np.testing.assert_array_equal(hit, [0, 0])


def test_consecutive_clustering_splits_on_gaps_and_invalid_returns():
    points = np.array([[0, 0], [0.1, 0], [0.2, 0], [2, 0], [2.1, 0], [np.inf, np.inf],
                       [2.2, 0], [5, 5]], dtype=float)
    np.testing.assert_array_equal(cluster_consecutive(points, gap=0.5),
                                  [0, 0, 0, 1, 1, -1, 2, 3])
    np.testing.assert_array_equal(cluster_consecutive(points, gap=0.5, min_points=2),
                                  [0, 0, 0, 1, 1, -1, -1, -1])
    assert np.all(cluster_consecutive(np.full((3, 2), np.nan), 0.5) == -1)


def scan_points(scan):
    """LaserScan -> (K, 2) points in the laser frame (inf ranges stay inf)."""
    ranges = np.asarray(scan.ranges, dtype=float)
    angles = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    with np.errstate(invalid='ignore'):
        return np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])


def test_lidar_bag_regenerates_and_each_car_is_one_cluster(tmp_path):
    from pathlib import Path

    from data_association_ros.bag.make_bags import make_bag
    from data_association_ros.bag.reader import BagReader
    from msg_adapters import cloud_to_array
    from test_bags import assert_same_message
    bags = Path(__file__).resolve().parents[1] / 'bags'
    fresh = list(BagReader(make_bag('lidar_two_cars', tmp_path)).messages())
    committed = list(BagReader(bags / 'lidar_two_cars').messages())
    assert len(fresh) == len(committed) == 2 * 120
    for a, b in zip(fresh[:6], committed[:6]):
        assert_same_message(a.msg, b.msg, a.topic)
    for scan, truth in ((committed[0].msg, committed[1].msg), (committed[80].msg,
                                                                committed[81].msg)):
        points = scan_points(scan)
        labels = cluster_consecutive(points, gap=0.3, min_points=3)
        cars = cloud_to_array(truth)
        nearest = []
        for car in cars:
            centres = np.array([points[labels == c].mean(axis=0) for c in range(labels.max() + 1)])
            distance = np.hypot(*(centres - [car['x'], car['y']]).T)
            nearest.append(int(np.argmin(distance)))
            assert distance.min() < 2.5  # the visible sides' centroid is within half a car
        assert nearest[0] != nearest[1]


def test_fictitious_measurement_recovers_a_known_rigid_motion():
    from data_association_ros.core.lidar.object_tracker import fictitious_measurement, rotation
    from data_association_ros.core.transforms import estimate_rigid_transform
    body = rectangle_segments(np.zeros(2), 0.0, 4.0, 1.8).reshape(-1, 2)
    centre, yaw, dt = np.array([3.0, -1.0]), 0.3, 0.025
    velocity, yaw_rate = np.array([6.0, 2.0]), 0.8
    before = body @ rotation(yaw).T + centre
    after = body @ rotation(yaw + yaw_rate * dt).T + centre + velocity * dt
    # the prediction (zero velocity) is the previous pose; T maps it onto the new scan
    transform = estimate_rigid_transform(before, after)
    z = fictitious_measurement(centre, yaw, centre, yaw, transform, dt)
    np.testing.assert_allclose(z, [*(centre + velocity * dt), yaw + yaw_rate * dt, *velocity,
                                   yaw_rate], atol=1e-9)
