"""A cache of precomputed read layouts with a byte budget: memory stays in proportion to what they hold.

Read layouts are computed per phase and kept, because a sensor's reads repeat; but a sensor with a long buffer
and delay has many phases, each layout as large as its window, so keeping them all would take memory in
proportion to buffer x (delay + buffer). Past the budget, a layout is computed again when needed instead of
kept (its cost is in proportion to the read it serves).
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any

import numpy as np

__all__ = ["BoundedCache", "nbytes"]

DEFAULT_BUDGET = 32 << 20  # bytes per cache


def nbytes(value: Any) -> int:
    """The bytes of the arrays in `value` (nested tuples and lists), roughly."""
    if isinstance(value, np.ndarray):
        return value.nbytes
    if isinstance(value, (tuple, list)):
        return sum(nbytes(v) for v in value) + 8 * len(value)
    return 64


class BoundedCache(dict):  # type: ignore[type-arg]
    """A dict (its `get` is the fast path of a read) that stops taking entries once they hold `budget`
    bytes; `put` adds within the budget, `clear` starts over."""

    def __init__(self, budget: int = DEFAULT_BUDGET):
        super().__init__()
        self.budget = budget
        self.used = 0

    def put(self, key: Hashable, value: Any, size: int | None = None) -> Any:
        """Keep `value` if it fits the budget (`size` bytes: its arrays' when not given); returns it."""
        size = nbytes(value) if size is None else size
        if self.used + size <= self.budget:
            self[key] = value
            self.used += size
        return value

    def clear(self) -> None:
        super().clear()
        self.used = 0
