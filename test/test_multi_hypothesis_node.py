"""association_node with algorithm multi_hypothesis on the eight_identical_landmarks bag: the
live node over real DDS publishes correspondences (with marginal probabilities),
pose_hypotheses and past_associations, the same as the offline pipeline."""
from pathlib import Path

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2

from data_association_ros.bag import topics
from data_association_ros.bag.offline import node_config, offline_answers
from data_association_ros.bag.reader import BagReader
from data_association_ros.bag.replay import bag_parameters
from data_association_ros.nodes.association_node import AssociationNode
from msg_adapters import cloud_to_array
from rclpy.parameter import Parameter
from ros_harness import Graph

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'eight_identical_landmarks'
OUTPUTS = ('correspondences', 'pose_hypotheses', 'past_associations')


def bag_inputs():
    reader = BagReader(BAG)
    return [(m.topic, m.msg) for m in reader.messages(
        [t for t in topics.INPUT_TOPICS if t in reader.topics])]


def offline():
    parameters = bag_parameters(BAG)
    return offline_answers(bag_inputs(), node_config('multi_hypothesis', parameters))


def test_offline_answers_are_probabilities_and_the_first_decision_firms_up():
    answers = offline()
    assert len(answers) == 10
    truth = {m.msg.header.stamp.sec * 10**9 + m.msg.header.stamp.nanosec:
             cloud_to_array(m.msg)['landmark'] for m in BagReader(BAG).messages(
                 [topics.GROUND_TRUTH])}
    first_true = truth[min(truth)][0]
    history = []
    for stamp, answer in sorted(answers.items()):
        hypotheses = cloud_to_array(answer.pose_hypotheses)
        assert hypotheses['weight'].sum() == pytest.approx(1.0, abs=1e-5)
        past = cloud_to_array(answer.past_associations)
        for back in np.unique(past['steps_back']):
            assert past['probability'][past['steps_back'] == back].sum() == pytest.approx(
                1.0, abs=1e-5)
        correspondences = cloud_to_array(answer.correspondences)
        assert np.all((correspondences['probability'] > 0) & (correspondences['probability']
                                                              <= 1 + 1e-6))
        row = past[(past['steps_back'] == len(history) + 1) & (past['landmark'] == first_true)]
        if len(history) < 4:  # the first decision stays inside the window of 5
            history.append(float(row['probability'][0]) if len(row) else 0.0)
    assert history[-1] >= history[0]  # later scans do not make the true first decision less likely


@pytest.fixture
def graph():
    g = Graph()
    overrides = [Parameter(k, value=v) for k, v in {**bag_parameters(BAG),
                                                     'algorithm': 'multi_hypothesis'}.items()]
    g.node = AssociationNode(context=g.context, parameter_overrides=overrides)
    g.add(g.node)
    for topic in OUTPUTS:
        g.collect(PointCloud2, topic)
    g.publisher(PointCloud2, 'landmarks')
    g.publisher(PointCloud2, 'observations')
    g.publisher(Odometry, 'robot_pose')
    g.publisher(Odometry, 'odometry')
    g.wait_for_subscribers(['landmarks', 'observations', 'robot_pose', 'odometry'])
    yield g
    g.close()


def test_live_node_publishes_the_three_topics_as_offline(graph):
    names = {topics.LANDMARKS: 'landmarks', topics.OBSERVATIONS: 'observations',
             topics.ROBOT_POSE: 'robot_pose', topics.ODOMETRY: 'odometry'}
    types = {'landmarks': PointCloud2, 'observations': PointCloud2, 'robot_pose': Odometry,
             'odometry': Odometry}
    sent = 0
    for topic, msg in bag_inputs():
        name = names[topic]
        graph.publisher(types[name], name).publish(msg)
        graph.spin_until(lambda: False, 0.02)
        if name == 'observations':
            sent += 1
            # answered at once: the bag has one robot_pose (an optional prior here), so a
            # scan held for a newer one would wait pose_wait (4 s) every time
            assert graph.spin_until(lambda: all(len(graph.received[t]) >= sent
                                                for t in OUTPUTS), 2.0), f'scan {sent}'
    expected = [answer for _, answer in sorted(offline().items())]
    assert sent == len(expected) == 10
    for k, answer in enumerate(expected):
        for topic, field in zip(OUTPUTS, ('correspondences', 'pose_hypotheses',
                                          'past_associations')):
            live = cloud_to_array(graph.received[topic][k])
            want = cloud_to_array(getattr(answer, field))
            assert live.dtype == want.dtype and len(live) == len(want), topic
            for name in live.dtype.names:
                np.testing.assert_allclose(live[name], want[name], rtol=1e-6, err_msg=topic)
