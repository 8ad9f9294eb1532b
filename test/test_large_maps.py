"""Large maps through the live association_node (real rclpy, real topics) and the pipelines:
a prior map published before the node starts, the stamped state_covariance tied to its map
(used when it fits, a counted fallback when not), the SLAM node's local map, and the
street_grid bag regenerated small and scored."""
import json

import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from nav_msgs.msg import Odometry

from data_association_ros import Landmarks, Observations, RobotPose, associate
from data_association_ros.bag import topics
from data_association_ros.bag.make_bags import PARAMETERS_KEY, make_bag
from data_association_ros.bag.evaluate import evaluate_offline
from data_association_ros.bag.reader import BagReader
from data_association_ros.bag.rosbag2_metadata import read_custom_data
from data_association_ros.bag.street_grid import poles, street_grid
from data_association_ros.core.models import MODELS
from data_association_ros.core.spatial_index import has_index
from data_association_ros.nodes.association_node import AssociationNode
from data_association_ros.pipelines.slam import SLAM_PARAMETERS, SlamPipeline
from msg_adapters import cloud_to_array, state_covariance_cloud, state_covariance_from_cloud
from ros_harness import Graph, cloud, header, odometry, wait_reply

MAP_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def grid_map(n_side: int = 100, spacing: float = 5.0):
    """n_side^2 landmarks on a grid (ids 1000 + index), sigma 0.05 m."""
    xs, ys = np.meshgrid(np.arange(n_side) * spacing, np.arange(n_side) * spacing)
    means = np.column_stack([xs.ravel(), ys.ravel()])
    return 1000 + np.arange(len(means)), means


def map_cloud(ids, means, stamp, variance=0.0025):
    n = len(ids)
    return cloud({'id': ids, 'x': means[:, 0], 'y': means[:, 1], 'cov_xx': np.full(n, variance),
                  'cov_xy': np.zeros(n), 'cov_yy': np.full(n, variance)}, stamp)


def range_bearing_scan(means, pose, seen, stamp):
    z = MODELS['range_bearing'].predict(means[seen], np.asarray(pose))[0]
    n = len(seen)
    return cloud({'range': z[:, 0], 'bearing': z[:, 1], 'var_range': np.full(n, 0.01),
                  'var_bearing': np.full(n, 1e-4)}, stamp, 'base_link')


def test_prior_map_published_before_the_node_starts_serves_every_later_scan():
    """A 10,000-landmark map published once, transient_local, before association_node exists;
    scans 100 s later (far beyond max_landmark_age) are answered with the true ids."""
    ids, means = grid_map()
    graph = Graph()
    try:
        map_publisher = graph.tester.create_publisher(PointCloud2, 'landmarks', MAP_QOS)
        map_publisher.publish(map_cloud(ids, means, stamp=1.0))
        graph.spin_until(lambda: False, 0.3)
        node = AssociationNode(context=graph.context, parameter_overrides=[
            Parameter('prior_map', value=True), Parameter('algorithm', value='jcbb')])
        graph.add(node)
        replies = graph.collect(PointCloud2, 'correspondences')
        graph.publisher(PointCloud2, 'observations')
        graph.publisher(Odometry, 'robot_pose')
        graph.wait_for_subscribers(['observations', 'robot_pose'])
        for k, (x, y) in enumerate([(102.0, 101.0), (251.0, 372.0), (480.0, 12.0)]):
            stamp = 100.0 + k
            pose = (x, y, 0.3)
            seen = np.flatnonzero(np.hypot(means[:, 0] - x, means[:, 1] - y) < 12.0)
            graph.publisher(Odometry, 'robot_pose').publish(
                odometry(*pose, np.diag([1e-4, 1e-4, 1e-6]), stamp))
            graph.spin_until(lambda: False, 0.05)
            graph.publisher(PointCloud2, 'observations').publish(
                range_bearing_scan(means, pose, seen, stamp))
            answer = cloud_to_array(wait_reply(graph, 'correspondences', k + 1)[-1])
            assert len(seen) >= 12
            np.testing.assert_array_equal(answer['landmark'], ids[seen])
        assert node.statistics.skipped['no_landmarks'] == 0
        assert len(node.pipeline.landmark_history) == 1
        # indexed once, on arrival (not in the first scan's latency), and used for every scan
        prior = node.pipeline.landmark_history.latest_not_after(0, 2 ** 63)[0].landmarks
        assert has_index(prior)
    finally:
        graph.close()


