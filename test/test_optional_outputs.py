"""AssociationPipeline.answer builds the optional outputs (new_landmarks, landmark_candidates,
association_markers) only when wanted - association_node asks for those with a subscriber - and
its state (the candidate landmarks) moves the same either way."""
import numpy as np
from std_msgs.msg import Header

from msg_adapters import array_to_cloud, cloud_to_array

from data_association_ros.bag.offline import node_config
from data_association_ros.pipelines.association import OPTIONAL_OUTPUTS, AssociationPipeline


def clouds(stamp_s: float, points):
    header = Header(frame_id='map')
    header.stamp.sec, header.stamp.nanosec = int(stamp_s), int(round(stamp_s % 1 * 1e9))
    points = np.asarray(points, dtype=float)
    return array_to_cloud({'x': points[:, 0], 'y': points[:, 1]}, header)


def test_unwanted_outputs_are_not_built_and_the_candidates_move_alike():
    config = node_config('mahalanobis_nn', {'confirm_hits': 2, 'confirm_window': 3,
                                            'publish_markers': True})
    everything, only_answers = AssociationPipeline(config), AssociationPipeline(config)
    scans = [[[30.0, -30.0], [0.1, 0.0]], [[30.02, -30.0], [0.0, 0.1]]]
    for k, points in enumerate(scans):
        landmarks = clouds(1.0 + k, [[0.0, 0.0]])
        landmarks = array_to_cloud({'id': np.array([7]), 'x': np.array([0.0]),
                                    'y': np.array([0.0])}, landmarks.header)
        for pipeline in (everything, only_answers):
            pipeline.on_landmarks(landmarks)
        full = everything.answer(clouds(1.0 + k, points))
        bare = only_answers.answer(clouds(1.0 + k, points), wanted=set())
        assert cloud_to_array(full.correspondences)['landmark'].tolist() == [-1, 7]
        assert cloud_to_array(bare.correspondences)['landmark'].tolist() == [-1, 7]
        assert (bare.new_landmarks, bare.candidates, bare.markers) == (None, None, None)
        assert full.candidates is not None and full.markers is not None
    # the second sighting confirmed the landmark in both; only the first built the cloud
    assert cloud_to_array(full.new_landmarks)['observation'].tolist() == [0, 0]
    assert everything.statistics.candidates_confirmed == 1
    assert only_answers.statistics.candidates_confirmed == 1
    assert OPTIONAL_OUTPUTS == {'new_landmarks', 'landmark_candidates', 'association_markers'}
