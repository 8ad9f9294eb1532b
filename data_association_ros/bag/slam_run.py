"""A SLAM bag through the node pair (association_node + ekf_slam_node), offline or live.

Offline: the two nodes' pipelines (AssociationPipeline, SlamPipeline) in this process, each
output handed to the other as the nodes' topics would (no DDS; for the score table).
Live: both nodes as processes on a loopback DDS graph of their own; the scans are sent in
lockstep (the next scan once `slam_pose` of the previous one arrived, or after a timeout),
the answers recorded with their latency (answer arrival - scan send, wall clock).
Both give a SlamRun.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import numpy as np

from msg_adapters import cloud_to_array, pose_from_odometry

from ..pipelines.association import AssociationPipeline, stamp_ns
from ..pipelines.slam import SLAM_BY_NAME, SLAM_PARAMETERS, SlamPipeline
from . import topics
from .datasets.slam_bags import SLAM_PARAMETERS_KEY
from .offline import node_config
from .reader import BagError, BagReader

RUN_TOPICS = (topics.ODOMETRY, topics.SENSOR_OBSERVATIONS, topics.GROUND_TRUTH)
MODES = ('ground_truth', 'node')
WAIT_FOR_NODES_S = 30.0
STEP_TIMEOUT_S = 5.0
DRAIN_S = 0.3


@dataclass
class SlamRun:
    """What one run produced: per scan stamp the association answer (K,) and its time [ms]
    (offline: the association pipeline's compute time; live: latency), the posterior pose, and
    the final slam_map points (id, x, y, cov_*, origin_*); the posterior pose covariance (3, 3)
    per scan and, offline only, the joint NIS and its degrees of freedom of each EKF update;
    origins: landmark id -> (origin stamp, observation) of every landmark the filter ever had,
    also those merged or dropped before the end (scoring needs their identity)."""

    answers: dict[int, np.ndarray] = field(default_factory=dict)
    times_ms: dict[int, float] = field(default_factory=dict)
    poses: dict[int, np.ndarray] = field(default_factory=dict)
    pose_covariances: dict[int, np.ndarray] = field(default_factory=dict)
    update_nis: dict[int, tuple[float, int]] = field(default_factory=dict)
    origins: dict[int, tuple[int, int]] = field(default_factory=dict)
    final_map: Optional[np.ndarray] = None
    scans_sent: int = 0
    nodes_alive: bool = True
    log: str = ''


def slam_config(mode: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """ekf_slam_node parameter values: defaults, then `overrides`, with association_source."""
    config = {p.name: p.default for p in SLAM_PARAMETERS}
    for name, value in {**overrides, 'association_source': mode}.items():
        config[name] = SLAM_BY_NAME[name].check(value)
    return config


def bag_slam_parameters(bag: Path) -> dict[str, Any]:
    """The ekf_slam_node parameters a bag's metadata asks for (initial pose)."""
    from .rosbag2_metadata import read_custom_data
    return json.loads(read_custom_data(bag).get(SLAM_PARAMETERS_KEY, '{}'))


def read_inputs(bag: Path, steps: Optional[int] = None) -> list[tuple[str, Any]]:
    """(topic, message) of the bag's odometry, scans and truth, cut after `steps` scans."""
    reader = BagReader(bag)
    reader.require([topics.ODOMETRY, topics.SENSOR_OBSERVATIONS])
    out, scans = [], 0
    for message in reader.messages([t for t in RUN_TOPICS if t in reader.topics]):
        if message.topic == topics.SENSOR_OBSERVATIONS:
            scans += 1
            if steps is not None and scans > steps:
                break
        out.append((message.topic, message.msg))
    return out


def run_offline(messages: list[tuple[str, Any]], algorithm: str, mode: str,
                association_parameters: dict[str, Any],
                slam_parameters: dict[str, Any]) -> SlamRun:
    """The node pair's pipelines in this process (see the module doc)."""
    association = AssociationPipeline(node_config(algorithm, association_parameters))
    slam = SlamPipeline(slam_config(mode, slam_parameters))
    run = SlamRun()
    to_association = {'landmarks': association.on_landmarks,
                      'robot_pose': association.on_robot_pose,
                      'state_covariance': association.on_state_covariance}

    def deliver(outputs):
        for topic, msg in outputs:
            if topic in to_association:
                to_association[topic](msg)
            elif topic == 'observations':
                started = time.perf_counter()
                answer = association.answer(msg)
                stamp = stamp_ns(msg.header)
                run.times_ms[stamp] = (time.perf_counter() - started) * 1e3
                if answer is None:
                    continue
                run.answers[stamp] = answer.association.assignment
                if answer.new_landmarks is not None:
                    deliver(slam.on_new_landmarks(answer.new_landmarks))
                deliver(slam.on_correspondences(answer.correspondences))
            elif topic == 'slam_pose':
                _record_pose(run, msg)
            elif topic == 'slam_map':
                run.final_map = msg

    handlers = {topics.ODOMETRY: slam.on_odometry, topics.SENSOR_OBSERVATIONS: slam.on_scan,
                topics.GROUND_TRUTH: slam.on_ground_truth}
    for topic, msg in messages:
        run.scans_sent += topic == topics.SENSOR_OBSERVATIONS
        deliver(handlers[topic](msg))
        if slam.last_update is not None:
            stamp, nis, dof = slam.last_update
            run.update_nis[stamp] = (nis, dof)
            slam.last_update = None
    run.final_map = None if run.final_map is None else cloud_to_array(run.final_map)
    run.origins = dict(slam.origins)
    return run


def _pose_of(msg) -> np.ndarray:
    return pose_from_odometry(msg).mean


def _record_pose(run: SlamRun, msg) -> None:
    """The posterior pose of a slam_pose message and its covariance, by stamp."""
    pose = pose_from_odometry(msg)
    stamp = stamp_ns(msg.header)
    run.poses[stamp] = pose.mean
    run.pose_covariances[stamp] = pose.covariance


def run_live(messages: list[tuple[str, Any]], algorithm: str, mode: str,
             association_parameters: dict[str, Any],
             slam_parameters: dict[str, Any]) -> SlamRun:
    """Both nodes as processes, scans in lockstep (see the module doc)."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from .parameter_arguments import ros_arguments
    from .ros_environment import (association_node_command, close_graph, open_graph,
                                  stop_processes)

    from .message_types import message_class
    slam_values = slam_config(mode, slam_parameters)
    node_config(algorithm, association_parameters)  # checked before anything starts
    log = tempfile.TemporaryFile()
    commands = [
        association_node_command(algorithm, association_parameters),
        [sys.executable, '-m', 'data_association_ros.nodes.ekf_slam_node', '--ros-args',
         *ros_arguments(slam_values, SLAM_BY_NAME)]]
    processes = [subprocess.Popen(c, stdout=log, stderr=subprocess.STDOUT) for c in commands]
    context, node, executor = open_graph('da_slam_run')
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    run = SlamRun()
    sent_at: dict[int, float] = {}
    done: set[int] = set()
    timed_out: set[int] = set()
    final_map = [None]

    def on_answer(msg):
        stamp = stamp_ns(msg.header)
        if stamp in timed_out:   # too late: the filter never used it
            return
        run.answers[stamp] = cloud_to_array(msg)['landmark'].astype(np.int64)
        if stamp in sent_at:
            run.times_ms[stamp] = (time.monotonic() - sent_at[stamp]) * 1e3

    def on_pose(msg):
        _record_pose(run, msg)
        done.add(stamp_ns(msg.header))

    types = {t: message_class(name) for t, name in (
        (topics.ODOMETRY, 'nav_msgs/msg/Odometry'),
        (topics.SENSOR_OBSERVATIONS, 'sensor_msgs/msg/PointCloud2'),
        (topics.GROUND_TRUTH, 'sensor_msgs/msg/PointCloud2'))}
    publishers = {t: node.create_publisher(kind, t, qos) for t, kind in types.items()}
    cloud = types[topics.GROUND_TRUTH]
    node.create_subscription(cloud, topics.CORRESPONDENCES, on_answer, qos)
    # the map before the pose: the ekf_slam_node publishes them in this order
    def on_map(msg):
        final_map[0] = msg
        points = cloud_to_array(msg)
        for landmark, sec, nanosec, observation in zip(
                points['id'].tolist(), points['origin_stamp_sec'].tolist(),
                points['origin_stamp_nanosec'].tolist(), points['origin_observation'].tolist()):
            run.origins.setdefault(landmark, (sec * 1_000_000_000 + nanosec, observation))

    node.create_subscription(cloud, topics.SLAM_MAP, on_map, qos)
    node.create_subscription(message_class('nav_msgs/msg/Odometry'), topics.SLAM_POSE, on_pose,
                             qos)

    def alive():
        return all(p.poll() is None for p in processes)
    try:
        deadline = time.monotonic() + WAIT_FOR_NODES_S
        while not (all(p.get_subscription_count() > 0 for p in publishers.values())
                   and node.count_publishers(topics.CORRESPONDENCES) > 0
                   and node.count_publishers(topics.SLAM_POSE) > 0
                   and all(node.count_subscribers(t) > 0 and node.count_publishers(t) > 0
                           for t in (topics.OBSERVATIONS, topics.LANDMARKS,
                                     topics.ROBOT_POSE, topics.STATE_COVARIANCE))):
            if not alive() or time.monotonic() > deadline:
                raise BagError('association_node / ekf_slam_node did not come up')
            executor.spin_once(timeout_sec=0.05)
        # the nodes' endpoints are discovered, but whether association_node's subscriptions have
        # matched ekf_slam_node's publishers is not visible from here; association_node comes
        # up last (numba import, start-up warm-up), so give the matching time
        settle = time.monotonic() + 3.0
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.05)
        for topic, msg in messages:
            if topic == topics.GROUND_TRUTH and mode != 'ground_truth':
                continue
            if topic == topics.SENSOR_OBSERVATIONS:
                sent_at[stamp_ns(msg.header)] = time.monotonic()
                run.scans_sent += 1
            publishers[topic].publish(msg)
            if topic == (topics.GROUND_TRUTH if mode == 'ground_truth'
                         else topics.SENSOR_OBSERVATIONS):
                stamp = stamp_ns(msg.header)   # the scan this message completes
                step_deadline = time.monotonic() + STEP_TIMEOUT_S
                while not (stamp in done and stamp in run.answers) and alive() and \
                        time.monotonic() < step_deadline:
                    executor.spin_once(timeout_sec=0.01)
                if stamp not in done:
                    timed_out.add(stamp)
                    run.answers.pop(stamp, None)
            if not alive():
                break
        drain = time.monotonic() + DRAIN_S   # a map republished after late new landmarks
        while time.monotonic() < drain and alive():
            executor.spin_once(timeout_sec=0.01)
    finally:
        run.nodes_alive = alive()
        close_graph(context, node, executor)
        run.log = stop_processes(processes, log)
    run.final_map = None if final_map[0] is None else cloud_to_array(final_map[0])
    return run
