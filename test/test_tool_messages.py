"""The bag tools as a new user meets them: every option has a help line; wrong input (unknown
algorithm, an existing --out, a topic of another or an uninstalled type, a sqlite3 bag, a file
that is no bag) gives one clear line and exit code 2 before anything starts; recordings carry
the algorithm and parameters; the MOT tools read the MOTChallenge layout and never overwrite a
bag; score tables have one-word headers, aligned columns and '-' for NaN."""
from __future__ import annotations

import argparse
import importlib
import io
import json
import re
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message

from data_association_ros.bag import evaluate, replay
from data_association_ros.bag.message_types import schema_text
from data_association_ros.bag.mot import read_mot_bag
from data_association_ros.bag.reader import BagError, BagReader
from data_association_ros.bag.rosbag2_metadata import read_custom_data
from ros_harness import cloud

REPO = Path(__file__).resolve().parents[1]
BAGS = REPO / 'bags'
BIN = Path(sys.executable).parent
NODES = {'association_node', 'ekf_slam_node', 'box_tracker_node', 'lidar_tracker_node'}
SCRIPTS = [(name, module, function) for name, module, function in re.findall(
    r"'(\w+) = ([\w.]+):(\w+)'", (REPO / 'setup.py').read_text()) if name not in NODES]


def run(tool: str, *arguments, cwd: Path = REPO) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / tool), *map(str, arguments)], capture_output=True,
                          text=True, timeout=180, cwd=cwd)


def one_error_line(result: subprocess.CompletedProcess, tool: str) -> str:
    """The single stderr line of a refused run (exit code 2), without the tool's prefix."""
    assert result.returncode == 2, (result.stdout, result.stderr)
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f'{tool}: '), result.stderr
    return lines[0][len(tool) + 2:]


class _Parser(Exception):
    pass


@pytest.mark.parametrize('name, module, function', SCRIPTS, ids=[s[0] for s in SCRIPTS])
def test_every_option_of_every_console_script_has_a_help_line(monkeypatch, name, module,
                                                               function):
    def capture(parser, args=None, namespace=None):
        raise _Parser(parser)
    monkeypatch.setattr(argparse.ArgumentParser, 'parse_args', capture)
    with pytest.raises(_Parser) as caught:
        getattr(importlib.import_module(module), function)([])
    parser = caught.value.args[0]
    assert parser.prog == name
    assert parser.description and parser.description.endswith('.'), parser.description
    assert '\n' not in parser.description.strip()
    assert [a.dest for a in parser._actions if not a.help] == []


def write_raw_bag(path: Path, topics: dict[str, tuple[str, bytes]]) -> Path:
    """A bare .mcap file with one message per topic: {topic: (type name, CDR bytes)}; types
    not installed get a made-up schema."""
    with open(path, 'wb') as stream:
        writer = Writer(stream)
        writer.start(profile='ros2', library='test')
        for k, (topic, (type_name, data)) in enumerate(topics.items()):
            try:
                schema = schema_text(type_name).encode()
            except LookupError:
                schema = b'float64 x\n'
            schema_id = writer.register_schema(name=type_name, encoding='ros2msg', data=schema)
            channel = writer.register_channel(topic=topic, message_encoding='cdr',
                                              schema_id=schema_id)
            writer.add_message(channel_id=channel, log_time=1000 + k, publish_time=1000 + k,
                               data=data)
        writer.finish()
    return path


CLOUD = ('sensor_msgs/msg/PointCloud2', bytes(serialize_message(cloud({'x': [1.0]}, 1.0))))
TRUTH = ('sensor_msgs/msg/PointCloud2', next(BagReader(BAGS / 'easy_point_map').messages(
    ['/ground_truth/correspondences'], deserialize=False)).data)
ODOMETRY = ('nav_msgs/msg/Odometry', bytes(serialize_message(Odometry())))
UNINSTALLED = ('fake_msgs/msg/Boxes', bytes(12))


@pytest.mark.parametrize('observations, expected', [
    (ODOMETRY, 'topic /observations has type nav_msgs/msg/Odometry, expected '
               'sensor_msgs/msg/PointCloud2'),
    (UNINSTALLED, 'topic /observations has type fake_msgs/msg/Boxes (not installed here), '
                  'expected sensor_msgs/msg/PointCloud2')])
