"""The nodes' endpoints carry no event handlers; QosWatch reports, from the graph, the
incompatible QoS and types rclpy's default handlers reported (real rclpy, loopback DDS)."""
import contextlib
import os
import subprocess
import sys

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseArray
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.qos import (DurabilityPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy,
                       qos_profile_sensor_data)
from sensor_msgs.msg import PointCloud2

from data_association_ros.nodes.association_node import AssociationNode
from data_association_ros.nodes.box_tracker_node import BoxTrackerNode
from data_association_ros.nodes.ekf_slam_node import EkfSlamNode
from data_association_ros.nodes.lidar_tracker_node import LidarTrackerNode
from data_association_ros.nodes import qos_watch
from data_association_ros.nodes.qos_watch import (FULL_CHECK_EVERY, QOS_CHECK_PERIOD,
                                                  UNKNOWN_NODE, as_discovered)
from msg_adapters import array_to_cloud
from ros_harness import Graph


LEASE_WAIT = 30.0
"""Seconds to wait for the endpoints of a participant shut down to leave the graph: longer than
Fast DDS's default participant lease (20 s), which ends them when the goodbye was lost."""


@contextlib.contextmanager
def node_of_its_own(name: str):
    """A node in a context of its own (its own DDS participant, as another process would be:
    one participant refuses a second type on a topic), destroyed on leaving, failed or not (a
    node left alive keeps its endpoints in the graph)."""
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node(name, context=context)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


@pytest.fixture
def other():
    with node_of_its_own('other') as node:
        yield node


@pytest.mark.parametrize('node_class', [AssociationNode, EkfSlamNode, BoxTrackerNode,
                                        LidarTrackerNode])
def test_the_nodes_wait_on_no_event_handlers(node_class):
    graph = Graph()
    try:
        node = node_class(context=graph.context)
        graph.add(node)     # destroyed by close(): a node left alive keeps its endpoints
        assert list(node.publishers) and list(node.subscriptions)
        assert list(node.waitables) == []
    finally:
        graph.close()


def seen(graph, node, topics) -> bool:
    """Spin until each topic has an endpoint of 'other' and none whose node is unknown yet.
    (Endpoints of another process's participant whose goodbye was lost linger until its lease
    ends; in this process a destroyed node's endpoints leave at once, a node never destroyed
    keeps them (Graph).  Compatible ones of our own nodes are no reason to wait.)"""
    def known(topic):
        names = [info.node_name for info in node.get_publishers_info_by_topic(topic) +
                 node.get_subscriptions_info_by_topic(topic)]
        return 'other' in names and UNKNOWN_NODE not in names
    return graph.spin_until(lambda: all(known(topic) for topic in topics), LEASE_WAIT)


@pytest.fixture
def watched():
    """(graph, association_node with its QoS timer stopped (checked by hand), its warnings)."""
    graph = Graph()
    try:
        node = AssociationNode(context=graph.context)
        node.qos_timer.cancel()
        graph.add(node)
        warnings = []
        node.qos_watch.warn = warnings.append
        yield graph, node, warnings
    finally:
        graph.close()


