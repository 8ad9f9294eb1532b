"""SlamPipeline (the ekf_slam_node's logic): message order does not change the result, bad
input is counted and never fatal, the oracle keeps the true ids."""
from pathlib import Path

import numpy as np
import pytest
from std_msgs.msg import Header

from msg_adapters import array_to_cloud, cloud_to_array
from msg_adapters.outputs import CORRESPONDENCE_DTYPE

from data_association_ros.bag import topics
from data_association_ros.bag.offline import node_config
from data_association_ros.bag.slam_run import read_inputs, run_offline, slam_config
from data_association_ros.pipelines.association import AssociationPipeline, stamp_ns
from data_association_ros.pipelines.slam import SlamPipeline

BAGS = Path(__file__).resolve().parents[1] / 'bags'
TTK = BAGS / 'ttk4250_simulated'


def scans_of(messages):
    """[(odometry msg, scan msg, truth msg)] per step (the first odometry is the origin)."""
    odometry = [m for t, m in messages if t == topics.ODOMETRY]
    scans = [m for t, m in messages if t == topics.SENSOR_OBSERVATIONS]
    truth = [m for t, m in messages if t == topics.GROUND_TRUTH]
    return odometry[0], list(zip(odometry[1:], scans, truth))


def answer_with(association, outputs):
    """Feed a SlamPipeline's outputs to an AssociationPipeline; the Answer of the scan."""
    handlers = {'landmarks': association.on_landmarks, 'robot_pose': association.on_robot_pose,
                'state_covariance': association.on_state_covariance}
    answer = None
    for topic, msg in outputs:
        if topic in handlers:
            handlers[topic](msg)
        elif topic == 'observations':
            answer = association.answer(msg)
    return answer


def run_in_order(steps, order, origin, mode='node'):
    """Closed loop over `steps`, delivering each step's messages in `order` (a permutation of
    'odometry', 'scan', 'new', 'answer'); returns the filter's final mean and ids."""
    slam = SlamPipeline(slam_config(mode, {}))
    association = AssociationPipeline(node_config('mahalanobis_nn', {}))
    slam.on_odometry(origin)
    for odometry, scan, truth in steps:
        pending = {'odometry': odometry, 'scan': scan}
        answer = None
        for item in order:
            if item == 'odometry':
                outputs = slam.on_odometry(odometry)
            elif item == 'scan':
                outputs = slam.on_scan(scan)
            else:
                continue
            produced = answer_with(association, outputs)
            answer = produced or answer
            pending.pop(item)
        assert answer is not None
        replies = [('new', answer.new_landmarks), ('answer', answer.correspondences)]
        if mode == 'ground_truth':
            replies = [('answer', truth)]
        for item in [o for o in order if o in ('new', 'answer')]:
            msg = dict(replies).get(item)
            if msg is None:
                continue
            if item == 'new':
                slam.on_new_landmarks(msg)
            elif mode == 'ground_truth':
                slam.on_ground_truth(msg)
            else:
                slam.on_correspondences(msg)
    return slam.slam.mean.copy(), slam.slam.ids.copy(), slam


@pytest.fixture(scope='module')
def ttk_steps():
    return scans_of(read_inputs(TTK, 25))


def test_message_order_does_not_change_the_estimate(ttk_steps):
    origin, steps = ttk_steps
    mean, ids, _ = run_in_order(steps, ('odometry', 'scan', 'new', 'answer'), origin)
    assert len(ids) > 10
    for order in [('scan', 'odometry', 'answer', 'new'), ('odometry', 'scan', 'answer', 'new')]:
        other_mean, other_ids, slam = run_in_order(steps, order, origin)
        np.testing.assert_array_equal(other_ids, ids)
        np.testing.assert_allclose(other_mean, mean, atol=1e-9)
        assert not slam.statistics.invalid and not slam.statistics.dropped