def test_a_topic_of_another_or_uninstalled_type_is_named_in_one_line(tmp_path, observations,
                                                                     expected):
    bag = write_raw_bag(tmp_path / 'wrong.mcap', {
        '/landmarks': CLOUD, '/observations': observations,
        '/ground_truth/correspondences': TRUTH})
    line = f'{bag}: {expected}'
    assert one_error_line(run('da_bag_eval', bag, '--offline'), 'da_bag_eval') == line
    if observations is UNINSTALLED:
        return   # the same check in every tool (BagReader.check_type): once is enough
    assert one_error_line(run('da_bag_eval', bag, '--algorithms', 'gnn'), 'da_bag_eval') == line
    out = tmp_path / 'out'
    assert one_error_line(run('da_bag_replay', bag, '--algorithm', 'gnn', '--out', out),
                          'da_bag_replay') == line
    assert not out.exists()
    mot = write_raw_bag(tmp_path / 'mot.mcap', {'/observations': CLOUD,
                                                '/ground_truth/tracks': observations})
    assert one_error_line(run('da_mot_eval', mot), 'da_mot_eval') == \
        f'{mot}: {expected}'.replace('/observations', '/ground_truth/tracks')


def test_a_sqlite3_bag_is_named_with_the_conversion_command(tmp_path):
    bag = tmp_path / 'rosbag2_db3'
    bag.mkdir()
    with sqlite3.connect(bag / 'rosbag2_db3_0.db3') as db:
        db.execute('CREATE TABLE topics(id INTEGER)')
    (bag / 'metadata.yaml').write_text(
        'rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n'
        '  relative_file_paths: [rosbag2_db3_0.db3]\n')
    for path in (bag, bag / 'rosbag2_db3_0.db3'):
        line = one_error_line(run('da_bag_eval', path, '--offline'), 'da_bag_eval')
        assert line.startswith(f'{path}: a sqlite3 (.db3) bag; only the MCAP storage is read. '
                               f'Convert it on a ROS 2 install: ros2 bag convert -i {path} '
                               '-o out.yaml'), line
        assert 'storage_id: mcap' in line
    (bag / 'metadata.yaml').unlink()   # a folder of .db3 files only
    assert 'only the MCAP storage is read' in one_error_line(
        run('da_mot_eval', bag), 'da_mot_eval')


def test_a_file_or_folder_that_is_no_bag_gets_a_plain_message(tmp_path):
    text = tmp_path / 'notes.txt'
    text.write_text('not a bag\n')
    assert one_error_line(run('da_bag_eval', text, '--offline'), 'da_bag_eval') == \
        f'{text}: not a bag (neither an MCAP file nor a rosbag2 bag directory)'
    empty = tmp_path / 'empty'
    empty.mkdir()
    assert one_error_line(run('da_bag_replay', empty, '--algorithm', 'gnn', '--out',
                              tmp_path / 'out'), 'da_bag_replay') == \
        f'{empty}: not a bag (no metadata.yaml and no .mcap file)'
    with pytest.raises(BagError, match=r'^[^\\]*$'):   # no byte string in the message
        BagReader(text)


def test_replay_refuses_an_unknown_algorithm_before_starting_anything(tmp_path):
    out = tmp_path / 'out'
    result = run('da_bag_replay', BAGS / 'easy_point_map', '--algorithm', 'magic', '--out', out)
    assert result.returncode == 2
    assert "argument --algorithm: invalid choice: 'magic'" in result.stderr
    for name in ('euclidean_nn', 'gnn', 'jcbb', 'multi_hypothesis'):
        assert f"'{name}'" in result.stderr
    assert not out.exists()
    assert 'association_node' not in result.stderr   # no node was started


