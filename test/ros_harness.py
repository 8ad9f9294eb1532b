"""A real rclpy graph for the tests: the node under test plus a test node that publishes inputs
and collects outputs over real topics, spun by one executor in this process."""
from __future__ import annotations

import struct
import time
from typing import Callable, Optional

import numpy as np
import rclpy
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

from msg_adapters import array_to_cloud, cloud_to_array

RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)


def header(seconds: float, frame: str = 'map') -> Header:
    whole = int(seconds)
    h = Header(frame_id=frame)
    h.stamp.sec = whole
    h.stamp.nanosec = int(round((seconds - whole) * 1e9))
    return h


def cloud(fields: dict, stamp: float, frame: str = 'map', dtype: str = '<f4') -> PointCloud2:
    """PointCloud2 from name -> values; `id` becomes INT32, everything else `dtype`."""
    n = len(next(iter(fields.values()))) if fields else 0
    array = np.zeros(n, dtype=[(k, '<i4' if k == 'id' else dtype) for k in fields])
    for k, v in fields.items():
        array[k] = v
    return array_to_cloud(array, header(stamp, frame))


def odometry(x: float, y: float, yaw: float, covariance_xyyaw, stamp: float) -> Odometry:
    msg = Odometry(header=header(stamp))
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(x), float(y)
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = np.sin(yaw / 2), np.cos(yaw / 2)
    full = np.zeros((6, 6))
    full[np.ix_([0, 1, 5], [0, 1, 5])] = covariance_xyyaw
    msg.pose.covariance = full.ravel().tolist()
    return msg


def cdr(msg: PointCloud2, order: str) -> bytes:
    """`msg` in classic CDR with byte order `order` ('<' or '>'), written field by field from
    the IDL of sensor_msgs/PointCloud2 (padding zero), independently of the module."""
    out = bytearray(b'\x00\x01\x00\x00' if order == '<' else b'\x00\x00\x00\x00')

    def align(size):
        out.extend(b'\x00' * (-(len(out) - 4) % size))

    def put(fmt, *values):
        align(struct.calcsize(fmt))
        out.extend(struct.pack(order + fmt, *values))

    def string(text):
        encoded = text.encode() + b'\x00'
        put('I', len(encoded))
        out.extend(encoded)

    put('i', msg.header.stamp.sec)
    put('I', msg.header.stamp.nanosec)
    string(msg.header.frame_id)
    put('I', msg.height)
    put('I', msg.width)
    put('I', len(msg.fields))
    for field in msg.fields:
        string(field.name)
        put('I', field.offset)
        put('B', field.datatype)
        put('I', field.count)
    put('B', msg.is_bigendian)
    put('I', msg.point_step)
    put('I', msg.row_step)
    put('I', len(msg.data))
    out.extend(bytes(msg.data))
    put('B', msg.is_dense)
    return bytes(out)


class Graph:
    """Owns a context, an executor, the node(s) under test and a test node with publishers to
    landmarks/observations/robot_pose/state_covariance and subscriptions to the outputs.
    close() destroys the nodes added to it: a node made in its context and not added outlives
    it, and so do its DDS participant and endpoints, seen by later tests until it is
    garbage-collected."""

    def __init__(self, namespace: str = '') -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.tester = rclpy.create_node('tester', namespace=namespace, context=self.context)
        self.executor.add_node(self.tester)
        self.publishers = {}
        self.received: dict[str, list] = {}

    def add(self, node) -> None:
        self.executor.add_node(node)

    def publisher(self, msg_type, topic: str):
        if topic not in self.publishers:
            self.publishers[topic] = self.tester.create_publisher(msg_type, topic, RELIABLE)
        return self.publishers[topic]

    def collect(self, msg_type, topic: str) -> list:
        if topic not in self.received:
            self.received[topic] = []
            self.tester.create_subscription(msg_type, topic, self.received[topic].append,
                                            RELIABLE)
        return self.received[topic]

    def spin_until(self, condition: Callable[[], bool], timeout: float = 5.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if condition():
                return True
            self.executor.spin_once(timeout_sec=0.02)
        return condition()

    def wait_for_subscribers(self, topics, timeout: float = 5.0) -> None:
        assert self.spin_until(lambda: all(self.publishers[t].get_subscription_count() > 0
                                           for t in topics), timeout), 'no subscriber matched'

    def close(self) -> None:
        for node in list(self.executor.get_nodes()):
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()
        rclpy.shutdown(context=self.context)


def correspondences(msg: PointCloud2) -> np.ndarray:
    return cloud_to_array(msg)


def wait_reply(graph: Graph, topic: str, count: int, timeout: float = 5.0) -> Optional[list]:
    """Spin until `count` messages arrived on `topic`; the list of them, or fail."""
    messages = graph.received[topic]
    assert graph.spin_until(lambda: len(messages) >= count, timeout), \
        f'{topic}: {len(messages)} of {count} messages after {timeout} s'
    return messages
