"""Ctrl-C to two nodes at once, many times: how often a stop outlives TEARDOWN_S.

Each cycle starts association_node and ekf_slam_node (the pair of slam.launch.py), waits for
both to say "ready" and for --hold seconds, sends SIGINT to both and a second SIGINT a random
0-`--gap` s later (as `ros2 launch` forwards Ctrl-C after the terminal's), and records each
node's exit code and how long it took.  Fast DDS 2.14 deadlocks now and then deleting the
participant while the other node leaves (docs/robustness.md, "Ctrl-C"); the node's teardown
watchdog then ends it after TEARDOWN_S with exit code 1 and its stacks.  A node still running
TEARDOWN_S + 5 s after the SIGINT is counted as hung, reported with its log, and killed.

    python benchmarks/stop_race.py [--cycles 300] [--gap 0.3] [--hold 1.0]

Runs on loopback DDS with a domain id of its own; the nodes run the numpy code (no numba
compilation per process).  About 4 s per cycle on 2 cores.
"""
from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from data_association_ros.nodes.parameterized_node import TEARDOWN_S  # noqa: E402

NODES = {'association_node': ['-p', 'algorithm:=gnn'],
         'ekf_slam_node': ['-p', 'association_source:=ground_truth']}
READY_S = 60.0


def start(name: str, arguments: list[str], log: Path, env: dict) -> subprocess.Popen:
    """The node `name` as `python -m data_association_ros.nodes.<name>`, output to `log`."""
    with open(log, 'wb') as out:
        return subprocess.Popen(
            [sys.executable, '-m', f'data_association_ros.nodes.{name}', '--ros-args',
             *arguments], stdout=out, stderr=subprocess.STDOUT, env=env, cwd=REPO)


def cycle(folder: Path, env: dict, gap_s: float, hold_s: float) -> list[tuple[str, str, float]]:
    """One start-and-SIGINT of both nodes: (node, outcome, seconds from the first SIGINT to its
    end) per node; outcome is 'exit 0', 'exit N' or 'hung' (killed)."""
    logs = {name: folder / f'{name}.log' for name in NODES}
    processes = {name: start(name, arguments, logs[name], env)
                 for name, arguments in NODES.items()}
    deadline = time.monotonic() + READY_S
    while time.monotonic() < deadline and not all(
            f'{name} ready' in logs[name].read_text(errors='replace') for name in NODES):
        time.sleep(0.05)
    time.sleep(hold_s)
    sent = time.monotonic()
    for process in processes.values():
        process.send_signal(signal.SIGINT)
    second = sent + random.uniform(0.0, gap_s)
    ended: dict[str, float] = {}
    while len(ended) < len(processes) and time.monotonic() - sent < TEARDOWN_S + 5.0:
        for name, process in processes.items():
            if name not in ended and process.poll() is not None:
                ended[name] = time.monotonic() - sent
        if second is not None and time.monotonic() >= second:
            for name, process in processes.items():
                if name not in ended:
                    process.send_signal(signal.SIGINT)
            second = None
        time.sleep(0.01)
    results = []
    for name, process in processes.items():
        if process.poll() is None:
            process.kill()
            process.wait()
            results.append((name, 'hung', float('nan')))
        else:
            results.append((name, f'exit {process.returncode}', ended[name]))
        if results[-1][1] != 'exit 0':
            print(f'--- {name}: {results[-1][1]}\n{logs[name].read_text(errors="replace")}',
                  flush=True)
    return results


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cycles', type=int, default=300)
    parser.add_argument('--gap', type=float, default=0.3,
                        help='the second SIGINT comes 0-GAP s after the first [s]')
    parser.add_argument('--hold', type=float, default=1.0,
                        help='how long both nodes run before the SIGINT [s]')
    args = parser.parse_args(argv)
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               DATA_ASSOCIATION_ROS_NO_JIT='1',
               ROS_DOMAIN_ID=os.environ.get('ROS_DOMAIN_ID', str(random.randint(20, 90))))
    outcomes: Counter = Counter()
    seconds: list[float] = []
    with tempfile.TemporaryDirectory() as folder:
        for index in range(args.cycles):
            for name, outcome, took in cycle(Path(folder), env, args.gap, args.hold):
                outcomes[outcome] += 1
                if outcome == 'exit 0':
                    seconds.append(took)
            if (index + 1) % 25 == 0:
                print(f'{index + 1} cycles: {dict(outcomes)}', flush=True)
    print(f'{args.cycles} cycles, {2 * args.cycles} node stops (second SIGINT 0-{args.gap} s '
          f'later): {dict(outcomes)}')
    if seconds:
        print(f'clean stops: median {np.median(seconds):.2f} s, p99 '
              f'{np.percentile(seconds, 99):.2f} s, max {max(seconds):.2f} s '
              f'(TEARDOWN_S {TEARDOWN_S} s)')


if __name__ == '__main__':
    main()
