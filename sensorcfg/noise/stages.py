"""Runtime noise stages: each stage's arithmetic and random numbers, written once. Numpy only.

A stage is built once per sensor from its config, with every parameter already broadcast to the
observation's shape. `reset(streams, stride)` makes the per-episode draws; `stage(src, dst, step)` writes
the noisy version of `src` into `dst` (they may be the same array; `src` is never written when it is not
`dst`). The per-sample pipeline, the feature bank and the batch all call the same arithmetic: the array
functions of `noise.arithmetic` (`add`, `multiply`, `walk`, `lowpass`, `quantize`, `clip`, `dropout`), over
any leading axes (one sample, samples, or simulations x samples), and the same numbers (`noise.streams`).

Truthful noise: a sample's value is a function of the seed, the sensor and the sample's time, never of
which other samples were taken.

- Random numbers are counter-based (`noise.streams`): value v of sample j of a stage is a function of the
  sensor's episode key, j, the stage and v alone (Philox4x32-10 at a counter made of them), so any set of
  samples, of any keys, is drawn in one call without the others (`streams.numbers`): the bank and the
  batch draw only the samples taken; the per-sample path draws a block of B samples ahead
  (`Context.block`, a matter of speed only).
- A sample's index is `step // stride`: `stride` is the sensor's interval when it is constant (sample j is
  the sensor's j-th nominal sample), else 1 (the physics step).
- A random walk's state is advanced over every index (a block at a time), whether or not its samples
  are taken: it depends on draws only, not on the signal.
- Stages that need the raw value of every nominal sample (`stateful`: low-pass, dropout holding the last
  value, a custom callable with its own random state) make their sensor take every nominal sample.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike

from .arithmetic import add, dropout, multiply, outlier, scaled, walk, walk_coefficients, width
from .base import Context, Stage, _Timed
from .filters import Clip, Custom, Lowpass, Quantize
from .streams import MAX_TERMS, Affine, Draw, ResetDraw, Streams, draw_episode, numbers, stream_key

__all__ = ["Context", "Streams", "Stage", "Sum", "Gaussian", "Uniform", "Outlier", "EpisodeDraw", "RandomWalk",
           "Lowpass", "Quantize", "Clip", "Dropout", "Custom", "stream_key", "start_draw", "value_draw"]


class _PerSample(Stage):
    """A stage with fresh random numbers for every sample (`streams.numbers`: any samples, any keys, at
    once). The per-sample path draws a block of B samples at a time (`Context.block`, a matter of speed
    only: a sample's numbers do not depend on the block)."""

    needs_rng = True
    lanes: tuple[bool, ...] = (True,)  # per lane: normals (True) or uniforms; (m, size) numbers each (`sizes`)

    def __init__(self, ctx: Context):
        self.ctx = ctx
        self.size = math.prod(ctx.shape)
        self.streams: Streams | None = None
        self.stride = 1
        self.block_id = -1
        self.rows: list[np.ndarray] | np.ndarray = []  # the current block's rows (a list of views, or the block)

    def sizes(self) -> tuple[int, ...]:
        """Values per sample of each lane."""
        return (self.size,) * len(self.lanes)

    def draws(self, samples: np.ndarray, keys: np.ndarray) -> list[Draw]:
        """What `shape` needs for samples `samples` of keys `keys` (m, 2)."""
        return [Draw(keys, samples, self.stream, lane, size, normal)
                for lane, (size, normal) in enumerate(zip(self.sizes(), self.lanes))]

    def shape(self, raw: list[np.ndarray], m: int) -> np.ndarray:
        """The rows (m, *shape) from the drawn numbers of each lane."""
        raise NotImplementedError

    def affine(self) -> list[Affine] | None:
        """Where `shape` is, lane by lane, numbers x scale (+ offset) added up in float64 (`streams.add_sums`
        computes it in one pass): those terms; else None."""
        return None

    def reset(self, streams: Streams | None, stride: int) -> None:
        self.streams = streams
        self.stride = stride
        self.block_id = -1
        self.rows = []

    def numbers(self, samples: np.ndarray, keys: np.ndarray | None = None,
                values: list[np.ndarray] | None = None) -> np.ndarray:
        """The per-sample numbers of samples `samples` (m, *shape), of the episode keys `keys` ((m, 2) or
        (1, 2); this episode's when None)."""
        samples = np.asarray(samples, np.int64)
        keys = self.streams.keys if keys is None else keys  # type: ignore[union-attr]
        keys = np.broadcast_to(keys, (samples.size, 2))
        return np.asarray(self.shape(numbers(self.draws(samples, keys)), samples.size))

    def block_rows(self, block: int) -> np.ndarray:
        """What each sample of `block` uses (block, *shape); subclasses with state override it."""
        size = self.ctx.block
        return self.numbers(np.arange(block * size, (block + 1) * size))

    def row(self, step: int) -> np.ndarray:
        """This sample's row (a view into the current block)."""
        block, j = divmod(step // self.stride, self.ctx.block)
        if block != self.block_id:
            rows = self.block_rows(block)
            # one writable view per sample (0-d views for scalar observations)
            self.rows = list(rows) if rows.ndim > 1 else [rows[i, ...] for i in range(len(rows))]
            self.block_id = block
        return self.rows[j]


class _Additive(_PerSample):
    """Adds a fresh array per sample (gaussian, uniform, outlier, their sums, a random walk's state)."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        add(src, self.row(step), dst)


class Sum(_Additive):
    """Adjacent additive stages (white noise and per-episode bias) fused: one addition per sample.

    Each part keeps its own stream and draws exactly what it would alone; only the order of the
    floating-point additions changes (x + (a + b) instead of (x + a) + b).
    """

    def __init__(self, ctx: Context, parts: list[Stage]):
        super().__init__(ctx)
        self.parts = parts
        self.width = len(parts)
        self.drawing = [p for p in parts if isinstance(p, _PerSample)]
        self.lanes = tuple(lane for p in self.drawing for lane in p.lanes)

    def reset(self, streams: Streams | None, stride: int) -> None:
        for part in self.parts:
            part.reset(streams, stride)
        super().reset(streams, stride)

    def draws(self, samples: np.ndarray, keys: np.ndarray) -> list[Draw]:
        return [d for part in self.drawing for d in part.draws(samples, keys)]

    def numbers(self, samples: np.ndarray, keys: np.ndarray | None = None,
                values: list[np.ndarray] | None = None) -> np.ndarray:
        """The parts' numbers added in order; `values` replaces the episode draws of the bias parts (each
        sample's, (m, *shape), in the batch)."""
        samples = np.asarray(samples, np.int64)
        keys = np.broadcast_to(self.streams.keys if keys is None else keys,  # type: ignore[union-attr]
                               (samples.size, 2))
        return self.shape(numbers(self.draws(samples, keys)), samples.size, values)

    def affine(self) -> list[Affine] | None:
        terms = [p.affine() if isinstance(p, _PerSample) else None for p in self.parts]
        if any(t is None for t in terms):
            return None
        flat = [a for t in terms for a in cast(list[Affine], t)]
        return flat if len(flat) <= MAX_TERMS else None

    def shape(self, raw: list[np.ndarray], m: int, values: list[np.ndarray] | None = None) -> np.ndarray:
        total: np.ndarray | None = None
        episode = iter(values if values is not None else [p.value for p in self.parts if isinstance(p, EpisodeDraw)])
        at = 0
        for part in self.parts:
            if isinstance(part, _PerSample):
                term = part.shape(raw[at:at + len(part.lanes)], m)
                at += len(part.lanes)
            else:
                term = next(episode)
            if total is None:  # the first part's numbers (a fresh array), or zeros plus the first episode draw
                total = term if isinstance(part, _PerSample) else np.zeros((m, *self.ctx.shape), self.ctx.work) + term
            else:
                total += term
        return cast(np.ndarray, total)


def _affine(ctx: Context, scale: ArrayLike, offset: ArrayLike | None) -> list[Affine] | None:
    """One lane's term x scale (+ offset), each parameter flattened to the sample's values (float64 only)."""
    if ctx.work != np.float64:
        return None

    def flat(p: ArrayLike) -> np.ndarray:
        return np.ascontiguousarray(np.broadcast_to(np.asarray(p, np.float64), ctx.shape)).ravel()

    return [Affine(flat(scale), None if offset is None else flat(offset))]


def _fresh(raw: np.ndarray, m: int, ctx: Context) -> np.ndarray:
    """Drawn numbers as a new (m, *shape) array of the work dtype."""
    return np.array(raw.reshape(m, *ctx.shape), dtype=ctx.work)


class Gaussian(_Additive):
    def __init__(self, ctx: Context, mean: ArrayLike, std: ArrayLike):
        super().__init__(ctx)
        self.mean, self.std = ctx.cast(mean), ctx.cast(std)
        self.centred = not np.any(self.mean)

    def affine(self) -> list[Affine] | None:
        return _affine(self.ctx, self.std, None if self.centred else self.mean)

    def shape(self, raw: list[np.ndarray], m: int) -> np.ndarray:
        return scaled(_fresh(raw[0], m, self.ctx), self.std, None if self.centred else self.mean)


class Uniform(_Additive):
    lanes = (False,)

    def __init__(self, ctx: Context, low: ArrayLike, high: ArrayLike):
        super().__init__(ctx)
        self.low, self.width = ctx.cast(low), ctx.cast(width(low, high))

    def affine(self) -> list[Affine] | None:
        return _affine(self.ctx, self.width, self.low)

    def shape(self, raw: list[np.ndarray], m: int) -> np.ndarray:
        return scaled(_fresh(raw[0], m, self.ctx), self.width, self.low)


class Outlier(_Additive):
    lanes = (False, True)  # hits, jumps

    def __init__(self, ctx: Context, p: ArrayLike, scale: ArrayLike):
        super().__init__(ctx)
        self.p, self.scale = p, ctx.cast(scale)

    def shape(self, raw: list[np.ndarray], m: int) -> np.ndarray:
        return outlier(raw[0].reshape(m, *self.ctx.shape), _fresh(raw[1], m, self.ctx), self.p, self.scale)


def _values(param: ArrayLike, shape: tuple[int, ...]) -> np.ndarray:
    """A parameter broadcast to the values of one sample, raveled (float64)."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(param, np.float64), shape)).ravel()


def value_draw(stream: int, shape: tuple[int, ...], normal: tuple[Any, Any] | None,
               uniform: tuple[Any, Any] | None) -> ResetDraw:
    """A bias's or scale's values drawn at each reset (one per value of a sample of `shape`): mean + std z from
    `normal` (mean, std), else low + (high - low) u from `uniform` (low, high)."""
    if uniform is not None:
        low, high = uniform
        return ResetDraw(stream, 1, False, _values(width(low, high), shape), _values(low, shape))
    mean, std = normal  # type: ignore[misc]
    return ResetDraw(stream, 1, True, _values(std, shape), _values(mean, shape))


class EpisodeDraw(Stage):
    """Bias (add) or scale (multiply): one draw per value at reset, from N(mean, std^2) or U(low, high)."""

    needs_rng = True

    def __init__(self, ctx: Context, op: Callable[..., Any], normal: tuple[Any, Any] | None,
                 uniform: tuple[Any, Any] | None):
        self.ctx, self.op, self.normal, self.uniform = ctx, op, normal, uniform
        self.value = np.zeros(ctx.shape, ctx.work)
        self.draw = value_draw(0, ctx.shape, normal, uniform)

    def reset(self, streams: Streams | None, stride: int) -> None:
        assert streams is not None
        self.value[...] = draw_episode(self.draw._replace(stream=self.stream), streams).reshape(self.ctx.shape)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        (add if self.op is np.add else multiply)(src, self.value, dst)


def start_draw(stream: int, shape: tuple[int, ...], std: ArrayLike, tau: ArrayLike | None) -> ResetDraw | None:
    """A random walk's start drawn at each reset: std z, its stationary distribution (a Gauss-Markov walk);
    None for a Brownian walk (tau None), which starts at 0."""
    return None if tau is None else ResetDraw(stream, 1, True, _values(std, shape), None)


class RandomWalk(_Additive):
    """b_j = a b_(j-1) + c z_j over every sample index j, a = exp(-dt/tau), c = std sqrt(1 - a^2) with dt the
    stride's time; Brownian: a = 1, c = std sqrt(dt). The state at a sample's index is added to it."""

    def __init__(self, ctx: Context, std: ArrayLike, tau: ArrayLike | None):
        super().__init__(ctx)
        self.std, self.tau = std, tau
        self.start = np.zeros(ctx.shape, ctx.work)
        self.carry = np.zeros(ctx.shape, ctx.work)
        self.coef = _Timed(ctx, self._coefficients)
        self.draw = start_draw(0, ctx.shape, std, tau)
        self.last = 0  # the newest block whose states `carry` ends
        self.newest = 0

    def _coefficients(self, dt: float) -> tuple[np.ndarray | None, np.ndarray]:
        a, c = walk_coefficients(self.std, self.tau, dt)
        return (None if a is None else self.ctx.cast(a)), self.ctx.cast(c)

    def shape(self, raw: list[np.ndarray], m: int) -> np.ndarray:
        return _fresh(raw[0], m, self.ctx)

    def reset(self, streams: Streams | None, stride: int) -> None:
        assert streams is not None
        if self.draw is None:
            self.start[...] = 0
        else:  # the stationary distribution
            self.start[...] = draw_episode(self.draw._replace(stream=self.stream), streams).reshape(self.ctx.shape)
        self.carry[...] = self.start
        self.last = -1
        self.newest = 0  # the latest step asked for (the per-sample path goes forward only)
        super().reset(streams, stride)

    def block_rows(self, block: int) -> np.ndarray:
        if block <= self.last:
            raise ValueError(f"noise pipeline called at an earlier step (block {block} after {self.last}); "
                             "call reset() at the start of an episode")
        a, c = self.coef(self.stride)
        states = np.empty(0)
        while self.last < block:  # every index is walked, whether or not its samples are taken
            self.last += 1
            states = walk(self.carry, super().block_rows(self.last), a, c, self.last == 0)
        return states

    def row(self, step: int) -> np.ndarray:
        if step < self.newest:
            raise ValueError(f"noise pipeline called at an earlier step ({step - self.newest} steps back); "
                             "call reset() at the start of an episode")
        self.newest = step
        return super().row(step)

class Dropout(_PerSample):
    """Lost samples (or values): hold the last delivered one, or give 0 or NaN."""

    def __init__(self, ctx: Context, p: ArrayLike, mode: str, per_value: bool):
        super().__init__(ctx)
        self.p, self.mode, self.per_value = p, mode, per_value
        self.fill = {"zero": 0.0, "nan": math.nan}.get(mode)
        self.held = np.zeros(ctx.shape, ctx.work) if mode == "hold" else None
        self.stateful = mode == "hold"  # holding needs the previous sample, whichever it was
        self.fresh = True

    lanes = (False,)

    def sizes(self) -> tuple[int, ...]:
        return (self.size if self.per_value else 1,)

    def shape(self, raw: list[np.ndarray], m: int) -> np.ndarray:
        if self.per_value:
            return raw[0].reshape(m, *self.ctx.shape) < self.p
        return raw[0][:, 0] < self.p

    def reset(self, streams: Streams | None, stride: int) -> None:
        super().reset(streams, stride)
        self.fresh = True

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        lost = self.row(step)
        held = self.held
        if self.fresh:  # nothing delivered yet: the first sample always is
            self.fresh = False
            if held is not None:
                lost = np.zeros_like(lost)
        dropout(src, lost, held if held is not None else self.fill, dst)
        if held is not None:
            np.copyto(held, dst)
