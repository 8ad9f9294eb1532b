"""The four node executables at start-up: `--help` prints what the node does, its topics and
its parameters and exits 0 without starting ROS; an invalid parameter (out of range, wrong type,
not a choice, in conflict with another) stops the node with one line naming the parameter, the
value and the valid values, and exit code 1; Ctrl-C, even twice, ends it cleanly."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager
from datetime import timedelta
from pathlib import Path

import pytest

from data_association_ros.nodes.box_tracker_node import TRACKER_PARAMETERS
from data_association_ros.nodes.lidar_tracker_node import LIDAR_NODE_PARAMETERS
from data_association_ros.pipelines.parameters import NODE_PARAMETERS
from data_association_ros.pipelines.slam import SLAM_PARAMETERS

BIN = Path(sys.executable).parent
NODES = {'association_node': (NODE_PARAMETERS, ('landmarks', 'observations',
                                                'correspondences', 'new_landmarks'),
                              'README.md'),
         'ekf_slam_node': (SLAM_PARAMETERS, ('odometry', 'sensor_observations', 'slam_map'),
                           'docs/slam.md'),
         'box_tracker_node': (TRACKER_PARAMETERS, ('observations', 'landmarks'), 'docs/mot.md'),
         'lidar_tracker_node': (LIDAR_NODE_PARAMETERS, ('scan', 'points', 'tracks'),
                                'docs/lidar.md')}


def run(node: str, *arguments: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    return subprocess.run([str(BIN / node), *arguments], capture_output=True, text=True,
                          timeout=60, env=env)


@pytest.mark.parametrize('node', sorted(NODES))
def test_help_describes_the_node_and_exits_0(node):
    parameters, topics, page = NODES[node]
    result = run(node, '--help')
    assert result.returncode == 0, result.stderr
    text = result.stdout
    assert text.startswith(f'usage: ros2 run data_association_ros {node}'), text
    for topic in topics:
        assert f'`{topic}`' in text, (topic, text)
    assert page in text
    for parameter in parameters:
        assert f'\n  {parameter.name} ' in text, parameter.name
    assert result.stderr == ''   # no ROS log line: ROS was not started


CASES = [  # node, parameter, value given, the line expected on stderr
    ('association_node', 'gate_probability', '2.0',
     'association_node: invalid parameter gate_probability:=2.0: 2.0 outside (0, 1); '
     'not started'),
    ('association_node', 'confirm_hits', '0',
     'association_node: invalid parameter confirm_hits:=0: 0 outside [1, 1000]; not started'),
    ('association_node', 'algorithm', 'magic',
     "association_node: invalid parameter algorithm:='magic': 'magic' is not one of "
     'euclidean_nn, mahalanobis_nn, maximum_likelihood, gnn, jcbb, jcbb_points, iou, '
     'multi_hypothesis; not started'),
    ('association_node', 'confirm_hits', '2.5',
     'association_node: invalid parameter confirm_hits:=2.5: expected an integer, got 2.5 '
     '(valid: [1, 1000]); not started'),
    ('association_node', 'max_pairs', '1.0',
     'association_node: invalid parameter max_pairs:=1.0: expected a value of type int '
     '(valid: [1, inf)); not started'),
    ('association_node', 'observation_noise', '[-1.0]',
     'association_node: invalid parameter observation_noise:=[-1.0]: expected 1 to 4 positive '
     'variances, got [-1.0] (valid: 1 or m positive values); not started'),
    ('association_node', 'confirm_hits', '5',
     'association_node: invalid parameters: confirm_hits (5) must not exceed confirm_window '
     '(3); not started'),
    ('ekf_slam_node', 'association_source', 'oracle', None),
    ('box_tracker_node', 'min_hits', '-1',
     'box_tracker_node: invalid parameter min_hits:=-1: -1 outside [0, 1000]; not started'),
    ('lidar_tracker_node', 'fine', 'magic',
     "lidar_tracker_node: invalid parameter fine:='magic': 'magic' is not one of "
     'jcbb_points, nearest; not started'),
]


@pytest.mark.parametrize('node, name, value, line', CASES)
def test_an_invalid_start_parameter_stops_the_node_with_one_line(node, name, value, line):
    result = run(node, '--ros-args', '-p', f'{name}:={value}')
    assert result.returncode == 1, result.stderr
    assert result.stdout == ''
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    if line is None:
        parameter = next(p for p in NODES[node][0] if p.name == name)
        line = (f"{node}: invalid parameter {name}:={value!r}: {value!r} is not one of "
                f'{parameter.range_text()}; not started')
    assert lines[0] == line


@contextmanager
def ready_association_node(command: list[str], log: Path, **env: str):
    """The association_node process `command` (output to `log`, `env` added to this one's, DDS
    on loopback) once it has said "ready"; killed on leaving if still running."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', **env)
    with open(log, 'wb') as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=env)
    try:
        deadline = time.monotonic() + 30
        while 'association_node ready' not in log.read_text() and time.monotonic() < deadline:
            assert process.poll() is None, log.read_text()
            time.sleep(0.1)
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


@pytest.mark.parametrize('gap_s', [0.0, 0.02, 0.1, 0.5])
def test_ctrl_c_twice_ends_the_node_cleanly(tmp_path, gap_s):
    """Ctrl-C under `ros2 launch` reaches a node twice (from the terminal and from launch)."""
    log = tmp_path / 'node.log'
    with ready_association_node([str(BIN / 'association_node')], log) as process:
        process.send_signal(signal.SIGINT)
        time.sleep(gap_s)
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=20) == 0, log.read_text()
    assert 'Traceback' not in log.read_text() and 'KeyboardInterrupt' not in log.read_text()


STUCK_STOP = '''
import ctypes
from data_association_ros.nodes import association_node

def stuck(node):
    """A native call that keeps the GIL and never returns, as Fast DDS's deadlocked participant
    deletion inside destroy_node does."""
    ctypes.PyDLL(None).sleep(600)

association_node.AssociationNode.destroy_node = stuck
association_node.main()
'''


def test_a_stop_stuck_in_a_native_call_ends_the_process_after_teardown_s(tmp_path):
    """The teardown watchdog (parameterized_node._stop): a stop that cannot finish ends the
    process after TEARDOWN_S with every thread's stack on stderr and exit code 1 (without it,
    the node ignored SIGINT and SIGTERM for good)."""
    from data_association_ros.nodes.parameterized_node import TEARDOWN_S
    log = tmp_path / 'node.log'
    with ready_association_node([sys.executable, '-c', STUCK_STOP], log,
                                DATA_ASSOCIATION_ROS_NO_JIT='1') as process:
        process.send_signal(signal.SIGINT)
        sent = time.monotonic()
        assert process.wait(timeout=TEARDOWN_S + 20) == 1, log.read_text()
        took = time.monotonic() - sent
    text = log.read_text()
    assert took >= TEARDOWN_S - 0.1, (took, text)
    assert f'Timeout ({timedelta(seconds=TEARDOWN_S)})!' in text, text
    assert 'in stuck' in text and 'in _stop' in text, text
