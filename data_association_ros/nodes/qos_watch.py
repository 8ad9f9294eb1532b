"""Endpoints on the node's topics whose QoS or type cannot match its own, found from the ROS
graph on a timer (in place of rclpy's default event handlers).

rclpy gives every publisher and subscription two event handlers that only log (incompatible
QoS, incompatible type).  The executor checks each of them, in Python, whenever it wakes up:
association_node's 28 cost about 0.1 ms of every scan's round trip (docs/benchmarks.md).  The
nodes therefore create their endpoints without them (ParameterizedNode), and QosWatch.check,
called every QOS_CHECK_PERIOD, warns instead: each topic's endpoint count is read (a cheap call)
and, where it changed (and every FULL_CHECK_EVERY looks), the endpoints are listed and checked
with rclpy.qos.qos_check_compatible and by type name.  Each incompatible endpoint is reported
once; one whose node is not discovered yet is looked at again the next time (for up
to UNKNOWN_NODE_WAIT seconds, then it is checked without its node's name).
"""
from __future__ import annotations

import copy
import time
from typing import Callable

from rclpy.duration import Infinite
from rclpy.node import Node
from rclpy.qos import (DurabilityPolicy, LivelinessPolicy, QoSCompatibility, QoSProfile,
                       ReliabilityPolicy, qos_check_compatible)

QOS_CHECK_PERIOD = 2.0
"""Seconds between two looks at the graph."""
FULL_CHECK_EVERY = 5
"""Every this many looks, every topic's endpoints are listed, whatever their counts: an
endpoint replaced by another between two looks leaves the count as it was."""
UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'
"""The node name the graph gives an endpoint whose node it has not discovered yet."""
UNKNOWN_NODE_WAIT = 10.0
"""Seconds an endpoint whose node is unknown waits for it: then it is checked without its node's
name (a DDS application that is no ROS node never gets one)."""


def as_discovered(profile: QoSProfile, publisher: bool) -> QoSProfile:
    """`profile` (one of ours) as the graph reports an endpoint's, so qos_check_compatible
    compares what DDS applies: the durations left at 0 (the default: none) are Infinite there
    (0 is not a deadline), and each SYSTEM_DEFAULT policy is what Fast DDS applies (a writer:
    reliable, transient local; a reader: best effort, volatile; both: liveliness automatic);
    else a MANUAL_BY_TOPIC subscriber of an automatic publisher, which receives nothing, would
    be only a "may be incompatible" warning."""
    discovered = copy.copy(profile)
    for name in ('deadline', 'lifespan', 'liveliness_lease_duration'):
        if getattr(discovered, name).nanoseconds == 0:
            setattr(discovered, name, Infinite)
    if discovered.liveliness == LivelinessPolicy.SYSTEM_DEFAULT:
        discovered.liveliness = LivelinessPolicy.AUTOMATIC
    if discovered.durability == DurabilityPolicy.SYSTEM_DEFAULT:
        discovered.durability = (DurabilityPolicy.TRANSIENT_LOCAL if publisher
                                 else DurabilityPolicy.VOLATILE)
    if discovered.reliability == ReliabilityPolicy.SYSTEM_DEFAULT:
        discovered.reliability = (ReliabilityPolicy.RELIABLE if publisher
                                  else ReliabilityPolicy.BEST_EFFORT)
    return discovered


def compatibility(publisher: QoSProfile, subscription: QoSProfile) -> tuple[bool, str]:
    """(whether DDS refuses the match, rclpy's reason).  qos_check_compatible, plus the one
    case it only calls a "may be": the graph reports a MANUAL_BY_PARTICIPANT subscription's
    liveliness as UNKNOWN, and an automatic publisher cannot serve it (DDS orders the kinds
    automatic < manual by participant < manual by topic)."""
    verdict, reason = qos_check_compatible(publisher, subscription)
    if verdict == QoSCompatibility.ERROR:
        return True, reason
    if (subscription.liveliness == LivelinessPolicy.UNKNOWN
            and publisher.liveliness == LivelinessPolicy.AUTOMATIC):
        return True, ("ERROR: Publisher's liveliness is automatic and subscription's is "
                      "unknown (manual by participant, which only a manual publisher serves);")
    return False, reason