def test_oracle_keeps_true_ids_and_matches_the_truth(ttk_steps):
    origin, steps = ttk_steps
    _, ids, slam = run_in_order(steps, ('odometry', 'scan', 'answer'), origin, 'ground_truth')
    seen = set()
    for _, _, truth in steps:
        labels = cloud_to_array(truth)['landmark']
        seen |= {int(label) for label in labels if label >= 0}
    assert set(ids.tolist()) == seen
    # every landmark consistent with its truth (truth x, y are in the ground truth message):
    # normalised squared error below chi2_2(0.9999) = 18.4 (landmarks up to 75 m away, seen
    # with 1 degree bearing noise, are off by a metre and have the covariance to say so)
    positions = {}
    for _, _, truth in steps:
        for point in cloud_to_array(truth):
            if point['landmark'] >= 0:
                positions[int(point['landmark'])] = (point['x'], point['y'])
    estimate = slam.slam.landmarks()
    errors = [estimate.means[k] - positions[int(i)] for k, i in enumerate(ids)]
    nees = [e @ np.linalg.solve(c, e) for e, c in zip(errors, estimate.covariances)]
    assert max(nees) < 18.4, max(nees)
    assert np.mean(nees) < 4.0   # chi2_2 mean 2; the EKF is mildly overconfident


def test_odometry_is_composed_up_to_the_scan(ttk_steps):
    """Scans wait for odometry; a late odometry message releases them in order."""
    origin, steps = ttk_steps
    slam = SlamPipeline(slam_config('ground_truth', {}))
    slam.on_odometry(origin)
    (odometry0, scan0, truth0), (odometry1, scan1, truth1) = steps[:2]
    assert slam.on_scan(scan0) == []                 # no odometry up to its stamp yet
    out = slam.on_odometry(odometry0)
    assert [t for t, _ in out] == ['landmarks', 'robot_pose', 'state_covariance', 'observations']
    assert stamp_ns(out[-1][1].header) == stamp_ns(scan0.header)
    out = slam.on_ground_truth(truth0)
    assert [t for t, _ in out] == ['slam_map', 'slam_pose']
    assert slam.on_ground_truth(truth1) == []        # early: kept until its scan
    slam.on_odometry(odometry1)
    out = slam.on_scan(scan1)
    assert [t for t, _ in out][-2:] == ['slam_map', 'slam_pose']


def header_at(stamp_msg):
    return Header(stamp=stamp_msg.header.stamp, frame_id='base_link')


def test_bad_input_is_counted_never_fatal(ttk_steps):
    origin, steps = ttk_steps
    slam = SlamPipeline(slam_config('node', {}))
    slam.on_odometry(origin)
    odometry, scan, _ = steps[0]
    broken = type(odometry)()
    broken.header = odometry.header
    broken.pose.pose.orientation.w = 0.0              # not a rotation
    assert slam.on_odometry(broken) == []
    nan = type(odometry)()
    nan.header = odometry.header
    nan.pose.pose.orientation.w = 1.0
    nan.pose.pose.position.x = float('nan')
    assert slam.on_odometry(nan) == []
    assert slam.statistics.invalid['odometry'] == 2
    slam.on_odometry(odometry)
    garbage = array_to_cloud({'foo': np.zeros(3, dtype='<f4')}, header_at(scan))
    assert slam.on_scan(garbage) == []
    assert slam.statistics.invalid['sensor_observations'] == 1
    out = slam.on_scan(scan)
    assert out[-1][0] == 'observations'
    wrong = np.zeros(2, dtype=CORRESPONDENCE_DTYPE)   # the scan has more observations
    assert slam.on_correspondences(array_to_cloud(wrong, header_at(scan))) == []
    assert slam.statistics.invalid['correspondences'] == 1
    unknown = np.zeros(len(cloud_to_array(scan)), dtype=CORRESPONDENCE_DTYPE)
    unknown['landmark'] = 12345                         # no such landmark in the map
    out = slam.on_correspondences(array_to_cloud(unknown, header_at(scan)))
    assert [t for t, _ in out] == ['slam_map', 'slam_pose']
    assert slam.statistics.dropped['unknown_landmark_id'] == len(unknown)
    assert slam.on_correspondences(array_to_cloud(unknown, header_at(scan))) == []
    assert slam.statistics.dropped['stale_answer'] == 1


