"""association_node's per-scan path (issue 18), with real rclpy: the start-up work (compiled
search, thresholds) is done when the constructor returns, and a fresh node's first scans give
the library's answers."""
import numpy as np
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

from data_association_ros import Landmarks, Observations, RobotPose, associate
from data_association_ros.core import problem_kernels
from data_association_ros.core.associators import jcbb_compiled
from data_association_ros.core.gating import chi2_threshold
from data_association_ros.nodes.association_node import AssociationNode
from data_association_ros.pipelines.warm_up import WARM_DOF

from msg_adapters import array_to_cloud, cloud_to_array
from ros_harness import Graph, odometry


def test_warm_up_runs_before_the_node_is_ready():
    graph = Graph()
    try:
        node = AssociationNode(context=graph.context,
                               parameter_overrides=[Parameter('algorithm', value='jcbb')])
        graph.add(node)
        spent = node.start_up_seconds
        assert spent['compiled'] == float(jcbb_compiled.available()
                                          and problem_kernels.KERNELS.available())
        assert {'compile_s', 'thresholds_s', 'scans_s'} <= set(spent)
        for dof in (1, 2, WARM_DOF):    # thresholds already computed (lru_cache hits)
            before = chi2_threshold.cache_info().hits
            chi2_threshold(0.99, dof)
            assert chi2_threshold.cache_info().hits == before + 1
    finally:
        graph.close()


def test_fresh_node_answers_its_first_scans_as_the_library():
    """node_latency's kind of scan through the callbacks of a node just built (jcbb and
    mahalanobis_nn): the correspondences equal associate()'s."""
    rng = np.random.default_rng(3)
    means = rng.uniform(-20, 20, (60, 2))
    pose_mean = np.array([0.5, -0.3, 0.2])
    seen = rng.choice(60, 20, replace=False)
    delta = means[seen] - pose_mean[:2] + rng.normal(0, 0.05, (20, 2))
    values = np.column_stack([np.hypot(delta[:, 0], delta[:, 1]),
                              np.arctan2(delta[:, 1], delta[:, 0]) - pose_mean[2]])
    lm_points = np.zeros(60, dtype=[('id', '<i4'), ('x', '<f8'), ('y', '<f8'),
                                    ('cov_xx', '<f8'), ('cov_xy', '<f8'), ('cov_yy', '<f8')])
    lm_points['id'], lm_points['x'], lm_points['y'] = np.arange(60), means[:, 0], means[:, 1]
    lm_points['cov_xx'] = lm_points['cov_yy'] = 0.01
    obs_points = np.zeros(20, dtype=[('range', '<f8'), ('bearing', '<f8'), ('var_range', '<f8'),
                                     ('var_bearing', '<f8')])
    obs_points['range'], obs_points['bearing'] = values.T
    obs_points['var_range'], obs_points['var_bearing'] = 0.01, 1e-4
    pose_covariance = np.diag([0.01, 0.01, 0.003])
    for algorithm in ('jcbb', 'mahalanobis_nn'):
        expected = associate(
            Landmarks(np.arange(60), means, np.tile(np.eye(2) * 0.01, (60, 1, 1))),
            Observations(values, np.tile(np.diag([0.01, 1e-4]), (20, 1, 1)), 'range_bearing'),
            algorithm, pose=RobotPose(pose_mean, pose_covariance))
        assert (expected.assignment >= 0).sum() >= 15
        graph = Graph()
        try:
            node = AssociationNode(context=graph.context, parameter_overrides=[
                Parameter('algorithm', value=algorithm)])
            graph.add(node)
            replies = graph.collect(PointCloud2, 'correspondences')
            assert graph.spin_until(lambda: node.correspondences_pub.get_subscription_count())
            for k in range(3):
                stamp = Header(frame_id='map')
                stamp.stamp.sec = 10 + k
                node.pipeline.on_landmarks(array_to_cloud(lm_points, stamp))
                node._on_robot_pose(odometry(*pose_mean, pose_covariance, 10 + k))
                node._on_serialized_observations(serialize_message(array_to_cloud(
                    obs_points, Header(stamp=stamp.stamp, frame_id='base_link'))))
                assert graph.spin_until(lambda: len(replies) == k + 1)
                np.testing.assert_array_equal(cloud_to_array(replies[-1])['landmark'],
                                              expected.assignment)
        finally:
            graph.close()
