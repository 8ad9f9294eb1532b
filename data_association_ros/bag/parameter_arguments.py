"""`-p name:=value` arguments of the bag tools <-> checked node parameter values."""
from __future__ import annotations

from typing import Any, Iterable, Mapping

import yaml

from ..core import InvalidInputError
from ..pipelines.parameters import BY_NAME


def parse_assignments(assignments: Iterable[str],
                      declarations: Mapping[str, Any] = BY_NAME) -> dict[str, Any]:
    """{'name': value} from ['name:=value', ...]; values read as YAML (true, 0.5, [1.0, 2.0]),
    each checked against the node's parameter declaration (`declarations`: name ->
    NodeParameter; the association node's by default)."""
    values: dict[str, Any] = {}
    for assignment in assignments:
        name, separator, text = assignment.partition(':=')
        if not separator:
            raise InvalidInputError(f'-p {assignment}: expected name:=value')
        if name not in declarations:
            raise InvalidInputError(f'-p {assignment}: the node has no parameter {name!r}')
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            value = text
        values[name] = declarations[name].check(value)
    return values


def ros_arguments(values: Mapping[str, Any],
                  declarations: Mapping[str, Any] = BY_NAME) -> list[str]:
    """['-p', 'name:=value', ...] with each value in the type the node declares
    (`declarations`: name -> NodeParameter; the association node's by default)."""
    arguments = []
    for name, value in values.items():
        default = declarations[name].default
        if isinstance(default, bool):
            text = 'true' if value else 'false'
        elif isinstance(default, float):
            text = float_text(value)
        elif isinstance(default, list):
            text = '[' + ', '.join(float_text(v) for v in value) + ']'
        else:
            text = str(value)
        arguments += ['-p', f'{name}:={text}']
    return arguments


def float_text(value: float) -> str:
    """A float as YAML reads it back as a float: 1e-09 (a string to YAML 1.1) -> 1.0e-09."""
    text = repr(float(value))
    mantissa, _, exponent = text.partition('e')
    if exponent and '.' not in mantissa:
        text = f'{mantissa}.0e{exponent}'
    return text
