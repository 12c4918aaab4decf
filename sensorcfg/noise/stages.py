"""Runtime noise stages: precomputed arrays and one in-place step per sample. Numpy only.

A stage is built once per sensor from its config, with every parameter already broadcast to the
observation's shape (`Params`). `reset(rng)` makes the per-episode draws; `stage(src, dst, step)` writes the
noisy version of `src` into `dst` (they may be the same array; `src` is never written when it is not `dst`).
Per-sample random numbers are drawn for many samples at once (`_BLOCK_VALUES` values per generator call),
so a white-noise stage costs one ufunc call per sample; the stream is still fixed by the seed alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import Problem, SuiteError

__all__ = ["Context", "Stage", "Sum", "Gaussian", "Uniform", "Outlier", "EpisodeDraw", "RandomWalk", "Lowpass",
           "Quantize", "Clip", "Dropout", "Custom"]

_BLOCK_VALUES = 1 << 14  # random values drawn per generator call (per stage), at most
_MAX_BLOCK = 256  # samples per block, at most
_MAX_INTERVALS = 64  # distinct sample intervals whose coefficients are cached


class Context:
    """What every stage is built against: the observation and the arithmetic it is noised in."""

    def __init__(self, shape: tuple[int, ...], dtype: np.dtype, work: np.dtype, timestep: float):
        self.shape = shape
        self.dtype = dtype  # the observation's
        self.work = work  # the stages' arithmetic: float64, or float32 for float32 / uint8 observations
        self.timestep = timestep
        size = math.prod(shape)
        self.block = max(1, min(_MAX_BLOCK, _BLOCK_VALUES // max(size, 1)))

    def cast(self, value: Any) -> np.ndarray:
        """A parameter as an array of the work dtype (0-d for a number): ufuncs take arrays faster than
        Python floats, which they convert on every call."""
        return np.array(value, dtype=self.work)


class Stage:
    """One stage at run time."""

    needs_rng = False
    # how many configured stages this one carries out (see `Sum`); Uniform reuses the name for high - low
    width: int | np.ndarray = 1

    def reset(self, rng: np.random.Generator | None) -> None:
        """Start an episode: per-episode draws, cleared state."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        raise NotImplementedError


class _PerSample(Stage):
    """A stage that needs fresh random numbers for every sample, drawn `ctx.block` samples at a time."""

    needs_rng = True

    def __init__(self, ctx: Context):
        self.ctx = ctx
        self.rows: list[Any] = []
        self.k = 0
        self.rng: np.random.Generator | None = None

    def draw(self, rng: np.random.Generator, count: int) -> Any:
        """Random numbers for `count` samples (an array with a leading axis of `count`, or a list)."""
        raise NotImplementedError

    def reset(self, rng: np.random.Generator | None) -> None:
        self.rng = rng
        self.rows = []
        self.k = 0

    def refill(self) -> None:
        block = self.draw(self.rng, self.ctx.block)  # type: ignore[arg-type]
        if isinstance(block, np.ndarray):  # one writable view per sample (0-d views for scalar observations)
            self.rows = list(block) if block.ndim > 1 else [block[i, ...] for i in range(len(block))]
        else:
            self.rows = block
        self.k = 0


