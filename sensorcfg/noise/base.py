"""What every noise stage is built against and shares: the observation's `Context`, the `Stage` interface,
and coefficients cached per time between samples. Numpy only."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .streams import Streams

__all__ = ["Context", "Stage", "block_samples"]

_BLOCK_VALUES = 1 << 13  # per-sample numbers drawn at a time on the per-sample path (per stage), at most
_MAX_BLOCK = 1024  # samples per block, at most (a power of two)
_MAX_INTERVALS = 64  # distinct sample intervals whose coefficients are cached


def block_samples(size: int) -> int:
    """Samples of `size` values each drawn at a time on the per-sample path and walked at a time by a random
    walk (the batch's too, which may walk it in halves): a power of two; a sample's numbers do not depend on it."""
    return 1 << (max(1, min(_MAX_BLOCK, _BLOCK_VALUES // max(size, 1))).bit_length() - 1)


class Context:
    """What every stage is built against: the observation and the arithmetic it is noised in."""

    def __init__(self, shape: tuple[int, ...], dtype: np.dtype, work: np.dtype, timestep: float):
        self.shape = shape
        self.dtype = dtype  # the observation's
        self.work = work  # the stages' arithmetic: float64, or float32 for float32 / uint8 observations
        self.timestep = timestep
        self.block = block_samples(math.prod(shape))

    def cast(self, value: ArrayLike) -> np.ndarray:
        """A parameter as an array of the work dtype (0-d for a number): ufuncs take arrays faster than
        Python floats, which they convert on every call."""
        return np.array(value, dtype=self.work)


# -- stages ---------------------------------------------------------------------------------------

class Stage:
    """One stage at run time."""

    needs_rng = False
    # True when the stage needs the raw value of every nominal sample (its sensor then takes them all)
    stateful = False
    # how many configured stages this one carries out (see `Sum`); Uniform reuses the name for high - low
    width: int | np.ndarray = 1
    stream = 0  # the stage's position in its pipeline: its part of the counter

    def reset(self, streams: Streams | None, stride: int) -> None:
        """Start an episode: per-episode draws, cleared state."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        raise NotImplementedError


class _Timed:
    """Coefficients that depend on the number of physics steps since the previous sample, cached."""

    def __init__(self, ctx: Context, make: Callable[[float], Any]):
        self.timestep, self.make = ctx.timestep, make
        self.cache: dict[int, Any] = {}

    def __call__(self, steps: int) -> Any:
        coef = self.cache.get(steps)
        if coef is None:
            if steps < 0:
                raise ValueError(f"noise pipeline called at an earlier step ({steps} steps back); "
                                 "call reset() at the start of an episode")
            if len(self.cache) >= _MAX_INTERVALS:
                self.cache.clear()
            coef = self.cache[steps] = self.make(steps * self.timestep)
        return coef
