"""The benchmark script runs (quick mode) and its comparisons hold: fast jcbb gives the reference
JCBB's answers, the compiled kernels those of numpy and the pure-Python search, the time budget
cuts a long search short.  Timings are not asserted."""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'benchmarks'))

import run_benchmarks  # noqa: E402


def rows_of(text: str, title: str) -> list[list[str]]:
    """The data rows of the markdown table under `title`."""
    block = text[text.index(title):].split('\n\n')[1]
    return [[c.strip() for c in line.strip('|').split('|')] for line in block.splitlines()[2:]]


def test_quick_benchmarks_agree_with_the_reference(tmp_path):
    assert run_benchmarks.main(['--quick', '--sections', 'jcbb,compiled,seed,budget',
                                '--out', str(tmp_path)]) == 0
    text = (tmp_path / 'benchmarks.md').read_text()
    assert re.search(r'\d+ cores', text)
    jcbb = rows_of(text, 'jcbb versus the reference JCBB')
    assert [r[0] for r in jcbb] == ['clutter_range_bearing', 'dense random']
    for row in jcbb:
        same, total = row[3].split('/')
        assert same == total == row[1]
    from data_association_ros.core.associators import jcbb_compiled
    if jcbb_compiled.available():
        compiled = rows_of(text, 'jcbb: compiled kernels (numba) versus numpy and the pure-Python')
        assert [r[0] for r in compiled] == ['clutter_range_bearing', 'dense random',
                                            'node_latency K=50 N=200']
        for row in compiled:
            same, total = row[3].split('/')
            assert same == total == row[1]
    budget_rows = rows_of(text, 'jcbb time_budget_ms')
    assert len(budget_rows) == 4
    for row in budget_rows:
        cut, repeats = row[3].split('/')
        assert cut == repeats


def test_node_latency_benchmark_answers_every_message_of_every_server():
    """benchmarks/node_latency.py (the servers run together, taking turns) on a few messages:
    the echo and association_node answer all of them (this run's domain, loopback)."""
    import os
    import subprocess
    environment = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
                   'PYTHONPATH': os.pathsep.join([str(ROOT), os.environ.get('PYTHONPATH', '')])}
    output = subprocess.run(
        [sys.executable, str(ROOT / 'benchmarks' / 'node_latency.py'), '--messages', '6',
         '--warmup', '1', '--algorithms', 'mahalanobis_nn'], env=environment,
        capture_output=True, text=True, timeout=180, check=True).stdout
    rows = {line[:26].strip(): line[26:].split() for line in output.splitlines()[2:]}
    assert set(rows) == {'bare rclpy echo', 'mahalanobis_nn'}, output
    assert all(row[0] == '6' for row in rows.values()), output


def test_mrclam_benchmark_removes_exactly_the_other_robots_sightings():
    """benchmarks/mrclam_other_robots.without_clutter on robot 1's first 300 scans: every scan
    keeps its landmark sightings, in order, with their labels, and loses every robot sighting."""
    import numpy as np
    from mrclam_other_robots import without_clutter
    from msg_adapters import cloud_to_array
    from data_association_ros.bag import topics
    from data_association_ros.bag.datasets.sequence import CLUTTER
    from data_association_ros.bag.slam_run import read_inputs
    messages = read_inputs(ROOT / 'bags' / 'mrclam_robot1', 300)
    kept = without_clutter(messages)
    assert [topic for topic, _ in kept] == [topic for topic, _ in messages]
    removed = scans = 0
    truth_of = {}
    for (topic, before), (_, after) in zip(messages, kept):
        if topic == topics.GROUND_TRUTH:
            labels = cloud_to_array(before)['landmark']
            truth_of[(before.header.stamp.sec, before.header.stamp.nanosec)] = labels
            new = cloud_to_array(after)
            assert list(new['landmark']) == [label for label in labels if label != CLUTTER]
            assert list(new['observation']) == list(range(len(new)))
            removed += int((labels == CLUTTER).sum())
    for (topic, before), (_, after) in zip(messages, kept):
        if topic == topics.SENSOR_OBSERVATIONS:
            scans += 1
            labels = truth_of[(before.header.stamp.sec, before.header.stamp.nanosec)]
            old, new = cloud_to_array(before), cloud_to_array(after)
            assert new.dtype == old.dtype
            assert np.array_equal(new, old[labels != CLUTTER])
    assert scans == 300 and removed > 0


def test_mrclam_benchmark_groups_wrong_pairs_into_bursts_by_hand():
    """wrong_bursts: scans with wrong pairs at most BURST_SCANS apart are one burst."""
    from mrclam_other_robots import BURST_SCANS, wrong_bursts
    second = 1_000_000_000
    outcomes = {k * second: (0, 0) for k in range(100)}
    outcomes[3 * second] = (1, 0)
    outcomes[(3 + BURST_SCANS) * second] = (2, 1)
    outcomes[(4 + 2 * BURST_SCANS) * second] = (5, 0)
    assert wrong_bursts(outcomes) == [(3, 3.0, 3), (4 + 2 * BURST_SCANS, 4.0 + 2 * BURST_SCANS, 5)]


def test_mrclam_benchmark_counts_bursts_from_one_per_sighting_to_one_per_robot():
    """sighting_bursts on robot 1's data: 952 robot sightings (the data's SOURCES.md); with no
    pause allowed every sighting is a burst of duration 0, with any pause allowed each robot
    seen is one burst; in between the count falls as the pause grows."""
    from mrclam_other_robots import sighting_bursts
    sightings, bursts, durations, observations = sighting_bursts(1, -1.0)
    assert (sightings, bursts, observations) == (952, 952, 5723)
    assert not durations.any()
    _, one_each, durations, _ = sighting_bursts(1, 1e9)
    assert one_each == 4 and (durations > 0).all()
    counts = [sighting_bursts(1, pause)[1] for pause in (0.5, 1.0, 2.0, 10.0)]
    assert 952 > counts[0] >= counts[1] >= counts[2] >= counts[3] > 4
