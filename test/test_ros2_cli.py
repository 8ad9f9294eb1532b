"""The package used with the real ROS 2 tools, as a ROS user does (README "Running the node"):
`colcon build` in a workspace, then from its install/setup.bash `ros2 run`, `ros2 param
set|describe|dump`, `ros2 launch` of every launch file, `ros2 topic echo` while a bag is played
into the launched node, and Ctrl-C (SIGINT) to the launch.

The tools are not wheels: they come from ../shared/vendor/ros2_jazzy_cli (scripts/setup_env.sh
installs them into .venv); without that folder these tests are skipped.  Every ros2 call runs
with this run's ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the ros2 daemon the
verbs start is stopped at the end; the nodes run the numpy code (DATA_ASSOCIATION_ROS_NO_JIT=1,
see the `tools` fixture)."""
from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import warnings
from datetime import timedelta
from pathlib import Path

import pytest
import yaml

from data_association_ros.nodes.parameterized_node import TEARDOWN_S


REPO = Path(__file__).resolve().parents[1]
VENDOR = REPO.parent / 'shared' / 'vendor' / 'ros2_jazzy_cli'
VENV = Path(sys.prefix)
BAG = REPO / 'bags' / 'easy_point_map'
UP_S = 30.0
DOWN_S = 20.0
PARAM_S = 30.0

pytestmark = pytest.mark.skipif(
    not (VENDOR / 'install.sh').is_file(),
    reason=f'the ROS 2 command-line tools are not vendored here ({VENDOR} absent): no ros2 '
           'or colcon to test with (README "ros2 and colcon")')


