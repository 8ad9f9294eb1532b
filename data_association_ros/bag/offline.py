"""Offline runs: bag messages through AssociationPipeline, the node's own code, without DDS."""
from __future__ import annotations

from typing import Any, Iterable, Mapping

import numpy as np

from msg_adapters import cloud_to_array

from ..core import InvalidInputError
from ..pipelines.parameters import BY_NAME, NODE_PARAMETERS, check_combination
from ..pipelines.association import AssociationPipeline, stamp_ns
from . import topics


def node_config(algorithm: str, overrides: Mapping[str, Any] = ()) -> dict[str, Any]:
    """The node's parameter values: defaults, then `overrides`, then `algorithm` (all checked)."""
    config = {p.name: p.default for p in NODE_PARAMETERS}
    for name, value in {**dict(overrides), 'algorithm': algorithm}.items():
        if name not in BY_NAME:
            raise InvalidInputError(f'{name}: not a parameter of association_node')
        config[name] = BY_NAME[name].check(value)
    check_combination(config)
    return config


def run_offline(messages: Iterable[tuple[str, Any]], config: dict[str, Any]) -> dict[int, Any]:
    """Feed (topic, message) pairs in order to a pipeline; {observation stamp ns: assignment}."""
    return {stamp: answer.association.assignment
            for stamp, answer in offline_answers(messages, config).items()}


def offline_answers(messages: Iterable[tuple[str, Any]],
                    config: dict[str, Any]) -> dict[int, Any]:
    """Feed (topic, message) pairs in order to a pipeline; {observation stamp ns: Answer}."""
    pipeline = AssociationPipeline(config)
    handlers = {topics.LANDMARKS: pipeline.on_landmarks, topics.ROBOT_POSE: pipeline.on_robot_pose,
                topics.ODOMETRY: pipeline.on_odometry,
                topics.STATE_COVARIANCE: pipeline.on_state_covariance}
    answers: dict[int, Any] = {}
    for topic, msg in messages:
        if topic == topics.OBSERVATIONS:
            answer = pipeline.answer(msg)
            if answer is not None:
                answers[stamp_ns(msg.header)] = answer
        elif topic in handlers:
            handlers[topic](msg)
    return answers


def truth_by_stamp(messages: Iterable[tuple[str, Any]]) -> dict[int, np.ndarray]:
    """{observation stamp ns: true assignment} from /ground_truth/correspondences messages."""
    return {stamp_ns(msg.header): cloud_to_array(msg)['landmark'].astype(np.int64)
            for topic, msg in messages if topic == topics.GROUND_TRUTH}


def truth_positions_by_stamp(messages: Iterable[tuple[str, Any]]) -> dict[int, np.ndarray]:
    """{observation stamp ns: true x, y (K, 2) of what each observation saw}."""
    out = {}
    for topic, msg in messages:
        if topic == topics.GROUND_TRUTH:
            points = cloud_to_array(msg)
            out[stamp_ns(msg.header)] = np.column_stack([points['x'], points['y']])
    return out
