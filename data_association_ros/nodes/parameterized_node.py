"""A Node whose parameters come from NodeParameter declarations: declared with descriptors,
validated in one callback (with a cross-parameter check), applied in another (DESIGN.md 4)."""
from __future__ import annotations

import sys
from typing import Any, Callable, Optional, Sequence

import rclpy

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..core import InvalidInputError
from ..pipelines.parameters import NodeParameter


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


class ParameterizedNode(Node):
    """Declares `parameters`; `config` holds the values in force; `combination(config)` raises
    InvalidInputError when values valid one by one conflict; `on_change()` runs after a set."""

    def __init__(self, name: str, parameters: Sequence[NodeParameter],
                 combination: Callable[[dict], None] = lambda config: None, **kwargs) -> None:
        super().__init__(name, **kwargs)
        self._declared = {p.name: p for p in parameters}
        self._combination = combination
        self.config: dict[str, Any] = {}
        for parameter in parameters:
            self.declare_parameter(parameter.name, parameter.default, descriptor(parameter))
            try:
                self.config[parameter.name] = parameter.check(
                    self.get_parameter(parameter.name).value)
            except InvalidInputError as error:
                self.get_logger().error(f'{error}; using the default {parameter.default!r}')
                self.config[parameter.name] = parameter.default
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

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


def spin(node_class: Callable[[], Node], args: Optional[list[str]] = None) -> None:
    """Entry point of an executable: init, spin `node_class()` until Ctrl-C or shutdown."""
    rclpy.init(args=args if args is not None else sys.argv)
    node = node_class()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