@pytest.fixture
def covariance_graph():
    g = Graph()
    g.node = AssociationNode(context=g.context, parameter_overrides=[
        Parameter('algorithm', value='mahalanobis_nn'), Parameter('pose_wait', value=0.3)])
    g.add(g.node)
    g.collect(PointCloud2, 'correspondences')
    for topic, kind in (('landmarks', PointCloud2), ('observations', PointCloud2),
                        ('robot_pose', Odometry), ('state_covariance', PointCloud2)):
        g.publisher(kind, topic)
    g.wait_for_subscribers(['landmarks', 'observations', 'robot_pose', 'state_covariance'])
    yield g
    g.close()


def test_state_covariance_is_used_only_with_its_own_map(covariance_graph):
    """The same scan: with the covariance of its map (same stamp and ids) the NIS is the one
    associate() gives with that joint covariance; with the ids in another order, or another
    stamp, the marginals are used and fallback_covariance_mismatch is counted."""
    graph = covariance_graph
    ids = np.array([5, 9, 20])
    means = np.array([[4.0, 0.0], [0.0, 4.0], [6.0, 6.0]])
    shared = np.random.default_rng(3).normal(size=(9, 3)) * 0.15   # pose and map correlated
    joint = shared @ shared.T + np.diag([0.04, 0.04, 0.01] + [0.01] * 6)
    pose = (0.2, -0.1, 0.05)
    marginals = np.array([joint[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j] for j in range(3)])
    seen = np.array([0, 1])
    expected = {}
    for name, state in (('joint', joint), ('marginal', None)):
        z = MODELS['range_bearing'].predict(means[seen] + 0.1, np.asarray(pose))[0]
        expected[name] = associate(
            Landmarks(ids, means, marginals),
            Observations(z, np.tile(np.diag([0.01, 1e-4]), (2, 1, 1)), 'range_bearing'),
            'mahalanobis_nn', pose=RobotPose(pose, joint[:3, :3]), state_covariance=state).nis
    assert not np.allclose(expected['joint'], expected['marginal'])

    def scan_with(stamp, covariance_stamp, covariance_ids):
        graph.publisher(PointCloud2, 'landmarks').publish(cloud(
            {'id': ids, 'x': means[:, 0], 'y': means[:, 1], 'cov_xx': marginals[:, 0, 0],
             'cov_xy': marginals[:, 0, 1], 'cov_yy': marginals[:, 1, 1]}, stamp,
            dtype='<f8'))
        graph.publisher(Odometry, 'robot_pose').publish(odometry(*pose, joint[:3, :3], stamp))
        graph.publisher(PointCloud2, 'state_covariance').publish(
            state_covariance_cloud(header(covariance_stamp), covariance_ids, joint))
        graph.spin_until(lambda: False, 0.1)
        z = MODELS['range_bearing'].predict(means[seen] + 0.1, np.asarray(pose))[0]
        graph.publisher(PointCloud2, 'observations').publish(cloud(
            {'range': z[:, 0], 'bearing': z[:, 1], 'var_range': [0.01, 0.01],
             'var_bearing': [1e-4, 1e-4]}, stamp, 'base_link', dtype='<f8'))
        count = len(graph.received['correspondences']) + 1
        return cloud_to_array(wait_reply(graph, 'correspondences', count)[-1])

    answer = scan_with(1.0, 1.0, ids)
    np.testing.assert_array_equal(answer['landmark'], ids[seen])
    np.testing.assert_allclose(answer['nis'], expected['joint'], rtol=1e-5)
    assert graph.node.statistics.fallbacks['covariance_mismatch'] == 0
    answer = scan_with(2.0, 2.0, ids[[1, 0, 2]])            # another id order: not this map's
    np.testing.assert_allclose(answer['nis'], expected['marginal'], rtol=1e-5)
    assert graph.node.statistics.fallbacks['covariance_mismatch'] == 1
    answer = scan_with(3.0, 2.5, ids)                        # another stamp: waits, then falls back
    np.testing.assert_allclose(answer['nis'], expected['marginal'], rtol=1e-5)
    assert graph.node.statistics.fallbacks['covariance_mismatch'] == 2


