"""Numeric noise parameters: a number, a list with one entry per value, or `{uniform: [low, high]}` drawn
per episode; quantities with units ('50ms', '20Hz', '0.5deg'); their bounds and their order (low <= high).

The noise stage configs (`config/noise.py`) annotate their fields with the types defined here (`Real`,
`Std`, `Probability`, `Step`, `Duration`, `Frequency`); errors are pydantic errors located at the field.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import re
from collections.abc import Mapping
from typing import TYPE_CHECKING, Annotated, Any, TypeAlias, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError, WrapValidator
from pydantic_core import InitErrorDetails, PydanticCustomError

from ..errors import did_you_mean, quote
from .units import DURATION_UNITS, RATE_UNITS

__all__ = ["Duration", "EpisodeUniform", "Frequency", "PER_VALUE", "PerValue", "Probability", "Real", "Std", "Step",
           "error_at", "ordered", "parse_quantity"]


class EpisodeUniform(BaseModel):
    """A parameter drawn once per episode, uniformly from [low, high] (one value for every entry)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    uniform: tuple[float, float] = Field(description="[low, high]: the parameter is drawn from U(low, high) at "
                                         "each reset. One end of a pair (min and max, low and high) drawn so must "
                                         "not overlap the other end's values: no episode draws them crossed.",
                                         examples=[[0.01, 0.03]])

    @property
    def low(self) -> float:
        return self.uniform[0]

    @property
    def high(self) -> float:
        return self.uniform[1]

    def scaled(self, factor: float) -> EpisodeUniform:
        return EpisodeUniform(uniform=(self.low * factor, self.high * factor))


PerValue = Union[float, tuple[float, ...], EpisodeUniform]  # what a validated numeric parameter holds

# -- numbers, per-value lists and quantities with units -----------------------------------------------

_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\d\s.+-][^\s]*)?\s*$", re.ASCII)


def parse_quantity(value: Any, units: Mapping[str, float], what: str) -> float:
    """A number in SI units from a number (already SI) or a string such as '50ms' or '20 Hz'.

    Unit names come from the suite's units table (`config.units`); signs are accepted here so that a negative
    duration is reported as out of range rather than as unreadable. Raises ValueError with the fix.
    """
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, str):
        match = _QUANTITY.match(value)
        if match:
            number, unit = match.groups()
            if unit is None:
                return float(number)
            if unit in units:
                return float(number) * units[unit]
            lowered = {u.lower(): u for u in units}
            hint = (f" (did you mean {lowered[unit.lower()]!r}?)" if unit.lower() in lowered
                    else did_you_mean(unit, units))
            raise ValueError(f"unknown unit {quote(unit)} in {quote(value)}{hint}; "
                             f"{'an' if what[0] in 'aeiou' else 'a'} {what} takes {', '.join(units)}")
    raise ValueError(f"expected a {what} such as {_EXAMPLE[what]!r} or a number "
                     f"({_SI[what]}), got {quote(value)}")


_EXAMPLE = {"duration": "50ms", "frequency": "20Hz", "angle": "0.5deg"}
_SI = {"duration": "seconds", "frequency": "Hz", "angle": "radians"}


@dataclasses.dataclass(frozen=True, eq=False)  # hashed by identity: it sits in type annotations
class _Bound:
    """What a numeric parameter accepts: its meaning (for messages), bounds, and units if a quantity."""

    meaning: str
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    units: Mapping[str, float] | None = None
    quantity: str = ""

    def check(self, value: Any) -> float:
        if self.units is not None:
            x = parse_quantity(value, self.units, self.quantity)
        elif isinstance(value, numbers.Real) and not isinstance(value, bool):
            x = float(value)
        else:
            raise ValueError(f"expected a number, got {quote(value)}")
        if not math.isfinite(x):
            raise ValueError(f"expected a finite number, got {quote(value)}")
        for bound, ok, op in ((self.gt, lambda b: x > b, ">"), (self.ge, lambda b: x >= b, ">="),
                              (self.le, lambda b: x <= b, "<=")):
            if bound is not None and not ok(bound):
                raise ValueError(f"{self.meaning} must be {op} {bound:g}, got {quote(value)}")
        return x

    def __call__(self, value: Any, handler: Any, info: Any) -> PerValue:
        """WrapValidator: a number, or a non-empty list of numbers (one per value); a tuple once valid; or
        `{uniform: [low, high]}`, drawn per episode."""
        if isinstance(value, EpisodeUniform):
            return value
        if isinstance(value, Mapping):
            return self.episode(value)
        if isinstance(value, (list, tuple)):
            if not value:
                raise PydanticCustomError("per_value", "an empty list gives no values; give a number or one "
                                                       "entry per value of the observation")
            errors = []
            out = []
            for i, item in enumerate(value):
                try:
                    out.append(self.check(item))
                except ValueError as e:
                    errors.append(InitErrorDetails(type=PydanticCustomError("per_value", str(e)), loc=(i,),
                                                   input=item))
            if errors:
                raise ValidationError.from_exception_data("per-value parameter", errors)
            return tuple(out)
        try:
            return self.check(value)
        except ValueError as e:
            raise PydanticCustomError("per_value", str(e)) from None


    def episode(self, value: Mapping[Any, Any]) -> EpisodeUniform:
        bounds = value.get("uniform") if set(value) == {"uniform"} else None
        if not isinstance(bounds, (list, tuple)) or len(bounds) != 2:
            raise PydanticCustomError("per_value", "a parameter drawn per episode is written {uniform: [low, high]}; "
                                      f"got {dict(value)!r}")
        try:
            low, high = self.check(bounds[0]), self.check(bounds[1])
        except ValueError as e:
            raise PydanticCustomError("per_value", str(e)) from None
        if low > high:
            raise PydanticCustomError("per_value", f"uniform bounds must satisfy low <= high; got [{low:g}, {high:g}]: "
                                      "swap them")
        return EpisodeUniform(uniform=(low, high))


