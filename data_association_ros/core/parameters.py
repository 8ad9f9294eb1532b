"""Algorithm parameters: name, default, range and meaning, checked before an associator runs."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional

from .errors import InvalidInputError


@dataclass(frozen=True)
class ParameterSpec:
    """One algorithm parameter. Numbers must lie in [low, high] (ends excluded where open)."""

    name: str
    default: Any
    description: str
    kind: type = float
    low: Optional[float] = None
    high: Optional[float] = None
    low_open: bool = False
    high_open: bool = False

    def range_text(self) -> str:
        """The valid range in interval notation, e.g. '(0, 1)'."""
        if self.kind is bool:
            return 'true or false'
        low = '-inf' if self.low is None else f'{self.low:g}'
        high = 'inf' if self.high is None else f'{self.high:g}'
        return (('(' if self.low_open or self.low is None else '[') + f'{low}, {high}'
                + (')' if self.high_open or self.high is None else ']'))

    def check(self, value: Any) -> Any:
        """`value` converted to the parameter's type; InvalidInputError naming it otherwise."""
        if self.kind is bool:
            if not isinstance(value, bool):
                raise InvalidInputError(f'{self.name}: expected true or false, got {value!r}')
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InvalidInputError(f'{self.name}: expected a number, got {value!r}')
        if self.kind is int and value != int(value):
            raise InvalidInputError(f'{self.name}: expected an integer, got {value!r}')
        value = self.kind(value)
        if not math.isfinite(value):
            raise InvalidInputError(f'{self.name}: must be finite, got {value!r}')
        below = self.low is not None and (value <= self.low if self.low_open else value < self.low)
        above = self.high is not None and (
            value >= self.high if self.high_open else value > self.high)
        if below or above:
            raise InvalidInputError(f'{self.name}: {value!r} outside {self.range_text()}')
        return value


GATE_PROBABILITY = ParameterSpec(
    'gate_probability', 0.99, 'probability mass of the chi-square individual gate (and of the '
    'joint test unless joint_gate_probability is set)',
    low=0.0, high=1.0, low_open=True, high_open=True)
JOINT_GATE_PROBABILITY = ParameterSpec(
    'joint_gate_probability', 0.0, 'jcbb: probability mass of the chi-square joint test of a set '
    'of pairs, 1 - its significance level (0: the same as gate_probability)',
    low=0.0, high=1.0, high_open=True)
MIN_INNOVATION_VARIANCE = ParameterSpec(
    'min_innovation_variance', 1e-9,
    'floor on each diagonal entry of S = H P H^T + R (measurement units squared)', low=0.0)
ONE_TO_ONE = ParameterSpec(
    'one_to_one', False, 'greedy by cost, each landmark taken at most once (else several '
    'observations may take one landmark)', kind=bool)


def resolve(specs: tuple[ParameterSpec, ...], given: dict[str, Any], algorithm: str) -> dict:
    """Defaults of `specs` overridden by the checked values of `given`; unknown names raise."""
    known = {spec.name: spec for spec in specs}
    unknown = sorted(set(given) - set(known))
    if unknown:
        raise InvalidInputError(
            f'{unknown[0]}: not a parameter of {algorithm!r} (valid: {", ".join(sorted(known))})')
    return {name: spec.check(given[name]) if name in given else spec.default
            for name, spec in known.items()}