class _Additive(_PerSample):
    """Adds a fresh array per sample (gaussian, uniform, outlier)."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        k = self.k
        if k == len(self.rows):
            self.refill()
            k = 0
        self.k = k + 1
        np.add(src, self.rows[k], out=dst)


class Sum(_Additive):
    """Adjacent additive stages (white noise and per-episode bias) fused: one addition per sample.

    Each part keeps its own generator and draws exactly what it would alone; only the order of the
    floating-point additions changes (x + (a + b) instead of (x + a) + b).
    """

    def __init__(self, ctx: Context, parts: list[Stage]):
        super().__init__(ctx)
        self.parts = parts
        self.width = len(parts)

    def reset_parts(self, rngs: list[np.random.Generator | None]) -> None:
        for part, rng in zip(self.parts, rngs):
            part.reset(rng)
        self.rows = []
        self.k = 0

    def draw(self, rng: Any, count: int) -> np.ndarray:
        total = np.zeros((count, *self.ctx.shape), self.ctx.work)
        for part in self.parts:
            total += part.value if isinstance(part, EpisodeDraw) else part.draw(part.rng, count)  # type: ignore[attr-defined]
        return total


class Gaussian(_Additive):
    def __init__(self, ctx: Context, mean: Any, std: Any):
        super().__init__(ctx)
        self.mean, self.std = ctx.cast(mean), ctx.cast(std)

    def draw(self, rng: np.random.Generator, count: int) -> np.ndarray:
        z = rng.standard_normal((count, *self.ctx.shape), dtype=self.ctx.work)
        z *= self.std
        z += self.mean
        return z


class Uniform(_Additive):
    def __init__(self, ctx: Context, low: Any, high: Any):
        super().__init__(ctx)
        self.low, self.width = ctx.cast(low), ctx.cast(np.subtract(high, low))

    def draw(self, rng: np.random.Generator, count: int) -> np.ndarray:
        u = rng.random((count, *self.ctx.shape), dtype=self.ctx.work)
        u *= self.width
        u += self.low
        return u


class Outlier(_Additive):
    def __init__(self, ctx: Context, p: Any, scale: Any):
        super().__init__(ctx)
        self.p, self.scale = p, ctx.cast(scale)

    def draw(self, rng: np.random.Generator, count: int) -> np.ndarray:
        shape = (count, *self.ctx.shape)
        hit = rng.random(shape) < self.p
        jump = rng.standard_normal(shape, dtype=self.ctx.work)
        jump *= self.scale
        jump[~hit] = 0
        return jump


class EpisodeDraw(Stage):
    """Bias (add) or scale (multiply): one draw per value at reset, from N(mean, std^2) or U(low, high)."""

    needs_rng = True

    def __init__(self, ctx: Context, op: Callable[..., Any], normal: tuple[Any, Any] | None,
                 uniform: tuple[Any, Any] | None):
        self.ctx, self.op, self.normal, self.uniform = ctx, op, normal, uniform
        self.value = np.zeros(ctx.shape, ctx.work)

    def reset(self, rng: np.random.Generator | None) -> None:
        assert rng is not None
        if self.uniform is not None:
            low, high = self.uniform
            draw = low + (np.subtract(high, low)) * rng.random(self.ctx.shape)
        else:
            mean, std = self.normal  # type: ignore[misc]
            draw = mean + std * rng.standard_normal(self.ctx.shape)
        self.value[...] = draw

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        self.op(src, self.value, out=dst)


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


class RandomWalk(_PerSample):
    """b <- a b + c z per sample, a = exp(-dt/tau), c = std sqrt(1 - a^2); Brownian: a = 1, c = std sqrt(dt)."""

    def __init__(self, ctx: Context, std: Any, tau: Any):
        super().__init__(ctx)
        self.std, self.tau = std, tau
        self.state = np.zeros(ctx.shape, ctx.work)
        self.coef = _Timed(ctx, self._coefficients)
        self.last = 0

    def _coefficients(self, dt: float) -> tuple[Any, Any]:
        if self.tau is None:
            return None, self.ctx.cast(np.multiply(self.std, math.sqrt(dt)))
        a = np.exp(-dt / np.asarray(self.tau))
        c = np.multiply(self.std, np.sqrt(-np.expm1(-2.0 * dt / np.asarray(self.tau))))
        return self.ctx.cast(a), self.ctx.cast(c)

    def draw(self, rng: np.random.Generator, count: int) -> np.ndarray:
        return rng.standard_normal((count, *self.ctx.shape), dtype=self.ctx.work)

    def reset(self, rng: np.random.Generator | None) -> None:
        assert rng is not None
        if self.tau is None:
            self.state[...] = 0
        else:  # the stationary distribution, drawn before any per-sample block
            self.state[...] = np.multiply(self.std, rng.standard_normal(self.ctx.shape))
        self.last = 0
        super().reset(rng)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        steps = step - self.last
        if steps:
            a, c = self.coef(steps)
            self.last = step
            k = self.k
            if k == len(self.rows):
                self.refill()
                k = 0
            self.k = k + 1
            z = self.rows[k]  # used once: scaled in place
            np.multiply(z, c, out=z)
            state = self.state
            if a is not None:
                np.multiply(state, a, out=state)
            np.add(state, z, out=state)
        np.add(src, self.state, out=dst)


class Lowpass(Stage):
    """y <- y + alpha (x - y), alpha = 1 - exp(-2 pi cutoff dt); starts settled at the first sample.

    A NaN input (a `dropout` with mode nan placed before it) stays in the state for the rest of the episode,
    as it would in a real filter fed NaN: put such a dropout after the filter.
    """

    def __init__(self, ctx: Context, cutoff: Any):
        omega = np.multiply(2.0 * math.pi, cutoff)
        self.alpha = _Timed(ctx, lambda dt: ctx.cast(-np.expm1(-dt * omega)))
        self.state = np.zeros(ctx.shape, ctx.work)
        self.fresh = True
        self.last = 0

    def reset(self, rng: np.random.Generator | None) -> None:
        self.fresh = True

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        state = self.state
        if self.fresh:
            self.fresh = False
            np.copyto(state, src, casting="unsafe")
        else:
            steps = step - self.last
            if steps:
                alpha = self.alpha(steps)
                np.subtract(src, state, out=dst)
                np.multiply(dst, alpha, out=dst)
                np.add(state, dst, out=state)
        self.last = step
        np.copyto(dst, state)


class Quantize(Stage):
    def __init__(self, ctx: Context, step: Any):
        self.step = ctx.cast(step)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        np.divide(src, self.step, out=dst)
        np.rint(dst, out=dst)
        np.multiply(dst, self.step, out=dst)


class Clip(Stage):
    def __init__(self, ctx: Context, low: Any, high: Any):
        self.low = None if low is None else ctx.cast(low)
        self.high = None if high is None else ctx.cast(high)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        if self.low is not None:
            np.maximum(src, self.low, out=dst)
            src = dst
        if self.high is not None:
            np.minimum(src, self.high, out=dst)


class Dropout(_PerSample):
    """Lost samples (or values): hold the last delivered one, or give 0 or NaN."""

    def __init__(self, ctx: Context, p: Any, mode: str, per_value: bool):
        super().__init__(ctx)
        self.p, self.mode, self.per_value = p, mode, per_value
        self.fill = {"zero": 0.0, "nan": math.nan}.get(mode)
        self.held = np.zeros(ctx.shape, ctx.work) if mode == "hold" else None
        self.fresh = True

    def draw(self, rng: np.random.Generator, count: int) -> Any:
        if self.per_value:
            return rng.random((count, *self.ctx.shape)) < self.p
        return (rng.random(count) < self.p).tolist()

    def reset(self, rng: np.random.Generator | None) -> None:
        super().reset(rng)
        self.fresh = True

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        k = self.k
        if k == len(self.rows):
            self.refill()
            k = 0
        self.k = k + 1
        lost = self.rows[k]
        held = self.held
        if self.fresh:  # nothing delivered yet: the first sample always is
            self.fresh = False
            if held is not None:
                lost = False if not self.per_value else np.zeros_like(lost)
        if not self.per_value:
            if lost:
                if held is not None:
                    np.copyto(dst, held)
                else:
                    dst.fill(self.fill)  # type: ignore[arg-type]
                return
            if dst is not src:
                np.copyto(dst, src)
        else:
            if dst is not src:
                np.copyto(dst, src)
            np.copyto(dst, held if held is not None else self.fill, where=lost)  # type: ignore[arg-type]
        if held is not None:
            np.copyto(held, dst)


class Custom(Stage):
    """A dm_control corruptor `f(value, random_state=...)`, given values in the observation's dtype."""

    needs_rng = True

    def __init__(self, ctx: Context, fn: Callable[..., Any], name: str, loc: str):
        self.ctx, self.fn, self.name, self.loc = ctx, fn, name, loc
        self.convert = ctx.work != ctx.dtype
        self.random_state = np.random.RandomState(0)

    def reset(self, rng: np.random.Generator | None) -> None:
        assert rng is not None
        self.random_state = np.random.RandomState(np.random.MT19937(rng.integers(0, 2**32, size=4)))

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