class Tools:
    """Runs shell commands with the venv, the vendored tools and the workspace sourced."""

    def __init__(self, setup: Path, env: dict[str, str]) -> None:
        self.setup = setup
        self.env = env
        self.started: list[subprocess.Popen] = []

    def argv(self, command: str) -> list[str]:
        return ['bash', '-c', f'source {shlex.quote(str(self.setup))} && exec {command}']

    def run(self, command: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
        """`command` to completion; stdout and stderr merged into .stdout."""
        return subprocess.run(self.argv(command), env=self.env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, timeout=timeout)

    def param(self, arguments: str) -> str:
        """Output of `ros2 param ARGUMENTS`, asked again while the node is not yet in the
        graph the ros2 daemon sees (it starts with the first verb and discovers afresh), and
        once more, with a warning, when a call gets no answer in PARAM_S: ros2param waits for
        a service response without a timeout, and DDS can lose one (a response written before
        the server has discovered the new client's reader; ros2/system_tests#420).  A node
        that does not answer fails the second call too, with where the call and the processes
        `start` started were stuck."""
        deadline = time.monotonic() + UP_S
        lost = 0
        while True:
            output = self._ros2_param(arguments, report=lost > 0)
            if output is None:
                lost += 1
                warnings.warn(f'ros2 param {arguments}: no answer in {PARAM_S} s; asked again')
                deadline = time.monotonic() + UP_S
                continue
            if 'Node not found' not in output or time.monotonic() > deadline:
                return output
            time.sleep(0.5)

    def _ros2_param(self, arguments: str, report: bool) -> str | None:
        """Output of one `ros2 param ARGUMENTS` call; None when it gets no answer in PARAM_S,
        or with `report` an AssertionError with the stacks of the call's process group (with
        the ros2 daemon, when this call started it) and of the started processes still running.
        Only the call is killed: a daemon it started stays in its group."""
        with subprocess.Popen(self.argv(f'ros2 param {arguments}'), env=self.env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              start_new_session=True) as call:
            try:
                return call.communicate(timeout=PARAM_S)[0]
            except subprocess.TimeoutExpired:
                where = ''
                try:
                    if report:
                        where = '\n'.join([stacks(call)] + [
                            stacks(process) for process in self.started
                            if process.poll() is None])
                finally:
                    call.kill()
                    call.communicate()
        if report:
            raise AssertionError(f'ros2 param {arguments}: no answer in {PARAM_S} s, twice\n'
                                 f'{where}')
        return None

    def start(self, command: str, log: Path) -> subprocess.Popen:
        """`command` in the background, output to `log`."""
        with open(log, 'wb') as out:
            process = subprocess.Popen(self.argv(command), env=self.env, stdout=out,
                                       stderr=subprocess.STDOUT, start_new_session=True)
        self.started = [p for p in self.started if p.poll() is None] + [process]
        return process


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['ROS_DOMAIN_ID'] = os.environ['ROS_DOMAIN_ID']   # set by conftest.py for this run
    env.pop('PYTHONPATH', None)
    return env


@pytest.fixture(scope='module')
def tools(tmp_path_factory) -> Tools:
    """The package built by colcon in a temporary workspace (once for this module)."""
    env = _environment()
    installed = subprocess.run(['bash', str(VENDOR / 'install.sh'), str(VENV)], env=env,
                               capture_output=True, text=True)
    assert installed.returncode == 0, installed.stderr[-2000:]
    ws = tmp_path_factory.mktemp('ws')
    shutil.copytree(REPO, ws / 'src' / 'data_association_ros', ignore=shutil.ignore_patterns(
        '.venv', '.git', '__pycache__', '*.egg-info', 'build', 'install', 'log', '.pytest_cache',
        '.hypothesis'))
    setup = ws / 'env.bash'
    setup.write_text(f'export PATH={shlex.quote(str(VENV / "bin"))}:"$PATH"\n'
                     f'source {shlex.quote(str(VENV / "ros2_extra" / "setup.bash"))}\n')
    build = Tools(setup, env).run(f'colcon --log-base {ws}/log build --base-paths {ws}/src '
                                  f'--build-base {ws}/build --install-base {ws}/install',
                                  timeout=300)
    assert build.returncode == 0, build.stdout[-3000:]
    install = shlex.quote(str(ws / 'install' / 'setup.bash'))
    setup.write_text(setup.read_text() + f'source {install}\n')
    # the ROS tools are what is tested here, with the numpy code: the installed copy would
    # compile its own numba kernels at its first use (numba caches them by source path; 25-30 s
    # of CI), which the source tree's tests of the compiled kernels and of the node's start-up
    # cover.  What must hold: `ros2 run` imports the installed copy, not the source tree.
    env['DATA_ASSOCIATION_ROS_NO_JIT'] = '1'
    imported = Tools(setup, env).run(
        'python -c "import sys; sys.path.pop(0); from data_association_ros.core import jit; '
        'print(jit.__file__)"', timeout=60)
    assert imported.returncode == 0, imported.stdout[-2000:]
    assert imported.stdout.startswith(str(ws / 'install')), imported.stdout[-2000:]
    yield Tools(setup, env)
    Tools(setup, env).run('ros2 daemon stop', timeout=30)


def wait_for(log: Path, pattern: str, process: subprocess.Popen, timeout: float = UP_S) -> str:
    """The log text once `pattern` occurs in it; fails when the process ends first."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        text = log.read_text(errors='replace')
        if re.search(pattern, text):
            return text
        assert process.poll() is None, \
            f'ended (exit {process.returncode}) before {pattern!r}:\n{text}'
        time.sleep(0.2)
    raise AssertionError(f'no {pattern!r} after {timeout} s:\n{log.read_text(errors="replace")}')


def stop(process: subprocess.Popen) -> None:
    """SIGKILL to the process group that `Tools.start` made for `process`."""
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()


def stacks(process: subprocess.Popen, limit: int = 12000) -> str:
    """Where each process of `process`'s group is stuck (gdb: the Python stack of its main
    thread, its native stack, then every thread's innermost frames), for the report of a hang;
    '' without gdb.  The group's leader (the tool that started the others, e.g. ros2 launch
    waiting for its nodes) comes last: a CI log shows the head and tail of a long failure."""
    if shutil.which('gdb') is None:
        return ''
    listed = subprocess.run(['pgrep', '-g', str(process.pid)], capture_output=True, text=True)
    report = []
    for pid in sorted(listed.stdout.split(), key=lambda pid: pid == str(process.pid)):
        try:
            command = Path(f'/proc/{pid}/cmdline').read_bytes().replace(b'\0', b' ').decode()
            traced = subprocess.run(
                ['gdb', '-p', pid, '-batch', '-iex', 'set auto-load safe-path /', '-ex',
                 'thread 1', '-ex', 'py-bt', '-ex', 'bt 30', '-ex', 'thread apply all bt 8'],
                capture_output=True, text=True, timeout=60).stdout
        except (OSError, subprocess.TimeoutExpired) as error:
            traced = repr(error)
        traced = '\n'.join(line for line in traced.splitlines() if '[New LWP' not in line)
        report.append(f'--- {pid}: {command}\n{traced[:limit]}')
    return '\n'.join(report)


TEARDOWN_DUMP = f'Timeout ({timedelta(seconds=TEARDOWN_S)})!'
"""The first line of a node's teardown watchdog's dump (parameterized_node._stop, faulthandler)."""


def ended_in_the_dds_deadlock(text: str, prefix: str = '') -> bool:
    """Whether the output lines that start with `prefix` (ros2 launch's '[name-N] ' of one node;
    '' under ros2 run) hold the dump of a node its teardown watchdog ended while its main thread
    was in rclpy's destroy_node: Fast DDS 2.14's deadlock deleting the participant when another
    node leaves at the same moment (docs/robustness.md, "Ctrl-C").  A stop stuck anywhere else
    is not this."""
    lines = [line[len(prefix):] for line in text.splitlines() if line.startswith(prefix)]
    if TEARDOWN_DUMP not in lines:
        return False
    at = lines.index(TEARDOWN_DUMP)
    return len(lines) > at + 2 and \
        re.fullmatch(r'Thread 0x[0-9a-f]+ \(most recent call first\):', lines[at + 1]) is not None \
        and re.fullmatch(r'  File ".*/rclpy/node\.py", line \d+ in destroy_node',
                         lines[at + 2]) is not None


def interrupt(process: subprocess.Popen, log: Path) -> str:
    """SIGINT to `process` and its children (Ctrl-C in its terminal); its log once it has
    ended with exit code 0 and without a Traceback (or, under ros2 run, with exit code 1 when
    the node ended in the DDS deadlock, ended_in_the_dds_deadlock; warned).  When ros2 launch
    reports a node that 'failed to terminate' after SIGINT (it then sends SIGTERM, and SIGKILL
    10 s after that), the stacks of the group's processes are taken at once and appended to the
    log returned, so a node that hangs says where."""
    os.killpg(process.pid, signal.SIGINT)
    deadline = time.monotonic() + DOWN_S
    where = ''
    while process.poll() is None and time.monotonic() < deadline:
        if not where and 'failed to terminate' in log.read_text(errors='replace'):
            where = '\n' + stacks(process)
        time.sleep(0.1)
    if process.poll() is None:
        where = where or '\n' + stacks(process)
        stop(process)
        raise AssertionError(f'still running {DOWN_S} s after SIGINT:\n{log.read_text()}'
                             f'{where}')
    text = log.read_text(errors='replace') + where
    assert 'Traceback' not in text, text
    if TEARDOWN_DUMP in text:
        warnings.warn(f'a node stop outlived TEARDOWN_S; its watchdog ended it:\n{text}')
    assert process.returncode == 0 or (
        process.returncode == 1 and ended_in_the_dds_deadlock(text)), text
    return text


def assert_every_node_ended(text: str, nodes) -> None:
    """Each of `nodes` ('/name') finished cleanly in a ros2 launch log, but for at most one the
    teardown watchdog ended in the DDS deadlock (exit code 1, ended_in_the_dds_deadlock)."""
    deadlocked = 0
    for node in nodes:
        if re.search(rf'\[INFO\] \[{node[1:]}-\d+\]: process has finished cleanly', text):
            continue
        died = re.search(rf'\[ERROR\] \[({node[1:]}-\d+)\]: process has died \[pid \d+, '
                         r'exit code 1,', text)
        assert died and ended_in_the_dds_deadlock(text, f'[{died.group(1)}] '), text
        deadlocked += 1
    assert deadlocked <= 1, text


def dump(tools: Tools, node: str) -> dict:
    """The node's parameters as `ros2 param dump` gives them."""
    output = tools.param(f'dump {node}')
    assert output.startswith(f'{node}:'), output
    return yaml.safe_load(output)[node]['ros__parameters']


