"""Stages that change the signal without per-sample numbers: low-pass, quantize, clip, and a custom
callable with its own random state. Numpy only."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import Problem, SuiteError
from .arithmetic import clip, lowpass, lowpass_alpha, quantize
from .base import Context, Stage, _Timed
from .streams import Streams

__all__ = ["Lowpass", "Quantize", "Clip", "Custom"]


class Lowpass(Stage):
    """y <- y + alpha (x - y), alpha = 1 - exp(-2 pi cutoff dt); starts settled at the first sample.

    A NaN input (a `dropout` with mode nan placed before it) stays in the state for the rest of the episode,
    as it would in a real filter fed NaN: put such a dropout after the filter.
    """

    stateful = True

    def __init__(self, ctx: Context, cutoff: Any):
        self.alpha = _Timed(ctx, lambda dt: ctx.cast(lowpass_alpha(cutoff, dt)))
        self.state = np.zeros(ctx.shape, ctx.work)
        self.fresh = True
        self.last = 0

    def reset(self, streams: Streams | None, stride: int) -> None:
        self.fresh = True

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        state = self.state
        if self.fresh:
            self.fresh = False
            np.copyto(state, src, casting="unsafe")
        else:
            steps = step - self.last
            if steps:
                lowpass(state, src, self.alpha(steps), dst)
        self.last = step
        np.copyto(dst, state)


class Quantize(Stage):
    def __init__(self, ctx: Context, step: Any):
        self.step = ctx.cast(step)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        quantize(src, self.step, dst)


class Clip(Stage):
    def __init__(self, ctx: Context, low: Any, high: Any):
        self.low = None if low is None else ctx.cast(low)
        self.high = None if high is None else ctx.cast(high)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        clip(src, self.low, self.high, dst)


class Custom(Stage):
    """A dm_control corruptor `f(value, random_state=...)`, given values in the observation's dtype.

    Its random state is sequential, so its sensor takes every nominal sample (`stateful`)."""

    needs_rng = True
    stateful = True

    def __init__(self, ctx: Context, fn: Callable[..., Any], name: str, loc: str):
        self.ctx, self.fn, self.name, self.loc = ctx, fn, name, loc
        self.convert = ctx.work != ctx.dtype
        self.random_state = np.random.RandomState(0)

    def reset(self, streams: Streams | None, stride: int) -> None:
        assert streams is not None
        words = streams.at(self.stream, 0, purpose=1).integers(0, 2**32, size=4)
        self.random_state = np.random.RandomState(np.random.MT19937(words))

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        value = src
        if self.convert:
            if self.ctx.dtype == np.uint8:
                value = np.clip(np.rint(src), 0, 255)
            value = value.astype(self.ctx.dtype)
        result = np.asarray(self.fn(value, random_state=self.random_state))
        if result.shape != self.ctx.shape:
            raise SuiteError(Problem(f"{self.name} returned a value of shape {result.shape}; the observation's "
                                     f"shape is {self.ctx.shape}", loc=self.loc))
        np.copyto(dst, result, casting="unsafe")