def type_name(msg_type) -> str:
    """'package/msg/Name' of a message class, as the graph names topic types."""
    return f'{msg_type.__module__.split(".")[0]}/msg/{msg_type.__name__}'


class QosWatch:
    """Checks `node`'s publishers and subscriptions against the other endpoints on their topics;
    `warn(text)` once per incompatible endpoint (by its gid) and problem."""

    def __init__(self, node: Node, warn: Callable[[str], None]) -> None:
        self.node = node
        self.warn = warn
        self._counts: dict[tuple[str, str], int] = {}
        self._looks = 0
        self._reported: set[tuple[str, bytes, str]] = set()   # (topic, gid, 'qos' / 'type')
        self._unnamed: dict[tuple[str, bytes], float] = {}  # (topic, gid): first seen nameless

    def check(self) -> list[str]:
        """Look at the topics whose endpoint counts changed (every topic every
        FULL_CHECK_EVERY looks); warn about (and return) the incompatibilities not reported
        before.  A full look also forgets the endpoints no longer in the graph."""
        node = self.node
        self._looks += 1
        full = self._looks % FULL_CHECK_EVERY == 0
        if full:
            self._counts.clear()
        listed: set[tuple[str, bytes]] = set()   # (topic, gid) of the endpoints listed
        now = time.monotonic()
        found = []
        for subscription in node.subscriptions:
            found += self._check_topic(
                listed, now, 'publishers', subscription.topic_name, node.count_publishers,
                node.get_publishers_info_by_topic,
                lambda info, own=subscription: self._compare(
                    info, own.topic_name, own.msg_type, info.qos_profile,
                    as_discovered(own.qos_profile, publisher=False), 'publisher', 'offering',
                    'received from'))
        for publisher in node.publishers:
            found += self._check_topic(
                listed, now, 'subscriptions', publisher.topic_name, node.count_subscribers,
                node.get_subscriptions_info_by_topic,
                lambda info, own=publisher: self._compare(
                    info, own.topic_name, own.msg_type,
                    as_discovered(own.qos_profile, publisher=True), info.qos_profile,
                    'subscription', 'requesting', 'sent to'))
        if full:
            self._reported = {key for key in self._reported if key[:2] in listed}
            self._unnamed = {key: t for key, t in self._unnamed.items() if key in listed}
        for text in found:
            self.warn(text)
        return found

    def _check_topic(self, listed: set, now: float, kind: str, topic: str, count, endpoints,
                     compare) -> list[str]:
        """The new problems with the `kind` endpoints on `topic` when their count changed
        (each endpoint listed is added to `listed`); an endpoint whose node is not discovered
        yet is looked at again next time (for up to UNKNOWN_NODE_WAIT s after `now` first saw
        it)."""
        number = count(topic)
        if self._counts.get((kind, topic)) == number:
            return []
        self._counts[(kind, topic)] = number
        found = []
        for info in endpoints(topic):
            key = (topic, bytes(info.endpoint_gid))
            listed.add(key)
            if info.node_name == UNKNOWN_NODE:
                if now - self._unnamed.setdefault(key, now) < UNKNOWN_NODE_WAIT:
                    self._counts.pop((kind, topic), None)
                    continue
            found += compare(info)
        return found

    def _compare(self, info, topic: str, own_type, publisher_qos, subscription_qos, other: str,
                 verb: str, direction: str) -> list[str]:
        """The new problems between one of ours and the endpoint `info` (rclpy's wording)."""
        node = ('unknown' if info.node_name == UNKNOWN_NODE else
                f"{info.node_namespace.rstrip('/')}/{info.node_name}")
        where = f"on topic '{topic}' (node {node})"
        if info.topic_type != type_name(own_type):
            problem = 'type', (f'Incompatible type {where}: {info.topic_type}, not '
                               f'{type_name(own_type)}; no messages will be {direction} it.')
        else:
            refused, reason = compatibility(publisher_qos, subscription_qos)
            if not refused:
                return []
            problem = 'qos', (f'New {other} discovered {where}, {verb} incompatible QoS. '
                              f'No messages will be {direction} it. {reason}')
        key = (topic, bytes(info.endpoint_gid), problem[0])
        if key in self._reported:
            return []
        self._reported.add(key)
        return [problem[1]]