def test_colcon_build_installs_the_nodes_launch_files_and_config(tools):
    result = tools.run('ros2 pkg executables data_association_ros')
    executables = {line.split()[1] for line in result.stdout.splitlines() if line.strip()}
    assert {'association_node', 'ekf_slam_node', 'box_tracker_node', 'lidar_tracker_node',
            'da_bag_replay', 'da_bag_eval'} <= executables, result.stdout
    prefix = tools.run('ros2 pkg prefix data_association_ros').stdout.strip()
    share = Path(prefix) / 'share' / 'data_association_ros'
    assert sorted(p.name for p in (share / 'launch').iterdir()) == sorted(
        p.name for p in (REPO / 'launch').glob('*.launch.py'))
    assert (share / 'config' / 'association.yaml').read_text() == \
        (REPO / 'config' / 'association.yaml').read_text()


def test_ros2_run_then_param_set_get_describe_and_sigint(tools, tmp_path):
    log = tmp_path / 'run.log'
    process = tools.start('ros2 run data_association_ros association_node', log)
    try:
        wait_for(log, r'association_node ready', process)
        accepted = tools.param('set /association_node algorithm gnn')
        assert 'Set parameter successful' in accepted, accepted
        assert 'String value is: gnn' in tools.param('get /association_node algorithm')
        refused = tools.param('set /association_node algorithm magic')
        assert 'Setting parameter failed' in refused, refused
        assert "'magic' is not one of" in refused and 'jcbb' in refused, refused
        refused = tools.param('set /association_node confirm_window 0')
        assert 'Setting parameter failed' in refused and 'confirm_window' in refused, refused
        refused = tools.param('set /association_node confirm_hits 5')
        assert 'Setting parameter failed' in refused, refused
        assert 'confirm_hits (5) must not exceed confirm_window (3)' in refused, refused
        parameters = dump(tools, '/association_node')
        assert (parameters['algorithm'], parameters['confirm_hits'],
                parameters['confirm_window']) == ('gnn', 1, 3)
        described = tools.param('describe /association_node gate_probability '
                                'confirm_hits landmarks_type')
        gate, hits, landmarks_type = described.split('Parameter name:')[1:]
        assert 'Min value: 0.0' in gate and 'Max value: 1.0' in gate, described
        assert 'Min value: 1' in hits and 'Max value: 1000' in hits, described
        assert 'Read only: true' in landmarks_type or 'read-only' in landmarks_type, described
        assert 'valid: pointcloud2, pose_array' in landmarks_type, described
    except BaseException:
        stop(process)
        raise
    interrupt(process, log)
    assert "algorithm: 'mahalanobis_nn' -> 'gnn'" in log.read_text()


