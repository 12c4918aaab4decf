"""The built-in aggregators: one read-only table, read by the observables, the Updater's specs, the feature
bank, the batch and the suite schema.

Each reduces a buffer over its first axis. `preserves_bounds` says whether a bounded spec stays bounded
after aggregation: min, max and median of values within bounds stay within them; a sum does not; a mean
does up to rounding (the mean of three 0.1s is 0.1 + 1 ulp), so its bounds widen by the rounding's
worst case (`aggregated_bounds`), and a spec holds every value the reads return.
`reduce` is the same reduction written for the bank and the batch (a stacked group of buffers, reduced once
per group; `reduce(x, out)` writes into `out`), bit-identical to numpy's (and so dm_control's) reduction along
axis 0: numpy adds rows in order and divides the sum by the count; a median is the middle value, or the mean of
the two middle values. (dm_control sets a misspelled `bounds_reserving` on its built-ins while its Updater reads
`preserves_bounds`, so it silently drops bounds; we read both names.)
"""

from __future__ import annotations

import types
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple, cast

import numpy as np

__all__ = ["AGGREGATORS", "Aggregator", "FAMILIES", "Family", "aggregated_bounds", "builtin", "family",
           "get_aggregator", "pairwise", "preserves_bounds", "reduce_stacked"]


def _mean(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    # numpy adds from 0.0 row by row: a sum of -0.0s is 0.0
    total: np.ndarray = np.add.reduce(x, 0, None, cast(Any, out))
    return np.true_divide(total, x.shape[0], out=total)


def _median(x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    b = x.shape[0]
    s = x if b <= 2 else np.sort(x, axis=0)
    out = _mean(s[(b - 1) // 2:b // 2 + 1], out)  # numpy's median is the mean of the middle value(s)
    if b > 2:
        nan = np.isnan(s[-1])  # numpy's median is nan wherever a nan is present (sort puts nans last)
        if nan.any():
            out[nan] = np.nan
    return out


class Aggregator:
    """A named reduction over the buffer axis; `reduce` is its bank-exact form (see the module's doc)."""

    __slots__ = ("name", "_func", "preserves_bounds", "reduce")

    def __init__(self, name: str, func: Callable[..., np.ndarray], preserves_bounds: bool,
                 reduce: Callable[..., np.ndarray]):
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
        ("min", np.min, True, lambda x, out=None: np.minimum.reduce(x, 0, None, out)),
        ("max", np.max, True, lambda x, out=None: np.maximum.reduce(x, 0, None, out)),
        ("mean", np.mean, True, _mean),
        ("median", np.median, True, _median),
        ("sum", np.sum, False, lambda x, out=None: np.add.reduce(x, 0, None, out)),
    )
})


class Family(NamedTuple):
    """Built-in reductions that run as one over buffers of different lengths, each buffer padded to the
    longest with `pad`, which changes no result: numpy adds rows in order from 0.0 and adding -0.0 changes
    no sum; -inf changes no maximum and +inf no minimum. A mean then divides each column by its own count."""

    reduce: str  # the table's entry that reduces the padded block
    pad: float


FAMILIES: Mapping[str, Family] = types.MappingProxyType(
    {"sum": Family("sum", -0.0), "max": Family("max", -np.inf), "min": Family("min", np.inf)})


def pairwise(name: str, width: int) -> bool:
    """Whether numpy adds up a buffer of `width`-value samples of the built-in `name` pairwise, not row by row:
    a sum or mean of one-value samples, whose buffer is a 1-D array to numpy (and dm_control), which sums it
    pairwise from 8 values on. Such a buffer is reduced by itself along contiguous memory, never side by side
    with other columns (there it would be added row by row, off in the last bits): the read layouts give it a
    group of its own, no family takes it (`family`), and a batch reduces it per simulation (`reduce_stacked`)."""
    return width == 1 and name in ("sum", "mean")


def family(name: str, buffer: int, width: int) -> tuple[Family, int] | None:
    """(family, divisor) of the built-in `name` reducing `buffer` samples of `width` values stacked; None
    when it runs alone: a sum or mean numpy adds pairwise (`pairwise`) or a median of 3 or more (sorted). A
    median of 1 or 2 is their mean (numpy's median is the mean of the middle values); a min or max stays in
    its family (no rounding)."""
    if name in ("min", "max"):
        return FAMILIES[name], 1
    if pairwise(name, width) or (name == "median" and buffer > 2):
        return None
    return FAMILIES["sum"], 1 if name == "sum" else buffer


def reduce_stacked(name: str, window: np.ndarray) -> np.ndarray:
    """The built-in `name` over each of n stacked buffers, a (buffer, n, width) window, as numpy reduces each
    (buffer, width) buffer alone; returns (n, width). A buffer numpy adds pairwise (`pairwise`) is reduced
    along contiguous memory, each of the n by itself."""
    reduce = AGGREGATORS[name].reduce
    if not pairwise(name, window.shape[2]):
        return reduce(np.ascontiguousarray(window))
    buffers = np.ascontiguousarray(window[:, :, 0].T)  # (n, buffer): reduced along contiguous memory
    return reduce(buffers.T)[:, None]


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
