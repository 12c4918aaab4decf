"""Intervals and delays drawn per sample: `{uniform: [lo, hi]}` and `{choice: [...], p: [...]}` in steps.

The Updater calls a schedule callable that takes a `random_state` keyword with its own random state, so
draws are seeded with the episode. Both classes are frozen and compare by value (handy in tests), and
accept a numpy `RandomState` (as dm_control passes) or a `Generator`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["UniformSteps", "ChoiceSteps"]


def _integers(random_state: Any, low: int, high_exclusive: int) -> int:
    if isinstance(random_state, np.random.RandomState):
        return int(random_state.randint(low, high_exclusive))
    return int(random_state.integers(low, high_exclusive))


@dataclasses.dataclass(frozen=True)
class UniformSteps:
    """An integer number of physics steps drawn uniformly from low..high, both inclusive."""

    low: int
    high: int

    @property
    def minimum(self) -> int:
        """The smallest value a draw can give: the Updater checks it once, not every draw."""
        return self.low if isinstance(self.low, int) and self.low <= self.high else -1

    def __call__(self, random_state: Any) -> int:
        return _integers(random_state, self.low, self.high + 1)


@dataclasses.dataclass(frozen=True)
class ChoiceSteps:
    """One of `values` (physics steps), with probabilities `p` (uniform when None)."""

    values: tuple[int, ...]
    p: tuple[float, ...] | None = None

    @property
    def minimum(self) -> int:
        """The smallest value a draw can give: the Updater checks it once, not every draw."""
        return min(self.values) if self.values and all(isinstance(v, int) for v in self.values) else -1

    def __call__(self, random_state: Any) -> int:
        if self.p is None:
            return self.values[_integers(random_state, 0, len(self.values))]
        return self.values[int(random_state.choice(len(self.values), p=self.p))]