def test_offline_run_scores_on_a_slice():
    run = run_offline(read_inputs(TTK, 40), 'jcbb', 'node', {'gate_probability': 0.999}, {})
    assert len(run.answers) == 40 and run.final_map is not None
    assert len(run.poses) == 40


def test_restart_when_a_bag_plays_again(ttk_steps):
    origin, steps = ttk_steps
    slam = SlamPipeline(slam_config('ground_truth', {}))
    slam.on_odometry(origin)
    for odometry, scan, truth in steps[:12]:
        slam.on_odometry(odometry)
        slam.on_scan(scan)
        slam.on_ground_truth(truth)
    assert len(slam.slam) > 5
    slam.on_odometry(origin)                   # too old for the filter: dropped
    assert slam.statistics.dropped['odometry_too_old'] == 1
    odometry, scan, truth = steps[0]           # 1.1 s older than the last scan: restart
    slam.on_scan(scan)
    assert slam.statistics.dropped['restarts'] == 1 and slam.slam is None
    slam.on_odometry(origin)
    out = slam.on_odometry(odometry)
    assert [t for t, _ in out][-1] == 'observations'
    slam.on_ground_truth(truth)
    assert len(slam.slam) == len(cloud_to_array(truth))


def test_new_landmarks_once_per_scan_and_late_ones_keep_their_origin(ttk_steps):
    origin, steps = ttk_steps
    slam = SlamPipeline(slam_config('node', {}))
    association = AssociationPipeline(node_config('mahalanobis_nn', {}))
    slam.on_odometry(origin)
    odometry, scan, _ = steps[0]
    slam.on_odometry(odometry)
    answer = answer_with(association, slam.on_scan(scan))
    slam.on_correspondences(answer.correspondences)
    slam.on_new_landmarks(answer.new_landmarks)
    count = len(slam.slam)
    assert count == len(cloud_to_array(scan))
    slam.on_new_landmarks(answer.new_landmarks)          # the same message again: ignored
    assert len(slam.slam) == count
    assert slam.statistics.dropped['repeated_new_landmarks'] == 1
    odometry, scan1, _ = steps[1]
    slam.on_odometry(odometry)
    answer_with(association, slam.on_scan(scan1))       # the next scan is in flight
    late = cloud_to_array(answer.new_landmarks)[:1]
    late['candidate'] = 999
    slam.on_new_landmarks(array_to_cloud(late, answer.new_landmarks.header))
    assert slam.statistics.dropped['late_new_landmarks'] == 1
    newest = int(slam.slam.ids[-1])
    assert slam.origins[newest] == (stamp_ns(scan.header), int(late['observation'][0]))


def test_odometry_without_scans_is_folded(monkeypatch, ttk_steps):
    import data_association_ros.pipelines.slam as module
    monkeypatch.setattr(module, 'MAX_ODOMETRY_QUEUE', 3)
    origin, steps = ttk_steps
    slam = SlamPipeline(slam_config('ground_truth', {}))
    slam.on_odometry(origin)
    for odometry, _, _ in steps[:6]:
        slam.on_odometry(odometry)
    assert len(slam.odometry_queue) == 3
    assert slam.statistics.dropped['odometry_folded_without_scan'] == 4


def test_odometry_yaw_noise_scale_multiplies_the_heading_variance_only():
    """odometry_yaw_noise_scale s: the increment covariance's heading variance times s, its
    heading row and column times sqrt(s), x and y untouched (on top of odometry_noise_scale and
    before min_motion_variance)."""
    noise = np.array([[4e-4, 1e-5, 2e-6], [1e-5, 1e-4, 3e-6], [2e-6, 3e-6, 4e-6]])
    base = SlamPipeline(slam_config('node', {}))._motion_noise(noise)
    np.testing.assert_allclose(base, noise + 1e-9 * np.eye(3), rtol=1e-12)
    scaled = SlamPipeline(slam_config('node', {'odometry_yaw_noise_scale': 16.0,
                                               'odometry_noise_scale': 2.0,
                                               'min_motion_variance': 0.0}))._motion_noise(noise)
    factor = np.array([1.0, 1.0, 4.0])
    np.testing.assert_allclose(scaled, 2.0 * noise * np.outer(factor, factor), rtol=1e-12)
    assert scaled[2, 2] == pytest.approx(32.0 * noise[2, 2])
    assert scaled[0, 0] == pytest.approx(2.0 * noise[0, 0])
    assert np.all(np.linalg.eigvalsh(scaled) > 0)


