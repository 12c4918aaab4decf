"""Intervals and delays drawn per sample: `{uniform: [lo, hi]}` and `{choice: [...], p: [...]}` in steps.

The Updater calls a schedule callable that takes a `random_state` keyword with its own random state, so
draws are seeded with the episode. Both classes are frozen and compare by value (handy in tests), and
accept a numpy `RandomState` (as dm_control passes) or a `Generator`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

__all__ = ["UniformSteps", "ChoiceSteps"]


def _integers(random_state: Any, low: int, high_exclusive: int) -> int:
    draw = getattr(random_state, "integers", None) or random_state.randint
    return int(draw(low, high_exclusive))


@dataclasses.dataclass(frozen=True)
class UniformSteps:
    """An integer number of physics steps drawn uniformly from low..high, both inclusive."""

    low: int
    high: int

    def __call__(self, random_state: Any) -> int:
        return _integers(random_state, self.low, self.high + 1)


@dataclasses.dataclass(frozen=True)
class ChoiceSteps:
    """One of `values` (physics steps), with probabilities `p` (uniform when None)."""

    values: tuple[int, ...]
    p: tuple[float, ...] | None = None

    def __call__(self, random_state: Any) -> int:
        if self.p is None:
            return self.values[_integers(random_state, 0, len(self.values))]
        return self.values[int(random_state.choice(len(self.values), p=self.p))]
