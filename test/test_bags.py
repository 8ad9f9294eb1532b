"""Bags: rosbag2 format, deterministic regeneration, exact re-reading, clear errors."""
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rclpy.serialization import serialize_message
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String

from data_association_ros.bag.make_bags import make_bag
from data_association_ros.bag.message_types import schema_text, type_hash, type_name_of
from data_association_ros.bag.reader import BagError, BagReader
from data_association_ros.bag.datasets import DEFAULT_DATA_DIRECTORY, SEQUENCES
from data_association_ros.bag.datasets.slam_bags import sequence_messages
from data_association_ros.bag.scenarios import SCENARIOS
from data_association_ros.bag.writer import BagWriter
from msg_adapters import cloud_to_array

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
REFERENCE = ROOT.parent / 'shared' / 'data' / 'rosbag2_reference_bags'


@pytest.mark.parametrize('name', sorted(SCENARIOS) + sorted(SEQUENCES))
def test_committed_bags_regenerate_to_the_same_messages(tmp_path, name):
    if name in SEQUENCES:   # converted data sets: the converter's messages, not re-read
        sequence = SEQUENCES[name](DEFAULT_DATA_DIRECTORY)
        fresh = [(topic, type_name_of(msg), log_time, msg)
                 for topic, msg, log_time in sequence_messages(sequence)]
    else:
        make_bag(name, tmp_path)
        fresh = [(m.topic, m.type_name, m.log_time_ns, m.msg)
                 for m in BagReader(tmp_path / name).messages()]
    committed = list(BagReader(BAGS / name).messages())
    assert len(fresh) == len(committed) > 0
    for (topic, type_name, log_time, msg), b in zip(fresh, committed):
        assert (topic, type_name, log_time) == (b.topic, b.type_name, b.log_time_ns)
        assert_same_message(msg, b.msg, f'{topic} at {log_time}')


def assert_same_message(a, b, where):
    """Equal up to float rounding (1e-9 relative): decoded clouds field by field, other messages
    field by field recursively."""
    if isinstance(a, PointCloud2):
        if a == b:
            return
        assert (a.header, a.fields, a.height, a.width) == (b.header, b.fields, b.height,
                                                           b.width), where
        x, y = cloud_to_array(a), cloud_to_array(b)
        for name in x.dtype.names:
            np.testing.assert_allclose(x[name], y[name], rtol=1e-6, atol=1e-9, err_msg=where)
    elif hasattr(a, 'get_fields_and_field_types'):
        if a == b:      # exact (the usual case on one machine): no field-by-field walk
            return
        for field in a.get_fields_and_field_types():
            assert_same_message(getattr(a, field), getattr(b, field), f'{where}.{field}')
    elif isinstance(a, (float, np.ndarray)) or (isinstance(a, (list, tuple)) and a
                                                 and isinstance(a[0], float)):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12, err_msg=where)
    elif isinstance(a, (list, tuple)) and a and hasattr(a[0], 'get_fields_and_field_types'):
        assert len(a) == len(b), where
        for k, (u, v) in enumerate(zip(a, b)):
            assert_same_message(u, v, f'{where}[{k}]')
    else:
        assert a == b, where


@pytest.mark.parametrize('name', sorted(SCENARIOS) + sorted(SEQUENCES))
def test_metadata_is_rosbag2_version_9_and_matches_the_mcap(name):
    info = yaml.safe_load((BAGS / name / 'metadata.yaml').read_text())[
        'rosbag2_bagfile_information']
    assert info['version'] == 9 and info['storage_identifier'] == 'mcap'
    assert info['ros_distro'] == 'jazzy'
    for key in ('duration', 'starting_time', 'message_count', 'topics_with_message_count',
                'compression_format', 'compression_mode', 'relative_file_paths', 'files',
                'custom_data'):
        assert key in info, key
    reader = BagReader(BAGS / name)
    messages = list(reader.messages(deserialize=False))
    assert info['message_count'] == len(messages)
    assert info['starting_time']['nanoseconds_since_epoch'] == messages[0].log_time_ns
    assert info['duration']['nanoseconds'] == messages[-1].log_time_ns - messages[0].log_time_ns
    assert info['relative_file_paths'] == [f'{name}_0.mcap']
    for entry in info['topics_with_message_count']:
        topic = entry['topic_metadata']
        assert topic['serialization_format'] == 'cdr'
        assert topic['type_description_hash'] == type_hash(topic['type'])
        assert isinstance(topic['offered_qos_profiles'], list)
        assert entry['message_count'] == sum(m.topic == topic['name'] for m in messages)
    assert (BAGS / name / f'{name}_0.mcap').stat().st_size < 3_000_000


def test_mcap_has_ros2_profile_ros2msg_schemas_and_summary():
    from mcap.reader import make_reader
    with open(BAGS / 'clutter_range_bearing' / 'clutter_range_bearing_0.mcap', 'rb') as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
    assert summary.statistics.message_count > 0 and summary.chunk_indexes
    for schema in summary.schemas.values():
        assert schema.encoding == 'ros2msg'
        assert schema.data.decode() == schema_text(schema.name)
    for channel in summary.channels.values():
        assert channel.message_encoding == 'cdr'
        assert channel.metadata['topic_type_hash'].startswith('RIHS01_')


def test_written_bag_rereads_bit_exactly(tmp_path):
    rng = np.random.default_rng(0)
    payloads = []
    with BagWriter(tmp_path / 'exact') as bag:
        for k in range(50):
            data = serialize_message(String(data=''.join(rng.choice(list('abc'), k))))
            payloads.append(data)
            bag.write_serialized('/text', 'std_msgs/msg/String', data, 1_000 + k)
    read = [m.data for m in BagReader(tmp_path / 'exact').messages(deserialize=False)]
    assert read == payloads


def test_reads_real_rosbag2_bags():
    bare = BagReader(REFERENCE / 'talker.mcap')
    strings = [m.msg.data for m in bare.messages(['/topic'])]
    assert len(strings) == 10 and strings[0].startswith('Hello')
    version8 = BagReader(REFERENCE / 'bag_with_topics_and_service_events')
    assert version8.topics['/test_topic1'] == 'test_msgs/msg/Strings'
    assert list(version8.messages()) == []  # test_msgs is not installed: skipped and counted
    assert version8.skipped_types['test_msgs/msg/Strings'] == 2
    with pytest.raises(BagError, match='no /observations topic'):
        version8.require(['/observations'])


@pytest.mark.parametrize('damage', ['truncate', 'garbage', 'no_mcap'])
def test_damaged_bag_gives_a_clear_error(tmp_path, damage):
    bag = tmp_path / 'bag'
    shutil.copytree(BAGS / 'easy_point_map', bag)
    mcap = bag / 'easy_point_map_0.mcap'
    data = mcap.read_bytes()
    if damage == 'truncate':
        mcap.write_bytes(data[:len(data) // 2])
    elif damage == 'garbage':
        mcap.write_bytes(data[:100] + b'\x00' * (len(data) - 100))
    else:
        mcap.unlink()
    with pytest.raises(BagError, match='easy_point_map_0.mcap'):
        list(BagReader(bag).messages())
    run = subprocess.run([sys.executable, '-m', 'data_association_ros.bag.evaluate', str(bag),
                          '--offline'], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2
    assert 'da_bag_eval: ' in run.stderr and 'Traceback' not in run.stderr


def test_eval_of_a_bag_without_observations_says_so():
    run = subprocess.run([sys.executable, '-m', 'data_association_ros.bag.evaluate',
                          str(REFERENCE / 'talker.mcap'), '--offline'], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 2 and 'has no /observations topic' in run.stderr
