"""A Node whose parameters come from NodeParameter declarations: declared with descriptors,
validated in one callback (with a cross-parameter check), applied in another (DESIGN.md 4).

At start-up an invalid value of any parameter (out of range, wrong type, not one of the
choices, or in conflict with another) stops the node: one line naming the parameter, the value
and the valid values, exit code 1.  `--help` prints the node's usage without starting ROS."""
from __future__ import annotations

import faulthandler
import gc
import signal
import sys
from typing import Any, Callable, Optional, Sequence

import rclpy

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..core import InvalidInputError
from ..pipelines.parameters import NodeParameter
from .qos_watch import QOS_CHECK_PERIOD, QosWatch


def descriptor(parameter: NodeParameter) -> ParameterDescriptor:
    """ParameterDescriptor with the description, valid values, range and read-only flag."""
    spec = parameter.spec
    result = ParameterDescriptor(
        name=parameter.name, read_only=parameter.read_only,
        description=f'{parameter.description} (valid: {parameter.range_text()})')
    if spec is not None and spec.low is not None and spec.high is not None:
        if spec.kind is float:
            result.floating_point_range = [FloatingPointRange(
                from_value=float(spec.low), to_value=float(spec.high), step=0.0)]
        elif spec.kind is int:
            result.integer_range = [IntegerRange(from_value=int(spec.low),
                                                 to_value=int(spec.high), step=0)]
    return result


class StartupParameterError(Exception):
    """An invalid parameter given at start-up: the node does not start (one-line message)."""


def refusal(node: str, parameter: NodeParameter, value: Any) -> str:
    """One line: the node, the parameter, the value given, why it is refused, the valid values."""
    try:
        parameter.check(value)
        reason = f'expected a value of type {type(parameter.default).__name__}'
    except InvalidInputError as error:
        reason = str(error).removeprefix(f'{parameter.name}: ')
    valid = parameter.range_text()
    if valid not in reason:
        reason += f' (valid: {valid})'
    return f'{node}: invalid parameter {parameter.name}:={value!r}: {reason}; not started'


class ParameterizedNode(Node):
    """Declares `parameters`; `config` holds the values in force; `combination(config)` raises
    InvalidInputError when values valid one by one conflict; `on_change()` runs after a set.
    Publishers and subscriptions are made without rclpy's default event handlers; `qos_watch`
    reports incompatible QoS and types from the graph instead (qos_watch.py)."""

    def __init__(self, name: str, parameters: Sequence[NodeParameter],
                 combination: Callable[[dict], None] = lambda config: None, **kwargs) -> None:
        super().__init__(name, **kwargs)
        self._declared = {p.name: p for p in parameters}
        self._combination = combination
        self.config: dict[str, Any] = {}
        try:
            self._declare(parameters)
        except StartupParameterError:
            self.destroy_node()
            raise
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.qos_watch = QosWatch(self, self.get_logger().warning)
        self.qos_timer = self.create_timer(QOS_CHECK_PERIOD, self._check_qos)

    def _check_qos(self) -> None:
        """qos_watch.check, never fatal (it only informs)."""
        try:
            self.qos_watch.check()
        except Exception as error:  # e.g. the graph going away at shutdown
            self.get_logger().warning(f'QoS compatibility check failed: {error!r}',
                                      throttle_duration_sec=60.0)

    def create_publisher(self, *args, **kwargs):
        """Node.create_publisher without default event handlers (unless `event_callbacks`)."""
        kwargs.setdefault('event_callbacks', PublisherEventCallbacks(use_default_callbacks=False))
        return super().create_publisher(*args, **kwargs)

    def create_subscription(self, *args, **kwargs):
        """Node.create_subscription without default event handlers (unless `event_callbacks`)."""
        kwargs.setdefault('event_callbacks',
                          SubscriptionEventCallbacks(use_default_callbacks=False))
        return super().create_subscription(*args, **kwargs)

    def _declare(self, parameters: Sequence[NodeParameter]) -> None:
        """Declare and check every parameter; StartupParameterError at the first invalid one."""
        for parameter in parameters:
            try:
                self.declare_parameter(parameter.name, parameter.default, descriptor(parameter))
            except (InvalidParameterTypeException, InvalidParameterValueException):
                # rclpy keeps the refused override only in this attribute
                given = self._parameter_overrides[parameter.name].value
                raise StartupParameterError(refusal(self.get_name(), parameter, given)) from None
            value = self.get_parameter(parameter.name).value
            try:
                self.config[parameter.name] = parameter.check(value)
            except InvalidInputError:
                raise StartupParameterError(refusal(self.get_name(), parameter, value)) from None
        try:
            self._combination(self.config)
        except InvalidInputError as error:
            raise StartupParameterError(f'{self.get_name()}: invalid parameters: {error}; '
                                        'not started') from None

    def on_change(self) -> None:
        """Called after parameters were applied (override)."""

    def _validate_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        trial = dict(self.config)
        try:
            for parameter in parameters:
                known = self._declared.get(parameter.name)
                if known is not None:
                    trial[parameter.name] = known.check(parameter.value)
            self._combination(trial)
        except InvalidInputError as error:
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters: list[Parameter]) -> None:
        for parameter in parameters:
            known = self._declared.get(parameter.name)
            if known is None:
                continue
            old = self.config.get(parameter.name)
            self.config[parameter.name] = known.check(parameter.value)
            self.get_logger().info(f'{parameter.name}: {old!r} -> {self.config[parameter.name]!r}'
                                   ' (from the next message)')
        self.on_change()


