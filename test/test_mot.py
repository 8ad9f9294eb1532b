"""Box tracking on the TUD-Campus bag (MOT15 detections, SORT's Faster R-CNN ones), scored with
TrackEval, and box_tracker_node over real DDS.

Measured (da_mot_eval, 2026-11-25) next to SORT's published figures on the same detections:

| tracker | MOTA % | IDF1 % | IDSW | FP | FN |
| SORT (published) | 62.7 | 60.6 | 6 | 15 | 113 |
| iou (this tracker) | 63.2 | 60.7 | 7 | 18 | 107 |
| mahalanobis_nn, SORT's noise | 0.3 | 10.6 | 43 | 34 | 281 |
| gnn, noise_scale 30 | 52.9 | 46.9 | 12 | 18 | 139 |

Thresholds: `iou` must reach SORT's MOTA and IDF1 (the issue's goal; measured 0.5 and 0.1
points above), with at most one ID switch more than measured.  The covariance-gated associators
with SORT's noise (sigma 1 px on the centre) reject most true pairs: MOTA stays below 5 %; with
noise_scale 30 they recover to 45-55 % but stay below `iou`, which a test pins as well.
"""

import numpy as np
import pytest
from sensor_msgs.msg import PointCloud2

from data_association_ros.bag.mot import (BAG, DATA, evaluate, make_mot_bag, read_mot_bag,
                                          track)
from data_association_ros.bag.reader import BagReader
from data_association_ros.nodes.box_tracker_node import BoxTrackerNode
from data_association_ros.core.tracking import BoxTracker
from msg_adapters import array_to_cloud, cloud_to_array
from ros_harness import Graph, header
from test_bags import assert_same_message
from test_node import set_parameters


def test_bag_regenerates_from_the_data_files(tmp_path):
    fresh = list(BagReader(make_mot_bag(DATA, tmp_path / 'mot')).messages())
    committed = list(BagReader(BAG).messages())
    assert len(fresh) == len(committed) == 2 * 71
    for a, b in zip(fresh, committed):
        assert (a.topic, a.log_time_ns) == (b.topic, b.log_time_ns)
        assert_same_message(a.msg, b.msg, a.topic)
    frames, truth = read_mot_bag(BAG)
    assert sum(len(t) for t in truth) == 359  # SOURCES.md: 71 frames, 359 true boxes


def test_iou_tracker_reaches_sort_on_tud_campus():
    r = evaluate(BAG, 'iou')
    assert r['MOTA'] >= 62.7 and r['IDF1'] >= 60.6, r
    assert r['IDSW'] <= 8 and r['FP'] <= 20 and r['FN'] <= 110, r


@pytest.mark.parametrize('algorithm', ['mahalanobis_nn', 'gnn', 'jcbb'])
def test_covariance_gates_need_calibrated_noise_and_still_trail_iou(algorithm):
    assert evaluate(BAG, algorithm)['MOTA'] < 15.0
    tuned = evaluate(BAG, algorithm, noise_scale=30.0)
    assert 35.0 <= tuned['MOTA'] < evaluate(BAG, 'iou')['MOTA'], tuned


@pytest.fixture
def graph():
    g = Graph()
    g.node = BoxTrackerNode(context=g.context)
    g.add(g.node)
    g.collect(PointCloud2, 'landmarks')
    g.publisher(PointCloud2, 'observations')
    g.wait_for_subscribers(['observations'])
    yield g
    g.close()


def detection_cloud(boxes, stamp):
    points = np.zeros(len(boxes), dtype=[('x', '<f4'), ('y', '<f4'), ('width', '<f4'),
                                         ('height', '<f4'), ('score', '<f4')])
    for k, name in enumerate(('x', 'y', 'width', 'height')):
        points[name] = boxes[:, k]
    points['score'] = 1.0
    return array_to_cloud(points, header(stamp, 'camera'))


def test_node_tracks_detections_with_their_stamps_and_switches_associator(graph):
    frames, _ = read_mot_bag(BAG)
    frames = [f.astype(np.float32).astype(float) for f in frames[:20]]  # as the cloud carries
    expected, _ = track(frames[:10], BoxTracker('iou'))
    for k, boxes in enumerate(frames[:10]):
        graph.publisher(PointCloud2, 'observations').publish(detection_cloud(boxes, 1 + k / 25))
        assert graph.spin_until(lambda: len(graph.received['landmarks']) > k, 5.0)
        reply = graph.received['landmarks'][k]
        assert reply.header.stamp == header(1 + k / 25, 'camera').stamp
        assert reply.header.frame_id == 'camera'
        tracks = cloud_to_array(reply)
        np.testing.assert_array_equal(tracks['id'], [i for i, _ in expected[k]])
        np.testing.assert_allclose(np.column_stack([tracks[n] for n in ('x', 'y', 'width',
                                                                        'height')]),
                                   np.array([b for _, b in expected[k]]).reshape(-1, 4),
                                   rtol=1e-5)
    refused = set_parameters(graph, algorithm='jcbb_points')[0]
    assert not refused.successful and 'jcbb_points' in refused.reason
    assert set_parameters(graph, algorithm='gnn', noise_scale=30.0)[0].successful
    assert graph.node.tracker.algorithm == 'gnn' and graph.node.tracker.noise_scale == 30.0
    for k, boxes in enumerate(frames[10:], start=10):
        graph.publisher(PointCloud2, 'observations').publish(detection_cloud(boxes, 1 + k / 25))
        assert graph.spin_until(lambda: len(graph.received['landmarks']) > k, 5.0)
    before = {int(i) for i in cloud_to_array(graph.received['landmarks'][9])['id']}
    after = {int(i) for m in graph.received['landmarks'][10:] for i in cloud_to_array(m)['id']}
    assert before & after  # the tracks (and their ids) carry on under the new associator
