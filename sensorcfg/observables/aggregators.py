"""The built-in aggregators: one read-only table, read by the observables, the Updater's specs, the feature
bank, the batch and the suite schema.

Each reduces a buffer over its first axis. `preserves_bounds` says whether a bounded spec stays bounded
after aggregation: min, max and median of values within bounds stay within them; a sum does not; a mean
does up to rounding (the mean of three 0.1s is 0.1 + 1 ulp), so its bounds widen by the rounding's
worst case (`aggregated_bounds`), and a spec holds every value the reads return.
`reduce` is the same reduction written for the bank and the batch (a stacked group of buffers, reduced once
per group), bit-identical to numpy's (and so dm_control's) reduction along axis 0: numpy adds rows in order
and divides the sum by the count; a median is the middle value, or the mean of the two middle values.
(dm_control sets a misspelled `bounds_reserving` on its built-ins while its Updater reads
`preserves_bounds`, so it silently drops bounds; we read both names.)
"""

from __future__ import annotations

import types
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

__all__ = ["AGGREGATORS", "Aggregator", "aggregated_bounds", "builtin", "get_aggregator", "preserves_bounds"]


def _mean(x: np.ndarray) -> np.ndarray:
    total = np.add.reduce(x, axis=0) if x.shape[0] != 2 else x[0] + x[1]
    return np.true_divide(total, x.shape[0], out=total)


def _median(x: np.ndarray) -> np.ndarray:
    b = x.shape[0]
    if b <= 2:  # the middle value, or the mean of both (a nan anywhere gives nan, as in numpy)
        return x[0].copy() if b == 1 else np.true_divide(x[0] + x[1], 2)
    s = np.sort(x, axis=0)
    out = s[b // 2].copy() if b % 2 else np.true_divide(s[b // 2 - 1] + s[b // 2], 2)
    nan = np.isnan(s[-1])  # numpy's median is nan wherever a nan is present (sort puts nans last)
    if nan.any():
        out[nan] = np.nan
    return out


class Aggregator:
    """A named reduction over the buffer axis; `reduce` is its bank-exact form (see the module's doc)."""

    __slots__ = ("name", "_func", "preserves_bounds", "reduce")

    def __init__(self, name: str, func: Callable[..., np.ndarray], preserves_bounds: bool,
                 reduce: Callable[[np.ndarray], np.ndarray]):
        self.name = name
        self._func = func
        self.preserves_bounds = preserves_bounds
        self.reduce = reduce

    def __call__(self, buffered: np.ndarray) -> np.ndarray:
        return self._func(buffered, axis=0)

    def __repr__(self) -> str:
        return f"Aggregator({self.name!r})"


AGGREGATORS: Mapping[str, Aggregator] = types.MappingProxyType({
    name: Aggregator(name, func, keeps, reduce)
    for name, func, keeps, reduce in (
        ("min", np.min, True, lambda x: np.minimum.reduce(x, 0)),
        ("max", np.max, True, lambda x: np.maximum.reduce(x, 0)),
        ("mean", np.mean, True, _mean),
        ("median", np.median, True, _median),
        ("sum", np.sum, False, lambda x: np.add.reduce(x, 0)),
    )
})


def builtin(aggregator: object) -> Aggregator | None:
    """The table's entry when `aggregator` is one of the built-ins (the object itself), else None."""
    found = AGGREGATORS.get(getattr(aggregator, "name", None) or "")
    return found if found is aggregator else None


def get_aggregator(value: str | Callable[[np.ndarray], Any] | None,
                   owner: str = "") -> Callable[[np.ndarray], Any] | None:
    """None, a built-in by name, or any callable reducing the leading axis (`owner` names the observable)."""
    if value is None or callable(value):
        return value
    if isinstance(value, str) and value in AGGREGATORS:
        return AGGREGATORS[value]
    from ..errors import SuiteError, did_you_mean

    raise SuiteError(
        f"{owner + ': ' if owner else ''}unknown aggregator {value!r}{did_you_mean(str(value), AGGREGATORS)}; "
        f"use one of {', '.join(AGGREGATORS)}, a callable, or none")


def _rounding(bounds: tuple[Any, Any], count: int) -> tuple[Any, Any]:
    """Bounds of a float mean of `count` values within `bounds`: the rows are summed one after another,
    each addition off by at most half an ulp of the running sum, then divided, so the mean is off by less
    than count x eps x the largest magnitude."""
    low, high = (np.asarray(b, dtype=np.float64) for b in bounds)
    slack = count * np.finfo(np.float64).eps * np.maximum(np.abs(low), np.abs(high))
    return low - slack, high + slack


def aggregated_bounds(aggregator: object, bounds: tuple[Any, Any] | None, count: int) -> tuple[Any, Any] | None:
    """The bounds an aggregated value keeps: None when the aggregator does not preserve them."""
    if bounds is None or not preserves_bounds(aggregator):
        return None
    return _rounding(bounds, count) if builtin(aggregator) is AGGREGATORS["mean"] else bounds


def preserves_bounds(aggregator: object) -> bool:
    return bool(getattr(aggregator, "preserves_bounds", getattr(aggregator, "bounds_reserving", False)))
