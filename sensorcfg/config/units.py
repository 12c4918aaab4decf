"""Time in a suite: integer physics steps, durations (`4ms`, `0.02s`, `500us`, `1e-3s`) and rates (`50Hz`).

Text is checked when a suite is loaded; it becomes steps only at binding, because a step is the model's
`opt.timestep`. A duration that is not a whole number of steps is an error that names the two nearest
valid values in the unit the user wrote, so the fix can be pasted. Pure Python: no mujoco, no numpy.
"""

from __future__ import annotations

import math
import re
import warnings

from ..errors import quote
from .limits import MAX_SCHEDULE_STEPS
from .source import DECIMAL

__all__ = ["DURATION_UNITS", "RATE_UNITS", "parse_time", "timestep_problem", "to_steps", "format_seconds",
           "TIME_PATTERN"]

# unit -> seconds per unit
DURATION_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9}
# unit -> hertz per unit
RATE_UNITS: dict[str, float] = {"Hz": 1.0, "kHz": 1e3}

# The number is written as YAML 1.2 writes one (`source.DECIMAL`: `4`, `0.5`, `.5`, `1e-3`), in ASCII digits and
# spaces only, so the schema's pattern (ECMAScript) and this parser agree, and '٤ms' or a line separator is not
# read as a time.
_NUMBER = DECIMAL
_SP = r"[ \t]*"
_TEXT = re.compile(rf"\A{_SP}({_NUMBER}){_SP}([a-zA-Zµ]+){_SP}\Z")
TIME_PATTERN = rf"^{_SP}{_NUMBER}{_SP}(?:{'|'.join(DURATION_UNITS)}|{'|'.join(RATE_UNITS)}){_SP}$"

_RELATIVE_TOLERANCE = 1e-9


def parse_time(text: str, *, rates: bool) -> tuple[float, str, str]:
    """'4ms' -> (4.0, 'ms', 'duration'); '50Hz' -> (50.0, 'Hz', 'rate'). Raises ValueError with the fix."""
    match = _TEXT.match(text)
    units = list(DURATION_UNITS) + (list(RATE_UNITS) if rates else [])
    examples = "'4ms', '0.02s', '500us'" + (", '50Hz'" if rates else "")
    if not match and text.strip().startswith("-") and _TEXT.match(text.strip()[1:]):
        raise ValueError(f"a time cannot be negative; got {quote(text)}; use a time like {examples}")
    if not match:
        raise ValueError(f"expected physics steps (an integer) or a time like {examples}; got {quote(text)}")
    number, unit = float(match.group(1)), match.group(2)
    if not math.isfinite(number):
        raise ValueError(f"{quote(text)} is not a finite number; use a time like {examples}")
    if unit not in units:
        hint = ""
        lowered = {u.lower(): u for u in units}
        if unit.lower() in lowered:
            hint = f" (did you mean {lowered[unit.lower()]!r}?)"
        elif unit in RATE_UNITS:
            hint = " (a delay is a duration, not a rate)"
        raise ValueError(f"unknown time unit {quote(unit)} in {quote(text)}{hint}; use one of {', '.join(units)}")
    kind = "rate" if unit in RATE_UNITS else "duration"
    if kind == "rate" and number <= 0:
        raise ValueError(f"a rate must be positive; got {quote(text)}")
    return number, unit, kind


def _fmt(number: float) -> str:
    text = f"{number:.6g}"
    return text


def format_seconds(seconds: float) -> str:
    """A readable duration: 0.002 -> '2ms'."""
    for unit in ("s", "ms", "us"):
        value = seconds / DURATION_UNITS[unit]
        if value >= 1 or unit == "us":
            return f"{_fmt(value)}{unit}"
    raise AssertionError("unreachable")


