"""The built-in aggregators: one table, read by the observables, the Updater's specs and the suite schema.

Each reduces a buffer over its first axis. `preserves_bounds` says whether a bounded spec stays bounded
after aggregation: min, max, mean and median of values within bounds stay within them; a sum does not.
(dm_control sets a misspelled `bounds_reserving` on its built-ins while its Updater reads
`preserves_bounds`, so it silently drops bounds; we read both names.)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["AGGREGATORS", "Aggregator", "get_aggregator", "preserves_bounds"]


class Aggregator:
    """A named reduction over the buffer axis."""

    __slots__ = ("name", "_func", "preserves_bounds")

    def __init__(self, name: str, func: Callable[..., np.ndarray], preserves_bounds: bool):
        self.name = name
        self._func = func
        self.preserves_bounds = preserves_bounds

    def __call__(self, buffered: np.ndarray) -> np.ndarray:
        return self._func(buffered, axis=0)

    def __repr__(self) -> str:
        return f"Aggregator({self.name!r})"


AGGREGATORS: dict[str, Aggregator] = {
    name: Aggregator(name, func, keeps)
    for name, func, keeps in (
        ("min", np.min, True),
        ("max", np.max, True),
        ("mean", np.mean, True),
        ("median", np.median, True),
        ("sum", np.sum, False),
    )
}


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


def preserves_bounds(aggregator: object) -> bool:
    return bool(getattr(aggregator, "preserves_bounds", getattr(aggregator, "bounds_reserving", False)))
