"""da_bag_replay: play a bag's inputs through a live association_node and record its answers.

Starts the node as a separate process with the given parameters, publishes the bag's input
topics with the recorded timing scaled by --rate, records every /correspondences and
/new_landmarks message (log time = arrival) together with the observations as sent (log time =
send) into OUT, waits for the last answer and exits non-zero if the node died or answers are
missing.  OUT's metadata (custom_data) names the bag, the algorithm and the parameters; an
existing OUT is replaced only with --force.  DDS stays on loopback with a domain id of its own.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from ..pipelines.parameters import BY_NAME
from .parameter_arguments import parse_assignments
from .offline import node_config
from .reader import BagError, BagReader
from .ros_environment import (association_node_command, close_graph, open_graph,
                              stop_processes)
from . import topics

WAIT_FOR_NODE_S = 30.0
WAIT_FOR_ANSWERS_S = 10.0
SETTLE_S = 1.0
DRAIN_S = 0.3
"""Spinning after the last answer, for the outputs published after it."""
RECORDED_BAG_KEY = 'data_association_ros.recorded.bag'
RECORDED_ALGORITHM_KEY = 'data_association_ros.recorded.algorithm'
RECORDED_PARAMETERS_KEY = 'data_association_ros.recorded.parameters'
"""custom_data keys of a recording: the bag played, the algorithm, the parameters (JSON)."""


@dataclass
class ReplayResult:
    """What a replay sent and received."""

    sent: int = 0
    answered: int = 0
    node_alive: bool = True
    node_log: str = ''
    recorded: list = field(default_factory=list)  # (topic, msg, log time ns)
    restarted_after: Optional[int] = None  # observation messages sent before a forced restart
    node_rss_kb: list = field(default_factory=list)  # the node's resident memory, every 50 scans

    @property
    def ok(self) -> bool:
        return self.node_alive and self.answered >= self.sent

    def unanswered(self) -> list[int]:
        """Indices (0-based, in sending order) of the observation messages never answered."""
        answered = {_stamp_key(m) for t, m, _ in self.recorded if t == topics.CORRESPONDENCES}
        sent = [_stamp_key(m) for t, m, _ in self.recorded if t == topics.OBSERVATIONS]
        return [k for k, key in enumerate(sent) if key not in answered]

    def gaps(self) -> list[tuple[int, int]]:
        """The unanswered messages as inclusive index ranges [(first, last), ...]."""
        ranges: list[tuple[int, int]] = []
        for k in self.unanswered():
            if ranges and ranges[-1][1] == k - 1:
                ranges[-1] = (ranges[-1][0], k)
            else:
                ranges.append((k, k))
        return ranges


def resident_kb(pid: int) -> int:
    """VmRSS of process `pid` [kB] (Linux /proc), 0 where it cannot be read."""
    try:
        for line in Path(f'/proc/{pid}/status').read_text().splitlines():
            if line.startswith('VmRSS:'):
                return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _stamp_key(msg) -> tuple[int, int]:
    return msg.header.stamp.sec, msg.header.stamp.nanosec


def _progress(label: str, done: int, total: int) -> None:
    if sys.stderr.isatty():
        width = 30
        filled = int(width * done / max(total, 1))
        sys.stderr.write(f'\r{label} [{"#" * filled}{"." * (width - filled)}] {done}/{total}'
                         ' scans')
        if done == total:
            sys.stderr.write('\n')
        sys.stderr.flush()


def replay(bag: Path, algorithm: str, parameters: dict[str, Any], rate: float = 1.0,
           progress: bool = True, restart_after: Optional[int] = None) -> ReplayResult:
    """Play `bag` into a fresh association_node; the answers recorded (see module doc).
    restart_after: kill the node (SIGKILL) after that many observation messages and start a
    new one without waiting for it (fault injection: what is sent meanwhile is lost)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import PointCloud2

    from .message_types import message_class

    reader = BagReader(bag)
    reader.require([topics.LANDMARKS, topics.OBSERVATIONS])
    present = [t for t in topics.INPUT_TOPICS if t in reader.topics]
    inputs = [(m.topic, m.msg, m.log_time_ns) for m in reader.messages(present)]
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    log = tempfile.TemporaryFile()
    command = association_node_command(algorithm, parameters)

    def start_node():
        return subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
    process = start_node()
    context, node, executor = open_graph('da_bag_replay')
    result = ReplayResult()

    def record(topic):
        return lambda msg: result.recorded.append((topic, msg, time.time_ns()))
    for topic in topics.OUTPUT_TOPICS:
        node.create_subscription(PointCloud2, topic, record(topic), qos)
    # a prior map goes out once, transient_local, as a map server publishes it
    map_qos = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    publishers = {t: node.create_publisher(
        message_class(reader.topics[t]), t,
        map_qos if t == topics.LANDMARKS and parameters.get('prior_map') else qos)
        for t in present}
    try:
        deadline = time.monotonic() + WAIT_FOR_NODE_S
        while not (all(p.get_subscription_count() > 0 for p in publishers.values())
                   and all(node.count_publishers(t) > 0 for t in topics.OUTPUT_TOPICS)):
            if process.poll() is not None or time.monotonic() > deadline:
                raise BagError('association_node did not come up')
            executor.spin_once(timeout_sec=0.05)
        # Our writers see the node's readers; give the readers time to see our writers too
        # (messages sent before that are lost with volatile durability).
        settle = time.monotonic() + SETTLE_S
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.05)
        start_wall = time.monotonic()
        first_log = inputs[0][2] if inputs else 0
        total = sum(1 for t, _, _ in inputs if t == topics.OBSERVATIONS)
        for topic, msg, log_time in inputs:
            if rate > 0:
                target = start_wall + (log_time - first_log) / 1e9 / rate
                while (remaining := target - time.monotonic()) > 0:
                    executor.spin_once(timeout_sec=min(remaining, 0.01))
            if topic == topics.OBSERVATIONS:
                result.recorded.append((topic, msg, time.time_ns()))
                result.sent += 1
                if result.sent % 50 == 1:
                    result.node_rss_kb.append(resident_kb(process.pid))
                if progress:
                    _progress(f'{algorithm} on {bag.name}', result.sent, total)
            publishers[topic].publish(msg)
            if topic == topics.OBSERVATIONS and result.sent == restart_after:
                process.kill()
                process.wait()
                process = start_node()
                result.restarted_after = result.sent
            if process.poll() is not None:
                break
        deadline = time.monotonic() + WAIT_FOR_ANSWERS_S
        while time.monotonic() < deadline and process.poll() is None:
            result.answered = sum(1 for t, _, _ in result.recorded
                                  if t == topics.CORRESPONDENCES)
            if result.answered >= result.sent or (
                    result.restarted_after is not None and result.sent - 1 not in
                    result.unanswered()):
                break
            executor.spin_once(timeout_sec=0.05)
        # the outputs published after the last correspondences (new_landmarks) are still on
        # their way
        drain = time.monotonic() + DRAIN_S
        while time.monotonic() < drain and process.poll() is None:
            executor.spin_once(timeout_sec=0.05)
        result.answered = sum(1 for t, _, _ in result.recorded if t == topics.CORRESPONDENCES)
    finally:
        result.node_alive = process.poll() is None
        close_graph(context, node, executor)
        result.node_log = stop_processes([process], log)
    return result