def timestep_problem(timestep: float) -> str | None:
    """Why a model's physics timestep cannot time a suite (0, negative or not finite: MuJoCo compiles
    them), or None. Every division by the timestep is behind this check (`to_steps`, binding)."""
    if timestep > 0 and math.isfinite(timestep):
        return None
    return (f"the model's physics timestep (<option timestep>) is {timestep:g} s; a suite's intervals, delays, "
            "rates and noise are timed in physics steps of it, which must last a positive, finite time: give "
            "the model a timestep such as <option timestep=\"0.002\"/>")


def _exact(number: float, unit: str, timestep: float) -> float:
    """Physics steps of `number` `unit` (a duration, or a rate's period), not rounded; inf when a rate overflows."""
    with warnings.catch_warnings():  # a rate of 1e-300Hz overflows to inf, which callers report
        warnings.simplefilter("ignore", RuntimeWarning)
        if unit in RATE_UNITS:
            hertz = number * RATE_UNITS[unit] * timestep
            return 1.0 / hertz if hertz else math.inf
        return number * DURATION_UNITS[unit] / timestep


def _whole(exact: float) -> int | None:
    """The whole number of steps `exact` is, to rounding, else None: the one acceptance rule."""
    nearest = round(exact) if math.isfinite(exact) else None
    if nearest is not None and math.isclose(exact, nearest, rel_tol=_RELATIVE_TOLERANCE, abs_tol=1e-9):
        return int(nearest)
    return None


def _spelled(steps: int, unit: str, timestep: float) -> str:
    """`steps` written so that it validates as exactly that many steps: in `unit` when its six significant digits
    are exact (250Hz, 6ms), else as a duration (200Hz on 2ms steps: 3 steps are 166.666...Hz, written 6ms), else
    as the integer (a timestep whose multiples need more digits)."""
    if unit in RATE_UNITS:
        rate = f"{_fmt(1.0 / (steps * timestep * RATE_UNITS[unit]))}{unit}" if steps else ""
        candidates = [rate, format_seconds(steps * timestep)]
    else:
        candidates = [f"{_fmt(steps * timestep / DURATION_UNITS[unit])}{unit}", format_seconds(steps * timestep)]
    for text in candidates:
        match = _TEXT.match(text)
        if match and _whole(_exact(float(match.group(1)), match.group(2), timestep)) == steps:
            return text
    return str(steps)


def to_steps(value: int | str, timestep: float, *, minimum: int, maximum: int = MAX_SCHEDULE_STEPS) -> int:
    """Physics steps for an integer, a duration or a rate; ValueError names the nearest valid values (each
    spelled so that it validates: `_spelled`), or the bound when the value is more than `maximum` steps, or why
    `timestep` cannot time a duration."""
    if isinstance(value, int):
        if value > maximum:
            raise ValueError(f"{value} physics steps is more than {maximum:,}, the most a schedule may take")
        return value
    number, unit, kind = parse_time(value, rates=True)
    problem = timestep_problem(timestep)
    if problem is not None:
        raise ValueError(f"{value} needs a physics step's duration: {problem}")
    exact = _exact(number, unit, timestep)
    if not exact <= maximum:
        spelled = f"{exact:.3g}" if math.isfinite(exact) else "infinitely many"
        raise ValueError(f"{value} is {spelled} physics steps of {format_seconds(timestep)}; a schedule may take at "
                         f"most {maximum:,} steps")
    whole = _whole(exact)
    if whole is not None and whole >= minimum:
        return whole
    step_text = format_seconds(timestep)
    low, high = (whole, whole) if whole is not None else (math.floor(exact), math.ceil(exact))
    choices = [s for s in dict.fromkeys((low, high, minimum)) if s >= minimum][:2]
    if kind == "rate" and exact < minimum:
        what = f"{value} is faster than one sample per {step_text} physics step"
    elif exact < minimum:
        what = f"{value} is shorter than one {step_text} physics step"
    else:
        what = f"{value} is not a whole number of {step_text} physics steps ({_fmt(exact)} steps)"
    offered = [_spelled(s, unit, timestep) for s in choices]
    steps = " (an integer is physics steps)" if any(text.isdigit() for text in offered) else ""
    raise ValueError(f"{what}; use {' or '.join(offered)}{steps}")