def test_ros2_run_refuses_an_invalid_start_parameter_in_one_line(tools):
    result = tools.run('ros2 run data_association_ros association_node --ros-args '
                       '-p gate_probability:=2.0', timeout=60)
    assert result.returncode != 0, result.stdout
    lines = [line for line in result.stdout.splitlines() if 'association_node:' in line]
    assert lines == ['association_node: invalid parameter gate_probability:=2.0: '
                     '2.0 outside (0, 1); not started'], result.stdout
    assert 'Traceback' not in result.stdout


LAUNCHES = {
    # launch file and arguments: {node: parameters it must come up with}
    'association.launch.py': ('', {'/association_node': yaml.safe_load(
        (REPO / 'config' / 'association.yaml').read_text())['association_node']
        ['ros__parameters']}),
    'slam.launch.py': ('algorithm:=gnn association_source:=ground_truth', {
        '/association_node': {'algorithm': 'gnn'},
        '/ekf_slam_node': {'association_source': 'ground_truth'}}),
    'lidar_tracker.launch.py': ('fine:=nearest jnis:=polar publish_markers:=true', {
        '/lidar_tracker_node': {'fine': 'nearest', 'jnis': 'polar', 'publish_markers': True}}),
}


DEADLOCK_DUMP = """Timeout (0:00:03)!
Thread 0x00007f7ba4a2b4c0 (most recent call first):
  File "/ws/.venv/lib/python3.11/site-packages/rclpy/node.py", line 1965 in destroy_node
  File "/ws/data_association_ros/nodes/parameterized_node.py", line 248 in _stop
  File "/ws/data_association_ros/nodes/parameterized_node.py", line 222 in spin"""
"""A watchdog's dump as association_node printed it in the deadlock (benchmarks/stop_race.py)."""