def test_incompatible_qos_and_types_reported_once_compatible_ones_not(other, watched):
    graph, node, warnings = watched
    # compatible: a reliable publisher of scans, a default subscriber of the answers
    other.create_publisher(PointCloud2, 'landmarks', 10)
    other.create_subscription(PointCloud2, 'correspondences', lambda msg: None, 10)
    assert seen(graph, node, ['/landmarks', '/correspondences'])
    assert node.qos_watch.check() == [] and warnings == []
    # incompatible: best effort into a reliable subscription, a transient-local
    # subscriber of a volatile publisher, a PoseArray on the Odometry topic
    other.create_publisher(PointCloud2, 'observations', qos_profile_sensor_data)
    other.create_subscription(PointCloud2, 'new_landmarks', lambda msg: None,
                              QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    other.create_publisher(PoseArray, 'robot_pose', 10)
    assert seen(graph, node, ['/observations', '/new_landmarks', '/robot_pose'])
    assert graph.spin_until(lambda: node.qos_watch.check() is None or len(warnings) >= 3)
    found = list(warnings)
    assert len(found) == 3
    qos_scan, qos_new, wrong_type = sorted(found, key=lambda text: (
        '/observations' not in text, '/new_landmarks' not in text))
    assert "'/observations' (node /other), offering incompatible QoS" in qos_scan
    assert 'Best effort publisher and reliable subscription' in qos_scan
    assert "'/new_landmarks' (node /other), requesting incompatible QoS" in qos_new
    assert 'Volatile publisher and transient local subscription' in qos_new
    assert 'deadline' not in qos_new    # unset durations are not taken for a deadline
    assert "type on topic '/robot_pose' (node /other): geometry_msgs/msg/PoseArray, " \
        'not nav_msgs/msg/Odometry' in wrong_type
    assert node.qos_watch.check() == [] and len(warnings) == 3   # each reported once
    # another incompatible endpoint on a topic already reported is reported too (once its
    # node is discovered)
    other.create_publisher(PointCloud2, 'observations', qos_profile_sensor_data)
    assert graph.spin_until(lambda: node.qos_watch.check() is None or len(warnings) == 4)
    assert "'/observations' (node /other), offering incompatible QoS" in warnings[3]
    graph.spin_until(lambda: node.qos_watch.check() is None, 0.5)
    assert len(warnings) == 4


def test_a_manual_by_topic_subscriber_of_our_system_default_liveliness_is_reported(other,
                                                                                   watched):
    """Our publishers leave liveliness at SYSTEM_DEFAULT, which Fast DDS makes AUTOMATIC: a
    MANUAL_BY_TOPIC subscriber receives nothing (an error, not rclpy's "may be" warning)."""
    graph, node, warnings = watched
    other.create_subscription(PointCloud2, 'correspondences', lambda msg: None,
                              QoSProfile(depth=10, liveliness=LivelinessPolicy.MANUAL_BY_TOPIC))
    other.create_subscription(PointCloud2, 'new_landmarks', lambda msg: None,
                              QoSProfile(depth=10, liveliness=LivelinessPolicy.AUTOMATIC))
    assert seen(graph, node, ['/correspondences', '/new_landmarks'])
    assert node.qos_watch.check() == warnings and len(warnings) == 1
    assert "'/correspondences' (node /other), requesting incompatible QoS" in warnings[0]
    assert "Publisher's liveliness is automatic and subscription's is manual by topic" \
        in warnings[0]


def test_an_endpoint_whose_node_never_gets_a_name_is_reported_after_the_wait(
        other, watched, monkeypatch):
    """A DDS application that is no ROS node never gets a node name in the graph: its endpoint
    waits UNKNOWN_NODE_WAIT for one, then is checked without it; once it has left the graph, a
    full look forgets it."""
    graph, node, warnings = watched
    listed = node.get_subscriptions_info_by_topic

    def nameless(topic):    # the real endpoints, 'other' without its name (as DDS-only ones)
        endpoints = listed(topic)
        for info in endpoints:
            if info.node_name == 'other':
                info.node_name = UNKNOWN_NODE
        return endpoints
    subscription = other.create_subscription(
        PointCloud2, 'correspondences', lambda msg: None,
        QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    assert seen(graph, node, ['/correspondences'])
    monkeypatch.setattr(node, 'get_subscriptions_info_by_topic', nameless)
    assert node.qos_watch.check() == [] and warnings == []    # waiting for its node's name
    monkeypatch.setattr(qos_watch, 'UNKNOWN_NODE_WAIT', 0.0)
    assert len(node.qos_watch.check()) == 1 and len(warnings) == 1
    assert "'/correspondences' (node unknown), requesting incompatible QoS" in warnings[0]
    assert node.qos_watch.check() == []     # once
    other.destroy_subscription(subscription)
    assert graph.spin_until(lambda: node.count_subscribers('/correspondences') == 0, 20.0)
    for _ in range(FULL_CHECK_EVERY):
        node.qos_watch.check()
    assert node.qos_watch._reported == set() and node.qos_watch._unnamed == {}


def test_system_default_policies_are_compared_as_fast_dds_applies_them(watched):
    """as_discovered gives what the graph reports for our own endpoints with every policy left
    to the system (Fast DDS: a writer reliable and transient local, a reader best effort and
    volatile, liveliness automatic)."""
    graph, node, _ = watched
    unset = QoSProfile(depth=5, reliability=ReliabilityPolicy.SYSTEM_DEFAULT,
                       durability=DurabilityPolicy.SYSTEM_DEFAULT,
                       liveliness=LivelinessPolicy.SYSTEM_DEFAULT)
    node.create_publisher(PointCloud2, 'unset_out', unset)
    node.create_subscription(PointCloud2, 'unset_in', lambda msg: None, unset)
    assert graph.spin_until(lambda: node.get_publishers_info_by_topic('/unset_out') and
                            node.get_subscriptions_info_by_topic('/unset_in'))
    for publisher, listed in ((True, node.get_publishers_info_by_topic('/unset_out')),
                              (False, node.get_subscriptions_info_by_topic('/unset_in'))):
        applied = listed[0].qos_profile
        ours = as_discovered(unset, publisher)
        assert (ours.reliability, ours.durability, ours.liveliness) == (
            applied.reliability, applied.durability, applied.liveliness), publisher
        assert (ours.deadline, ours.lifespan, ours.liveliness_lease_duration) == (
            applied.deadline, applied.lifespan, applied.liveliness_lease_duration)
        assert ours.depth == 5
    assert unset.liveliness == LivelinessPolicy.SYSTEM_DEFAULT    # not changed in place
    explicit = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
                          durability=DurabilityPolicy.VOLATILE,
                          liveliness=LivelinessPolicy.MANUAL_BY_TOPIC)
    kept = as_discovered(explicit, True)
    assert (kept.reliability, kept.durability, kept.liveliness) == (
        ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.VOLATILE,
        LivelinessPolicy.MANUAL_BY_TOPIC)


MANUAL_BY_PARTICIPANT_PROFILES = """<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <data_reader profile_name="/correspondences">
    <qos><liveliness><kind>MANUAL_BY_PARTICIPANT</kind></liveliness></qos>
  </data_reader>
  <data_writer profile_name="/observations">
    <qos><liveliness><kind>MANUAL_BY_PARTICIPANT</kind></liveliness></qos>
  </data_writer>
</profiles>
"""


def test_a_manual_by_participant_subscriber_set_in_fast_dds_xml_is_reported(watched,
                                                                           tmp_path):
    """The graph reports MANUAL_BY_PARTICIPANT (set in a Fast DDS XML profile, as DDS-level
    configurations do) as UNKNOWN, which qos_check_compatible only calls a "may be": a reader
    of that kind gets nothing from our automatic publisher (reported), a writer of it serves
    our automatic subscription (not reported)."""
    graph, node, warnings = watched
    profiles = tmp_path / 'profiles.xml'
    profiles.write_text(MANUAL_BY_PARTICIPANT_PROFILES)
    script = (
        'import rclpy, time\n'
        'from sensor_msgs.msg import PointCloud2\n'
        'rclpy.init(); node = rclpy.create_node("dds_configured")\n'
        'node.create_subscription(PointCloud2, "correspondences", lambda msg: None, 10)\n'
        'node.create_publisher(PointCloud2, "observations", 10)\n'
        'end = time.monotonic() + 60\n'
        'while time.monotonic() < end: rclpy.spin_once(node, timeout_sec=0.1)\n')
    environment = {**os.environ, 'RMW_FASTRTPS_USE_QOS_FROM_XML': '1',
                   'FASTRTPS_DEFAULT_PROFILES_FILE': str(profiles)}
    process = subprocess.Popen([sys.executable, '-c', script], env=environment)
    try:
        def listed(topic, endpoints):
            return [info for info in endpoints(topic) if info.node_name == 'dds_configured']
        assert graph.spin_until(
            lambda: listed('/correspondences', node.get_subscriptions_info_by_topic) and
            listed('/observations', node.get_publishers_info_by_topic), 30.0)
        assert listed('/correspondences', node.get_subscriptions_info_by_topic)[
            0].qos_profile.liveliness == LivelinessPolicy.UNKNOWN
        assert node.qos_watch.check() == warnings and len(warnings) == 1
        assert "'/correspondences' (node /dds_configured), requesting incompatible QoS" \
            in warnings[0]
        assert 'manual by participant' in warnings[0]
    finally:
        process.kill()
        process.wait()


def test_a_best_effort_node_takes_a_reliable_publisher_and_the_timer_reports_by_itself(other):
    graph = Graph()
    try:
        node = AssociationNode(context=graph.context, parameter_overrides=[
            Parameter('input_qos', value='sensor_data')])
        graph.add(node)
        warnings = []
        node.qos_watch.warn = warnings.append
        other.create_publisher(PointCloud2, 'observations', 10)    # reliable: compatible
        other.create_subscription(PointCloud2, 'correspondences', lambda msg: None,
                                  QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        assert graph.spin_until(lambda: warnings, 3 * QOS_CHECK_PERIOD)
        assert len(warnings) == 1 and "'/correspondences'" in warnings[0]
        # the answers still flow to a compatible subscriber alongside
        answers = graph.collect(PointCloud2, 'correspondences')
        graph.publisher(PointCloud2, 'landmarks').publish(array_to_cloud(
            {'id': np.array([1], np.int32), 'x': [0.0], 'y': [0.0]}))
        graph.spin_until(lambda: False, 0.3)
        graph.publisher(PointCloud2, 'observations').publish(array_to_cloud(
            {'x': [0.1], 'y': [0.0]}))
        assert graph.spin_until(lambda: answers, 5.0)
    finally:
        graph.close()


def publishers_of(node, topic: str) -> list:
    """The nodes of `topic`'s publishers in `node`'s graph (what a failed count was made of)."""
    return [info.node_name for info in node.get_publishers_info_by_topic(topic)]


def test_a_publisher_replaced_between_two_looks_and_undiscovered_nodes_are_reported(watched):
    """The count alone misses a compatible publisher replaced by an incompatible one between
    two looks: every FULL_CHECK_EVERY looks each topic is listed anyway.  Endpoints seen before
    their node (several on one topic) are looked at again, nothing raised or lost."""
    graph, node, warnings = watched
    for attempt in range(6):    # two publishers of a node just started, looked at at once
        with node_of_its_own(f'driver{attempt}') as other:
            for _ in range(2):
                other.create_publisher(PointCloud2, 'observations', qos_profile_sensor_data)
            assert graph.spin_until(lambda: node.count_publishers('/observations') == 2,
                                    20.0), publishers_of(node, '/observations')
            node.qos_watch.check()
            assert graph.spin_until(
                lambda: node.qos_watch.check() is None or len(warnings) == 2 * attempt + 2)
            assert all(f'(node /driver{attempt})' in text for text in warnings[-2:])
        # in one process they leave at once (measured: 0.0 s in 20 tries under load); the
        # lease wait is for a participant elsewhere whose goodbye was lost
        assert graph.spin_until(lambda: node.count_publishers('/observations') == 0,
                                LEASE_WAIT), publishers_of(node, '/observations')
    warnings.clear()
    # a reliable publisher, looked at, then replaced by a best-effort one: count 1 -> 1
    with node_of_its_own('driver') as other:
        reliable = other.create_publisher(PointCloud2, 'observations', 10)
        assert graph.spin_until(lambda: node.count_publishers('/observations') == 1, 20.0), \
            publishers_of(node, '/observations')
        graph.spin_until(lambda: node.qos_watch.check() is None, 0.5)
        assert warnings == []
        other.destroy_publisher(reliable)
        other.create_publisher(PointCloud2, 'observations', qos_profile_sensor_data)
        assert graph.spin_until(lambda: [info.qos_profile.reliability for info in
                                         node.get_publishers_info_by_topic('/observations')
                                         if info.node_name == 'driver'] ==
                                [qos_profile_sensor_data.reliability], 5.0)
        for _ in range(FULL_CHECK_EVERY):
            node.qos_watch.check()
        assert len(warnings) == 1 and "'/observations' (node /driver)" in warnings[0]