def _per_value(meaning: str, **bounds: Any) -> Any:
    """The annotated type of a per-value parameter: schema `number | number[] | {uniform: [lo, hi]}`,
    validated by `_Bound`."""
    constraints = {k: v for k, v in bounds.items() if k in ("ge", "gt", "le")}
    if "units" in bounds:
        item: Any = Union[float, str]
    else:
        item = Annotated[float, Field(**constraints)]
    return Annotated[Union[item, Annotated[list[item], Field(min_length=1)], EpisodeUniform],
                     WrapValidator(_Bound(meaning, **bounds))]


if TYPE_CHECKING:  # what a validated field holds; pydantic reads the annotated types below
    Real: TypeAlias = PerValue
    Std: TypeAlias = PerValue
    Probability: TypeAlias = PerValue
    Step: TypeAlias = PerValue
    Duration: TypeAlias = PerValue
    Frequency: TypeAlias = PerValue
else:
    Real = _per_value("the value")
    Std = _per_value("a standard deviation", ge=0)
    Probability = _per_value("a probability", ge=0, le=1)
    Step = _per_value("a quantisation step", gt=0, ge=1e-100)  # smaller: value / step overflows to inf
    Duration = _per_value("a correlation time", gt=0, units=DURATION_UNITS, quantity="duration")
    Frequency = _per_value("a cutoff frequency", gt=0, units=RATE_UNITS, quantity="frequency")

PER_VALUE = ("A number, or a list with one entry per value of the observation (or one per entry of its last "
              "axis, e.g. per colour channel).")


def ordered(low: PerValue | None, high: PerValue | None, names: tuple[str, str]) -> None:
    """low <= high entry by entry where the two can be compared (equal lengths, or one a number), in every
    episode: where either end is drawn (`{uniform: [lo, hi]}`), the highest value low can take must not
    exceed the lowest value high can take. Drawn ranges that overlap are refused, not reordered at each
    draw: a pair put back in order would no longer follow the distributions the suite wrote."""
    if low is None or high is None:
        return
    lows = low if isinstance(low, tuple) else None
    highs = high if isinstance(high, tuple) else None
    if lows is not None and highs is not None and len(lows) != len(highs):
        return  # may broadcast differently (per value vs per last axis); checked at binding time
    n = len(lows or highs or (0,))
    drawn = isinstance(low, EpisodeUniform) or isinstance(high, EpisodeUniform)
    for i in range(n):
        lo = lows[i] if lows is not None else low
        hi = highs[i] if highs is not None else high
        top = lo.high if isinstance(lo, EpisodeUniform) else lo
        bottom = hi.low if isinstance(hi, EpisodeUniform) else hi
        if top > bottom:  # type: ignore[operator]
            at = f" (entry {i})" if n > 1 or lows is not None or highs is not None else ""
            a, b = names
            if not drawn:
                raise error_at(a, "noise_order", f"{a} must not exceed {b}{at}: {a} is {top:g} and {b} is "
                               f"{bottom:g}; swap them", lo)
            raise error_at(a, "noise_order", f"{a} must not exceed {b}{at} in any episode, but {a} is "
                           f"{_described(lo)} and {b} is {_described(hi)}: a draw can put {a} above {b}; make "
                           f"{_end(a, lo, 'highest')} ({top:g}) at most {_end(b, hi, 'lowest')} ({bottom:g}), "
                           "so that the two never cross", lo)


def _end(name: str, value: Any, which: str) -> str:
    return f"{name}'s {which} value" if isinstance(value, EpisodeUniform) else name


def _described(value: Any) -> str:
    return f"drawn from [{value.low:g}, {value.high:g}]" if isinstance(value, EpisodeUniform) else f"{value:g}"


def error_at(field: str, kind: str, message: str, value: Any) -> ValidationError:
    """A stage-level check reported at one of the stage's fields (so the YAML position is that key's)."""
    detail = InitErrorDetails(type=PydanticCustomError(kind, message), loc=(field,), input=value)
    return ValidationError.from_exception_data("NoiseStage", [detail])