def test_new_landmarks_after_the_answer_are_seen_with_their_own_scan_only(ttk_steps):
    """Live, a scan's new_landmarks may arrive after its correspondences, i.e. after the
    landmark manager's call for that scan: the landmarks started from it count as seen with
    that scan's landmarks, never with the next scan's (which would keep a true duplicate from
    ever being merged).  Merging on with a probability so small that nothing merges and a merge
    distance that records every pair: the record is exactly the pairs of one scan's fused or
    started landmarks (the last scan's late ones are recorded at the next call).  Every other
    scan's answer is scripted to leave the previous scan's landmarks unassociated, so that the
    next scan sees landmarks its predecessor did not (ttk's robot sees every landmark on every
    scan): recording late landmarks with the next scan's would show as extra pairs."""
    origin, steps = ttk_steps
    slam = SlamPipeline(slam_config('node', {'merge_probability': 1e-9, 'merge_distance': 500.0}))
    association = AssociationPipeline(node_config('mahalanobis_nn', {}))
    slam.on_odometry(origin)
    seen, late, crossings = [], 0, 0
    for step, (odometry, scan, _) in enumerate(steps):
        slam.on_odometry(odometry)
        answer = answer_with(association, slam.on_scan(scan))
        before = set(slam.slam.ids.tolist())
        points = cloud_to_array(answer.correspondences)
        if step % 2 and seen:
            points['landmark'][np.isin(points['landmark'], list(seen[-1]))] = -2
        slam.on_correspondences(array_to_cloud(points, answer.correspondences.header))
        assert set(slam.slam.ids.tolist()) == before       # nothing started before its news
        if answer.new_landmarks is not None:
            slam.on_new_landmarks(answer.new_landmarks)
        fused = {int(i) for i in points['landmark'] if i in before}
        started = set(slam.slam.ids.tolist()) - before
        late += bool(started)
        if len(seen) >= 1:      # pairs the old record made: the last scan's late, these fused
            crossings += len({(a, b) for a in seen[-1] - fused for b in fused - seen[-1]})
        seen.append(fused | started)
        # kept under the scan's stamp for its late landmarks, recorded at the next call
        stamp = stamp_ns(scan.header)
        assert set(slam.manager.seen_on) <= {stamp}
        assert slam.manager.seen_on.get(stamp, set()) == fused | started
    assert late >= 5 and crossings > 0 and slam.statistics.dropped['landmarks_merged'] == 0
    recorded = {(a, b) for a, others in slam.manager.together.items() for b in others if a < b}
    expected = {(min(a, b), max(a, b)) for group in seen[:-1] for a in group for b in group
                if a != b}
    last = {(min(a, b), max(a, b)) for a in seen[-1] for b in seen[-1] if a != b}
    assert expected and expected <= recorded <= expected | last


@pytest.mark.parametrize('mode', ['node', 'ground_truth'])
def test_the_scan_record_stays_one_scan_long_and_merging_can_be_switched_on(ttk_steps, mode):
    """With the landmark manager off (the default) and in oracle mode the per-scan record keeps
    one scan, not one per scan of the run; merging switched on at run time takes effect (the
    record of pairs starts)."""
    origin, steps = ttk_steps
    *_, slam = run_in_order(steps[:10], ('odometry', 'scan', 'new', 'answer'), origin, mode)
    assert len(slam.manager.seen_on) <= 1 and not slam.manager.together
    if mode == 'node':
        slam.config.update(merge_probability=1e-9, merge_distance=500.0)
        odometry, scan, _ = steps[10]
        association = AssociationPipeline(node_config('mahalanobis_nn', {}))
        slam.on_odometry(odometry)
        answer = answer_with(association, slam.on_scan(scan))
        slam.on_correspondences(answer.correspondences)
        assert slam.manager.active and slam.manager.together
