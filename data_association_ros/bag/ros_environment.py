"""The little ROS graph of the bag tools that start nodes of their own: DDS kept on loopback
(DESIGN.md 6), the tool's own node and executor, the node processes and their shutdown."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
from typing import Any, Mapping

STOP_TIMEOUT_S = 10.0


def use_loopback_dds() -> str:
    """Set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and, unless set, a ROS_DOMAIN_ID of this run's
    own (10-99); call before rclpy.init. Returns the domain id."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.Random(os.getpid()).randint(10, 99)))
    return os.environ['ROS_DOMAIN_ID']


def association_node_command(algorithm: str, parameters: Mapping[str, Any]) -> list[str]:
    """The command line of an association_node process with `parameters` and a deep input
    queue (the tools publish faster than a live sensor)."""
    from .parameter_arguments import ros_arguments
    return [sys.executable, '-m', 'data_association_ros.nodes.association_node', '--ros-args',
            '-p', f'algorithm:={algorithm}', *ros_arguments(parameters), '-p', 'qos_depth:=1000']


def open_graph(name: str):
    """(context, node, executor): a context of its own on loopback DDS with the tool's node."""
    use_loopback_dds()
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    return context, node, executor


def close_graph(context, node, executor) -> None:
    """Undo open_graph."""
    import rclpy
    executor.remove_node(node)
    node.destroy_node()
    executor.shutdown()
    rclpy.shutdown(context=context)


def stop_processes(processes: list[subprocess.Popen], log) -> str:
    """SIGINT the processes still running, kill those not gone within STOP_TIMEOUT_S; the text
    of their shared `log` file (closed)."""
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
    for process in processes:
        try:
            process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
    log.seek(0)
    text = log.read().decode(errors='replace')
    log.close()
    return text