def slam_config(**overrides):
    config = {p.name: p.default for p in SLAM_PARAMETERS}
    config.update(overrides)
    return config


def test_slam_pipeline_publishes_the_local_map_and_its_covariance_block():
    """After 25 landmarks along a line, the published map holds those within local_map_radius
    of the robot, ids global, and state_covariance is exactly the filter's block of [pose, them]."""
    pipeline = SlamPipeline(slam_config(local_map_radius=10.0))
    pipeline.slam = pipeline._start('range_bearing')
    means = np.column_stack([np.arange(25) * 2.0 - 20.0, np.full(25, 3.0)])
    observations = Observations(MODELS['range_bearing'].predict(means, np.zeros(3))[0],
                                np.tile(np.diag([0.01, 1e-4]), (25, 1, 1)), 'range_bearing')
    pipeline.slam.add_landmarks(observations.values, observations.covariances, np.arange(25) + 100)
    scan = cloud({'range': [5.0], 'bearing': [0.5], 'var_range': [0.01],
                  'var_bearing': [1e-4]}, 1.0, 'base_link')
    out = dict(pipeline._process_scan(scan, 10 ** 9))
    landmarks = cloud_to_array(out['landmarks'])
    near = np.hypot(pipeline.slam.mean[3::2] - pipeline.slam.mean[0],
                    pipeline.slam.mean[4::2] - pipeline.slam.mean[1]) <= 10.0
    assert 0 < near.sum() < 25
    np.testing.assert_array_equal(landmarks['id'], (np.arange(25) + 100)[near])
    ids, block = state_covariance_from_cloud(out['state_covariance'])
    np.testing.assert_array_equal(ids, landmarks['id'])
    rows = np.concatenate([[0, 1, 2], (3 + 2 * np.flatnonzero(near)[:, None]
                                       + np.arange(2)).ravel()])
    np.testing.assert_array_equal(block, pipeline.slam.covariance[np.ix_(rows, rows)])


def test_street_grid_bag_regenerated_small_and_scored(tmp_path):
    """The street_grid generator at a small size (600 poles, 60 scans) through make_bag: the map
    is published once with transient_local durability, and the offline pipeline with the bag's
    own parameters pairs the poles right."""
    from data_association_ros.bag import scenarios
    original = scenarios.SCENARIOS['street_grid']
    scenarios.SCENARIOS['street_grid'] = scenarios.Scenario(
        'street_grid', original.description,
        lambda: street_grid(side=230.0, steps=60), parameters=original.parameters)
    try:
        bag = make_bag('street_grid', tmp_path)
    finally:
        scenarios.SCENARIOS['street_grid'] = original
    reader = BagReader(bag)
    maps = [m for m in reader.messages([topics.LANDMARKS])]
    assert len(maps) == 1 and len(cloud_to_array(maps[0].msg)) == len(poles(230.0)[0])
    assert 'transient_local' in (bag / 'metadata.yaml').read_text()
    parameters = json.loads(read_custom_data(bag)[PARAMETERS_KEY])
    assert parameters['prior_map'] is True
    score = evaluate_offline(bag, 'jcbb', parameters)
    assert score['answered'] == 60
    assert score['pair_precision'] > 0.99 and score['pair_recall'] > 0.99