def test_replay_records_algorithm_and_parameters_refuses_existing_out_and_eval_shows_them(
        tmp_path):
    out = tmp_path / 'recording'
    out.mkdir()
    (out / 'keep.txt').write_text('mine')
    assert one_error_line(run('da_bag_replay', BAGS / 'easy_point_map', '--algorithm', 'gnn',
                              '--out', out), 'da_bag_replay') == \
        f'{out} exists; choose another --out or add --force to replace it'
    assert one_error_line(run('da_bag_replay', BAGS / 'easy_point_map', '--algorithm', 'gnn',
                              '--out', out, '--force'), 'da_bag_replay') == \
        f'{out} exists and is not a bag directory: not replaced, even with --force'
    assert (out / 'keep.txt').read_text() == 'mine'
    out = tmp_path / 'bag_out'
    first = run('da_bag_replay', BAGS / 'easy_point_map', '--algorithm', 'jcbb', '--rate', '0',
                '--out', out, '-p', 'gate_probability:=0.95')
    assert first.returncode == 0, first.stderr
    custom = read_custom_data(out)
    assert custom[replay.RECORDED_ALGORITHM_KEY] == 'jcbb'
    assert json.loads(custom[replay.RECORDED_PARAMETERS_KEY]) == {'gate_probability': 0.95}
    assert custom[replay.RECORDED_BAG_KEY] == str(BAGS / 'easy_point_map')
    assert run('da_bag_replay', BAGS / 'easy_point_map', '--algorithm', 'jcbb',
               '--out', out).returncode == 2   # exists
    scored = run('da_bag_eval', BAGS / 'easy_point_map', out)
    assert scored.returncode == 0, scored.stderr
    lines = scored.stdout.splitlines()
    assert lines[0] == (f'{out}: {BAGS / "easy_point_map"} replayed with jcbb, parameters '
                        '{"gate_probability": 0.95}')
    assert lines[2].split()[0] == 'jcbb' and lines[2].split()[6] == '40/40'


def test_score_table_has_one_word_headers_aligned_columns_and_dashes_for_nan():
    rows = [{'algorithm': 'jcbb', 'pair_precision': 1.0, 'pair_recall': 0.997,
             'new_correct': 0, 'new_false': 153, 'clutter_paired': 0, 'clutter': 160,
             'answered': 40, 'messages': 40, 'landmarks_right': 0, 'landmarks_false': 153,
             'landmarks_duplicate': 0, 'landmarks_missed': 0,
             'confirm_delay_scans': float('nan'), 'latency_median_ms': 2.21,
             'latency_p99_ms': float('nan')},
            {'algorithm': 'maximum_likelihood', 'pair_precision': float('nan'),
             'pair_recall': 0.5, 'new_correct': 12345, 'new_false': 1, 'clutter_paired': 18,
             'clutter': 160, 'answered': 4, 'messages': 40, 'landmarks_right': 3,
             'landmarks_false': 1, 'landmarks_duplicate': 1, 'landmarks_missed': 2,
             'confirm_delay_scans': 2.0, 'latency_median_ms': 1.0, 'latency_p99_ms': 30.5}]
    lines = evaluate.format_table(rows, offline=False).splitlines()
    columns = len(evaluate.COLUMNS) + len(evaluate.LIVE_COLUMNS)
    assert all(len(line.split()) == columns for line in lines), lines
    assert len({len(line) for line in lines}) == 1, lines          # right edges aligned
    assert 'nan' not in '\n'.join(lines)
    assert lines[1].split()[11] == '-' and lines[2].split()[1] == '-'
    for k, title in enumerate(lines[0].split()[1:], start=1):     # each column's right edge
        end = lines[0].index(title) + len(title)
        assert all(line[:end].split()[-1] == line.split()[k] for line in lines[1:]), title


@pytest.mark.parametrize('parameters, note', [([], True), (['-p', 'confirm_hits:=2'], False)])
def test_main_job_table_explains_lm_false_with_confirm_hits_1(capsys, parameters, note):
    assert evaluate.main([str(BAGS / 'clutter_range_bearing'), '--offline', '--algorithms',
                          'jcbb', *parameters]) == 0
    text = capsys.readouterr().out
    assert ('lm_false is high with confirm_hits 1' in text) == note
    assert 'precision, recall: correct pairs' in text   # the legend


def test_progress_bar_names_the_algorithm_and_the_bag(monkeypatch):
    stream = io.StringIO()
    stream.isatty = lambda: True
    monkeypatch.setattr(sys, 'stderr', stream)
    replay._progress('jcbb on clutter_range_bearing', 20, 40)
    assert stream.getvalue() == ('\rjcbb on clutter_range_bearing '
                                 '[###############...............] 20/40 scans')