def usage_text(node: str, doc: str, parameters: Sequence[NodeParameter], table: str) -> str:
    """The `--help` text: what the node does and its topics (`doc`), how to run it, and its
    parameters with defaults and valid values (the full table is in `table`)."""
    width = max(len(p.name) for p in parameters)
    rows = [f'  {p.name:<{width}}  {p.default!r:<14} valid: {p.range_text()}'
            + (' (read-only)' if p.read_only else '') for p in parameters]
    return '\n'.join([
        f'usage: ros2 run data_association_ros {node} [--ros-args -p NAME:=VALUE ...]', '',
        doc.strip(), '',
        f'Parameters (full table with meanings: {table}; at run time: '
        f'ros2 param describe /{node} NAME):', *rows])


INTERRUPTED: list = []
"""The SIGINTs received (_record_interrupts)."""


def _record_interrupts() -> None:
    """SIGINT only records itself: rclpy's own handler (installed by rclpy.init, which calls
    this one after it) shuts the context down, and the spin ends with ExternalShutdownException.
    Raising KeyboardInterrupt here (as before) let it land anywhere, also inside rclpy's Task
    constructor, whose half-built object then printed a traceback from its __del__; and Ctrl-C
    under `ros2 launch` reaches a node twice (from the terminal and forwarded by launch).  A
    SIGINT before rclpy.init is acted on once init is done (spin)."""
    signal.signal(signal.SIGINT, lambda signum, frame: INTERRUPTED.append(signum))


def freeze_start_up_objects() -> None:
    """Move everything allocated so far (modules, numba, scipy, the node: about 160,000 objects)
    out of the garbage collector's reach (gc.freeze): a full collection during operation then
    scans only what the node allocated since, instead of pausing the node for 50-150 ms."""
    gc.collect()
    gc.freeze()


def spin(node_class: Callable[[], Node], args: Optional[list[str]] = None,
         usage: str = '') -> None:
    """Entry point of an executable: `usage` for --help/-h (ROS not started); else init, spin
    `node_class()` until Ctrl-C or shutdown; exit 1 with one line on an invalid parameter."""
    args = args if args is not None else sys.argv
    own = args[:args.index('--ros-args')] if '--ros-args' in args else args
    if usage and ('--help' in own or '-h' in own):
        print(usage)
        return
    _record_interrupts()
    rclpy.init(args=args)
    if INTERRUPTED:  # Ctrl-C before rclpy's handler was there
        rclpy.shutdown()
        return
    try:
        node = node_class()
    except StartupParameterError as error:
        rclpy.shutdown()
        sys.exit(str(error))
    try:
        try:
            # the executor is made before "ready": a Ctrl-C right after it cannot interrupt the
            # executor's construction (whose __del__ would then print a traceback)
            executor = rclpy.executors.SingleThreadedExecutor(context=node.context)
            executor.add_node(node)
            freeze_start_up_objects()
            if getattr(node, 'ready_text', ''):   # after the freeze: a Ctrl-C right after
                node.get_logger().info(node.ready_text)   # "ready" no longer lands in gc
            executor.spin()
        except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
            pass
        except Exception:
            if rclpy.ok():
                raise
            # Ctrl-C: rclpy's handler shut the context down before spin was under way (its
            # executor cannot be made)
        finally:
            _stop(node)
    except KeyboardInterrupt:   # a KeyboardInterrupt raised by anything else while stopping
        _stop(node)


TEARDOWN_S = 3.0
"""Longest the stop may take from its start to the process's end (destroy_node, rclpy.shutdown
and the interpreter's exit; normally 0.1-0.3 s) before the process ends itself (_stop); under
ros2 launch, within the 5 s before launch's SIGTERM."""


def _stop(node: Node) -> None:
    """Ignore any further SIGINT (else the interpreter's exit restores the default action and a
    late second Ctrl-C ends the process by the signal, exit code -2), destroy the node once,
    shut rclpy down; a stop interrupted by a KeyboardInterrupt is begun again by the caller.

    A process not ended TEARDOWN_S after its stop began prints every thread's Python stack on
    stderr ('Timeout (0:00:03)!', faulthandler) and exits with code 1: faulthandler's watchdog
    is a thread of its own that runs while the stuck call holds the GIL; armed once (a stop
    begun again does not restart it).  Seen in 4 of 1,277 stops of two nodes at once (as under
    ros2 launch; benchmarks/stop_race.py): Fast DDS 2.14 deadlocks deleting the participant
    in destroy_node (DomainParticipant::set_listener waits for a discovery callback about the
    other node's leaving, which waits for the lock set_listener holds); the node then ignored
    SIGINT and SIGTERM until SIGKILL, and under `ros2 run` hung for good."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if not getattr(node, '_stopping', False):
        node._stopping = True
        faulthandler.dump_traceback_later(TEARDOWN_S, exit=True)
    if not getattr(node, '_stopped', False):
        node.destroy_node()
        node._stopped = True
    if rclpy.ok():
        rclpy.shutdown()
