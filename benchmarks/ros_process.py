"""A server node in its own process for the DDS benchmarks: waiting for it, stopping it."""
from __future__ import annotations

import signal
import subprocess
import time


def wait_until_matched(executor, node, publisher, reply_topic: str,
                       timeout_s: float = 30.0) -> None:
    """Spin until the server subscribes to `publisher` and publishes `reply_topic`."""
    deadline = time.monotonic() + timeout_s
    while (publisher.get_subscription_count() == 0
           or node.count_publishers(reply_topic) == 0) and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)


def close(executor, node, process: subprocess.Popen) -> None:
    """Remove the client node and stop the server (SIGINT, then kill after 10 s)."""
    executor.remove_node(node)
    node.destroy_node()
    stop(process)


def stop(process: subprocess.Popen) -> None:
    """Stop a server process: SIGINT, then kill after 10 s."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