def write_sequence(folder: Path) -> None:
    """A small MOT17-style sequence: det/det.txt, gt/gt.txt (with ignored rows), seqinfo.ini."""
    (folder / 'det').mkdir(parents=True)
    (folder / 'gt').mkdir()
    (folder / 'det' / 'det.txt').write_text(
        '1,-1,10,20,30,60,0.9,-1,-1,-1\n2,-1,12,20,30,60,0.8,-1,-1,-1\n'
        '3,-1,14,20,30,60,0.9,-1,-1,-1\n')
    (folder / 'gt' / 'gt.txt').write_text(
        '1,1,10,20,30,60,1,1,1.0\n2,1,12,20,30,60,1,1,0.9\n3,1,14,20,30,60,1,1,1.0\n'
        '1,2,100,20,30,60,0,1,1.0\n'       # conf 0: ignored by the evaluation
        '2,3,200,20,30,60,1,7,1.0\n'       # class 7 (static person): not a pedestrian
        '3,4,300,20,30,60,1,2,0.5\n')      # class 2 (person on vehicle)
    (folder / 'seqinfo.ini').write_text(
        '[Sequence]\nname=MOT17-99-TEST\nimDir=img1\nframeRate=10\nseqLength=3\n'
        'imWidth=1920\nimHeight=1080\nimExt=.jpg\n')


def test_make_mot_bag_reads_the_motchallenge_layout_and_never_overwrites(tmp_path):
    write_sequence(tmp_path / 'MOT17-99-TEST')
    made = run('da_make_mot_bag', tmp_path / 'MOT17-99-TEST', cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    bag = tmp_path / 'mot_mot17_99_test'
    assert made.stdout.strip() == bag.name
    custom = read_custom_data(bag)
    assert custom['data_association_ros.mot.sequence'] == 'MOT17-99-TEST'
    assert custom['data_association_ros.mot.image_size'] == '1920x1080'
    assert custom['data_association_ros.mot.fps'] == '10'
    stamps = [m.log_time_ns for m in BagReader(bag).messages(['/observations'])]
    assert stamps == [0, 100_000_000, 200_000_000]   # frameRate 10
    _, truth = read_mot_bag(bag)
    assert [t['id'].tolist() for t in truth] == [[1], [1], [1]]   # ignored rows dropped
    before = (bag / 'metadata.yaml').read_text()
    again = run('da_make_mot_bag', tmp_path / 'MOT17-99-TEST', cwd=tmp_path)
    assert one_error_line(again, 'da_make_mot_bag') == \
        f'{bag.name} exists; choose another --out or add --force to replace it'
    assert (bag / 'metadata.yaml').read_text() == before
    scored = run('da_mot_eval', bag, '--algorithms', 'iou')
    assert scored.returncode == 0, scored.stderr
    assert 'SORT' not in scored.stdout and '(MOT17-99-TEST;' in scored.stdout
    shipped = run('da_mot_eval', '--algorithms', 'iou')
    assert shipped.returncode == 0, shipped.stderr
    sort_rows = [line for line in shipped.stdout.splitlines() if line.startswith('SORT')]
    assert len(sort_rows) == 1 and sort_rows[0].split()[2:4] == ['62.7', '60.6']


def test_make_mot_bag_still_reads_the_flat_layout(tmp_path):
    write_sequence(tmp_path / 'seq')
    flat = tmp_path / 'flat'
    flat.mkdir()
    (flat / 'det.txt').write_text((tmp_path / 'seq' / 'det' / 'det.txt').read_text())
    (flat / 'gt.txt').write_text((tmp_path / 'seq' / 'gt' / 'gt.txt').read_text())
    made = run('da_make_mot_bag', flat, '--out', tmp_path / 'flat_bag', cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    assert read_custom_data(tmp_path / 'flat_bag')['data_association_ros.mot.sequence'] == 'flat'
    stamps = [m.log_time_ns for m in BagReader(tmp_path / 'flat_bag').messages(
        ['/observations'])]
    assert np.diff(stamps).tolist() == [40_000_000, 40_000_000]   # 25 fps without seqinfo
