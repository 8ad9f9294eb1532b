"""Generated hostile messages on every input topic of a live association_node (real rclpy,
real topics): it stays up, answers the valid scan sent after each batch, and its /diagnostics
count the rejections by cause."""
import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2

from data_association_ros.nodes.association_node import AssociationNode
from message_fuzz import SCALE, covariance_clouds, odometries, plausible_clouds, raw_clouds
from ros_harness import Graph, cloud, correspondences, odometry

TOPICS = {'landmarks': PointCloud2, 'observations': PointCloud2, 'robot_pose': Odometry,
          'state_covariance': PointCloud2}
MESSAGES = st.one_of(
    st.tuples(st.just('observations'), st.one_of(raw_clouds(), plausible_clouds())),
    st.tuples(st.just('landmarks'), st.one_of(raw_clouds(), plausible_clouds())),
    st.tuples(st.just('robot_pose'), odometries()),
    st.tuples(st.just('state_covariance'), covariance_clouds()))


@pytest.fixture(scope='module')
def graph():
    g = Graph()
    # a hostile but valid state_covariance makes the next scans wait for their map's
    # covariance, which never comes: at most pose_wait (4 s by default, 0.5 s here for CI time)
    node = AssociationNode(context=g.context,
                           parameter_overrides=[Parameter('pose_wait', value=0.5)])
    g.add(node)
    g.node = node
    g.collect(PointCloud2, 'correspondences')
    g.collect(DiagnosticArray, '/diagnostics')
    for topic, msg_type in TOPICS.items():
        g.publisher(msg_type, topic)
    g.wait_for_subscribers(list(TOPICS))
    g.clock = 100.0
    yield g
    g.close()


@settings(max_examples=25 * SCALE, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                 HealthCheck.data_too_large])
@given(batch=st.lists(MESSAGES, min_size=1, max_size=12))
def test_live_node_survives_hostile_messages_and_answers_the_next_valid_scan(graph, batch):
    for topic, msg in batch:
        graph.publisher(TOPICS[topic], topic).publish(msg)
    graph.clock += 0.1
    graph.publisher(PointCloud2, 'landmarks').publish(
        cloud({'id': [3, 7], 'x': [0.0, 5.0], 'y': [0.0, 0.0]}, graph.clock))
    graph.publisher(Odometry, 'robot_pose').publish(
        odometry(0.0, 0.0, 0.0, np.eye(3) * 1e-4, graph.clock))
    graph.spin_until(lambda: False, 0.05)
    scan = cloud({'x': [5.01], 'y': [0.02]}, graph.clock + 0.01)
    graph.publisher(PointCloud2, 'observations').publish(scan)

    def answered():
        return [m for m in graph.received['correspondences']
                if m.header.stamp == scan.header.stamp]
    assert graph.spin_until(lambda: bool(answered()), 5.0)
    np.testing.assert_array_equal(correspondences(answered()[-1])['landmark'], [7])


def test_diagnostics_count_rejections_by_cause(graph):
    """Runs after the hypothesis test above (same module graph)."""
    statistics = graph.node.statistics
    assert statistics.invalid['internal_error'] == 0
    assert sum(statistics.invalid.values()) > 0
    before = len(graph.received['/diagnostics'])
    assert graph.spin_until(lambda: len(graph.received['/diagnostics']) > before, 3.0)
    values = {kv.key: kv.value for kv in graph.received['/diagnostics'][-1].status[0].values}
    for cause, n in statistics.invalid.items():
        assert int(values[f'invalid_{cause}']) <= n  # the report lags by at most one period
    assert int(values['invalid_total']) > 0