def test_the_dds_deadlock_is_told_from_its_dump_and_from_no_other():
    assert ended_in_the_dds_deadlock(f'[INFO] ready\n{DEADLOCK_DUMP}\n')
    launched = '\n'.join(f'[ekf_slam_node-2] {line}' for line in DEADLOCK_DUMP.splitlines())
    interleaved = launched.replace('\n', '\n[association_node-1] [INFO] bye\n', 1)
    assert ended_in_the_dds_deadlock(interleaved, '[ekf_slam_node-2] ')
    assert not ended_in_the_dds_deadlock(interleaved, '[association_node-1] ')
    elsewhere = DEADLOCK_DUMP.replace('rclpy/node.py", line 1965 in destroy_node',
                                      'threading.py", line 1112 in join')
    assert not ended_in_the_dds_deadlock(elsewhere)
    assert not ended_in_the_dds_deadlock(DEADLOCK_DUMP.split('\n', 1)[0])


def test_every_launch_file_is_covered():
    assert sorted(LAUNCHES) == sorted(p.name for p in (REPO / 'launch').glob('*.launch.py'))


@pytest.mark.parametrize('launch_file', sorted(LAUNCHES))
def test_ros2_launch_configures_every_node_and_ends_cleanly_on_sigint(tools, tmp_path,
                                                                       launch_file):
    arguments, expected = LAUNCHES[launch_file]
    log = tmp_path / 'launch.log'
    process = tools.start(f'ros2 launch data_association_ros {launch_file} {arguments}', log)
    try:
        for node in expected:
            wait_for(log, rf'\[{node[1:]}\]: {node[1:]} ready', process)
        for node, parameters in expected.items():
            actual = dump(tools, node)
            assert {k: actual[k] for k in parameters} == parameters, node
        if launch_file == 'association.launch.py':
            echo_while_playing(tools, tmp_path)
    except BaseException:
        stop(process)
        raise
    assert process.poll() is None, f'the launch ended by itself:\n{log.read_text()}'
    assert_every_node_ended(interrupt(process, log), expected)


def echo_while_playing(tools: Tools, tmp_path: Path) -> None:
    """`ros2 topic echo --once /correspondences` while BAG's inputs are published to the
    launched association_node: the message echoed answers one of the observations sent."""
    from data_association_ros.bag import topics
    from data_association_ros.bag.message_types import message_class
    from data_association_ros.bag.reader import BagReader
    from ros_harness import Graph

    reader = BagReader(BAG)
    present = [t for t in topics.INPUT_TOPICS if t in reader.topics]
    inputs = list(reader.messages(present))
    log = tmp_path / 'echo.log'
    echo = tools.start('ros2 topic echo --once --no-arr /correspondences '
                       'sensor_msgs/msg/PointCloud2', log)
    graph = Graph()
    try:
        publishers = {t: graph.publisher(message_class(reader.topics[t]), t) for t in present}
        graph.wait_for_subscribers(present, timeout=UP_S)
        assert graph.spin_until(
            lambda: graph.tester.count_subscribers(topics.CORRESPONDENCES) >= 1, UP_S), \
            'ros2 topic echo never subscribed'
        graph.spin_until(lambda: False, 1.0)   # both ends have seen each other
        sent = {}   # observation stamp -> observations in the message
        for message in inputs:
            if echo.poll() is not None:
                break
            publishers[message.topic].publish(message.msg)
            if message.topic == topics.OBSERVATIONS:
                stamp = message.msg.header.stamp
                sent[stamp.sec, stamp.nanosec] = message.msg.width * message.msg.height
                graph.spin_until(lambda: echo.poll() is not None, 0.05)
        echo.wait(timeout=UP_S)
    finally:
        if echo.poll() is None:
            stop(echo)
        graph.close()
    text = log.read_text()
    assert echo.returncode == 0, text
    stamp = re.search(r'stamp:\s+sec: (\d+)\s+nanosec: (\d+)', text)
    assert stamp and (int(stamp[1]), int(stamp[2])) in sent, text
    # one point per observation; fields observation, landmark, nis, probability, x, y
    assert f'width: {sent[int(stamp[1]), int(stamp[2])]}\n' in text, text
    assert 'PointField, length: 6>' in text, text