def recording_custom_data(bag: Path, algorithm: str,
                          parameters: dict[str, Any]) -> dict[str, str]:
    """custom_data of a recording: what was played, with which algorithm and parameters."""
    return {RECORDED_BAG_KEY: str(bag), RECORDED_ALGORITHM_KEY: algorithm,
            RECORDED_PARAMETERS_KEY: json.dumps(parameters, sort_keys=True)}


def write_recording(out: Path, result: ReplayResult,
                    custom_data: Optional[dict[str, str]] = None) -> None:
    """OUT: the observations as sent and the node's outputs as received, in a bag whose
    metadata carries `custom_data` (recording_custom_data)."""
    from .writer import BagWriter
    with BagWriter(out, custom_data=custom_data) as bag:
        for topic, msg, log_time in sorted(result.recorded, key=lambda r: r[2]):
            bag.write(topic, msg, log_time)


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog='da_bag_replay', 
                                     description=' '.join(__doc__.split('\n\n')[0].split()))
    parser.add_argument('bag', type=Path, help='bag with /landmarks and /observations (MCAP)')
    algorithms = BY_NAME['algorithm'].choices
    parser.add_argument('--algorithm', required=True, choices=algorithms, metavar='NAME',
                        help='association_node algorithm: ' + ', '.join(algorithms))
    parser.add_argument('--out', type=Path, required=True,
                        help='output bag directory (must not exist, unless --force)')
    parser.add_argument('--force', action='store_true',
                        help='replace OUT when it exists (only a bag directory is replaced)')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='playback rate factor (0: as fast as the answers allow)')
    parser.add_argument('-p', dest='parameters', action='append', default=[],
                        metavar='NAME:=VALUE', help='node parameter (repeatable)')
    parser.add_argument('--kill-node-after', type=int, metavar='N',
                        help='fault injection: kill the node after N observation messages and '
                             'start a new one; the gap is reported')
    args = parser.parse_args(argv)
    try:
        check_out(args.out, args.force)
        parameters = {**bag_parameters(args.bag), **parse_assignments(args.parameters)}
        node_config(args.algorithm, parameters)   # the combination, before starting anything
        result = replay(args.bag, args.algorithm, parameters, args.rate,
                        restart_after=args.kill_node_after)
    except (BagError, ValueError) as error:
        print(f'da_bag_replay: {error}', file=sys.stderr)
        return 2
    if args.out.exists():
        shutil.rmtree(args.out)
    write_recording(args.out, result, recording_custom_data(args.bag, args.algorithm,
                                                            parameters))
    print(f'{args.out}: {result.sent} observation messages sent, {result.answered} answered')
    gaps = result.gaps()
    if gaps:
        print('unanswered observation messages (0-based, in sending order): ' + ', '.join(
            f'{a}' if a == b else f'{a}-{b}' for a, b in gaps))
    if not result.node_alive:
        print(f'da_bag_replay: association_node died:\n{result.node_log[-2000:]}', file=sys.stderr)
        return 1
    if result.restarted_after is not None:
        sent_ns = [ns for t, _, ns in result.recorded if t == topics.OBSERVATIONS]
        print(f'node killed and restarted after message {result.restarted_after} (at '
              f'{sent_ns[result.restarted_after - 1] / 1e9:.3f} s; the last message sent at '
              f'{sent_ns[-1] / 1e9:.3f} s, system clock as in the node log)')
        # the restarted node must answer again: nothing unanswered after the first gap
        if len(gaps) <= 1 and (not gaps or gaps[0][1] < result.sent - 1):
            return 0
        print(f'da_bag_replay: the restarted node did not answer again; node log (both '
              f'nodes):\n{result.node_log[-3000:]}', file=sys.stderr)
        return 1
    if result.answered < result.sent:
        print(f'da_bag_replay: {result.sent - result.answered} answers missing; node log:\n'
              f'{result.node_log[-2000:]}', file=sys.stderr)
        return 1
    return 0


def check_out(out: Path, force: bool) -> None:
    """BagError unless `out` is free, or (with `force`) a bag directory that may be replaced."""
    if not out.exists():
        return
    if not force:
        raise BagError(f'{out} exists; choose another --out or add --force to replace it')
    if not out.is_dir() or not ((out / 'metadata.yaml').is_file() or any(out.glob('*.mcap'))):
        raise BagError(f'{out} exists and is not a bag directory: not replaced, even with '
                       '--force')


def bag_parameters(bag: Path) -> dict[str, Any]:
    """Node parameters a bag asks for in its metadata custom_data ({} if none)."""
    import json

    from .make_bags import PARAMETERS_KEY
    from .rosbag2_metadata import read_custom_data
    return json.loads(read_custom_data(bag).get(PARAMETERS_KEY, '{}'))


if __name__ == '__main__':
    sys.exit(main())
