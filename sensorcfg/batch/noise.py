"""Noise pipelines across simulations: one stream per (simulation, sensor), vectorised per sample.

A sensor's single-simulation `NoisePipeline` stays the authority on randomness: at simulation i's reset it
is reset with that simulation's sensor stream (so every per-episode draw and every stage generator is
exactly the single simulation's), and a copy of each stage is kept for simulation i. On the per-step path
a batched stage applies to the simulations that sample at this step, all at once: per-sample random
numbers come from per-simulation blocks drawn by simulation i's own stage copy (the single-simulation
`draw`, `ctx.block` samples at a time), so only a refill, once per block, loops over simulations.
Stateful stages (random walk, low-pass, dropout with hold) keep their state as (nsim, ...) arrays.

A stage type without a batched form here (a custom callable) makes `BatchPipeline` raise before stepping.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..errors import SuiteError
from ..noise import stages as rt

__all__ = ["BatchPipeline", "BATCHED"]


class _Batched:
    """One stage across simulations; `template` is the sensor's own stage (stateless parts are shared)."""

    def __init__(self, template: rt.Stage, nsim: int):
        self.template = template
        self.nsim = nsim

    def load(self, i: int, stage: rt.Stage) -> None:
        """Take simulation i's episode start from `stage`, the template just reset with i's generators."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raise NotImplementedError


class _Stateless(_Batched):
    """Elementwise stages (quantize, clip): the single-simulation stage broadcasts over the leading axis."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.template(src, dst, 0)


_BLOCK_BYTES = 8 << 20  # pre-drawn random numbers per stage, across simulations, at most (when chunkable)


def _chunkable(stage: rt.Stage) -> bool:
    """Whether drawing `ctx.block` samples in smaller chunks gives the same numbers: a draw of one array per
    block from one stream is sequential; an outlier draws two arrays per block (hits, then jumps)."""
    if isinstance(stage, getattr(rt, "Sum", ())):
        return all(_chunkable(part) or isinstance(part, rt.EpisodeDraw) for part in cast(rt.Sum, stage).parts)
    return isinstance(stage, (rt.Gaussian, rt.Uniform, rt.RandomWalk, rt.Dropout))


def _fork(stage: Any) -> Any:
    """A copy of a just-reset stage that keeps drawing what it would: it shares the parameters and the
    generators (a reset binds new ones to the template), and owns what a reset writes in place."""
    clone = copy.copy(stage)
    parts = getattr(stage, "parts", None)
    if parts is not None:
        clone.parts = [_fork(part) for part in parts]
    value = getattr(stage, "value", None)
    if isinstance(value, np.ndarray):
        clone.value = value.copy()
    return clone


class _Blocks(_Batched):
    """Per-sample random numbers: each simulation's own block, refilled by its own copy of the stage.

    Where the stream allows (`_chunkable`), blocks are shorter than the single simulation's so that their
    memory stays bounded across thousands of simulations; the numbers are the same.
    """

    def __init__(self, template: rt._PerSample, nsim: int):
        super().__init__(template, nsim)
        block = template.ctx.block
        if _chunkable(template):
            per_sample = 8 * max(1, math.prod(template.ctx.shape)) * nsim
            block = max(1, min(block, _BLOCK_BYTES // per_sample))
        self.block = block
        self.copies: list[Any] = [None] * nsim
        self.k = np.full(nsim, self.block, np.intp)  # next row of each block; `block` means empty
        self.rows: np.ndarray | None = None

    def load(self, i: int, stage: rt.Stage) -> None:
        self.copies[i] = _fork(stage)  # its generator(s), positioned at the episode's start
        self.k[i] = self.block

    def take(self, sims: np.ndarray) -> np.ndarray:
        """This sample's random numbers for `sims`, (m, ...) (refilling the blocks that ran out)."""
        k = self.k[sims]
        empty = k == self.block
        if empty.any():
            for i in sims[empty]:  # once per `block` samples of a simulation
                stage = self.copies[i]
                drawn = np.asarray(stage.draw(getattr(stage, "rng", None), self.block))
                if self.rows is None:
                    self.rows = np.zeros((self.nsim, *drawn.shape), drawn.dtype)
                self.rows[i] = drawn
            k[empty] = 0
        rows = self.rows
        if sims.size == self.nsim and (k == k[0]).all():  # every simulation (sims is sorted), in step: a view
            self.k[:] = k[0] + 1
            return rows[:, k[0]]  # type: ignore[index]
        self.k[sims] = k + 1
        return rows[sims, k]  # type: ignore[index]


class _Additive(_Blocks):
    """White noise, outliers, and the fused sum of additive stages: one addition per sample."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        np.add(src, self.take(sims), out=dst)


class _Episode(_Batched):
    """Bias or scale: each simulation's per-episode draw."""

    def __init__(self, template: rt.EpisodeDraw, nsim: int):
        super().__init__(template, nsim)
        self.values = np.zeros((nsim, *template.value.shape), template.value.dtype)

    def load(self, i: int, stage: rt.Stage) -> None:
        self.values[i] = stage.value  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.template.op(src, self.values[sims], out=dst)  # type: ignore[attr-defined]


def _by_gap(gaps: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(gap, positions) for each distinct number of steps since a simulation's previous sample."""
    if gaps.size and (gaps == gaps[0]).all():
        return [(int(gaps[0]), np.arange(gaps.size))]
    return [(int(g), np.flatnonzero(gaps == g)) for g in np.unique(gaps)]


class _RandomWalk(_Blocks):
    def __init__(self, template: rt.RandomWalk, nsim: int):
        super().__init__(template, nsim)
        self.state = np.zeros((nsim, *template.state.shape), template.state.dtype)
        self.last = np.zeros(nsim, np.int64)

    def load(self, i: int, stage: rt.Stage) -> None:
        super().load(i, stage)
        self.state[i] = stage.state  # type: ignore[attr-defined]
        self.last[i] = stage.last  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        gaps = steps - self.last[sims]
        moving = np.flatnonzero(gaps)
        if moving.size:
            ms = sims[moving]
            z = self.take(ms)
            state = self.state[ms]
            for gap, at in _by_gap(gaps[moving]):
                a, c = self.template.coef(gap)  # type: ignore[attr-defined]
                zz = z[at]
                np.multiply(zz, c, out=zz)
                st = state[at]
                if a is not None:
                    np.multiply(st, a, out=st)
                np.add(st, zz, out=st)
                state[at] = st
            self.state[ms] = state
            self.last[ms] = steps[moving]
        np.add(src, self.state[sims], out=dst)


class _Lowpass(_Batched):
    def __init__(self, template: rt.Lowpass, nsim: int):
        super().__init__(template, nsim)
        self.state = np.zeros((nsim, *template.state.shape), template.state.dtype)
        self.fresh = np.ones(nsim, bool)
        self.last = np.zeros(nsim, np.int64)

    def load(self, i: int, stage: rt.Stage) -> None:
        self.fresh[i] = stage.fresh  # type: ignore[attr-defined]
        self.state[i] = stage.state  # type: ignore[attr-defined]
        self.last[i] = stage.last  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        state = self.state[sims]
        fresh = self.fresh[sims]
        if fresh.any():
            state[fresh] = src[fresh]
        gaps = steps - self.last[sims]
        moving = np.flatnonzero(~fresh & (gaps != 0))
        for gap, at in _by_gap(gaps[moving]):
            rows = moving[at]
            alpha = self.template.alpha(gap)  # type: ignore[attr-defined]
            d = np.subtract(src[rows], state[rows])
            np.multiply(d, alpha, out=d)
            state[rows] = np.add(state[rows], d)
        self.state[sims] = state
        self.fresh[sims] = False
        self.last[sims] = steps
        np.copyto(dst, state)


class _Dropout(_Blocks):
    def __init__(self, template: rt.Dropout, nsim: int):
        super().__init__(template, nsim)
        self.per_value = template.per_value
        self.fill = template.fill
        self.held = None if template.held is None else np.zeros((nsim, *template.held.shape), template.held.dtype)
        self.fresh = np.ones(nsim, bool)

    def load(self, i: int, stage: rt.Stage) -> None:
        super().load(i, stage)
        self.fresh[i] = stage.fresh  # type: ignore[attr-defined]
        if self.held is not None:
            self.held[i] = stage.held  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        lost = self.take(sims)
        fresh = self.fresh[sims]
        if fresh.any():
            self.fresh[sims] = False
            if self.held is not None:  # nothing delivered yet: the first sample always is
                lost = lost.copy()  # (it may be a view of the block)
                lost[fresh] = False
        if dst is not src:
            np.copyto(dst, src)
        if not self.per_value:
            lost = lost.reshape(lost.shape + (1,) * (dst.ndim - 1))
        held = self.held[sims] if self.held is not None else None
        np.copyto(dst, held if held is not None else cast(float, self.fill), where=lost)  # a fill without hold
        if self.held is not None:
            self.held[sims] = dst


# One row per runtime stage type (`sensorcfg.noise.stages`); a stage type missing here cannot be batched.
BATCHED: dict[type, Callable[[Any, int], _Batched]] = {
    rt.Gaussian: _Additive,
    rt.Uniform: _Additive,
    rt.Outlier: _Additive,
    rt.EpisodeDraw: _Episode,
    rt.RandomWalk: _RandomWalk,
    rt.Lowpass: _Lowpass,
    rt.Quantize: _Stateless,
    rt.Clip: _Stateless,
    rt.Dropout: _Dropout,
}
if hasattr(rt, "Sum"):  # fused adjacent additive stages
    BATCHED[rt.Sum] = _Additive


class BatchPipeline:
    """A sensor's noise pipeline for nsim simulations."""

    def __init__(self, pipeline: Any, nsim: int, sensor: str):
        self.pipeline = pipeline
        if np.dtype(pipeline.dtype) != np.float64:
            raise SuiteError(f"sensor {sensor!r}: its noise cannot be vectorised across simulations: the batch runs "
                             f"noise on float64 values, the observation is {np.dtype(pipeline.dtype)}")
        stages = tuple(pipeline.stages)  # the pipeline's runtime stages (after fusing)
        batched = []
        for stage in stages:
            make = BATCHED.get(type(stage))
            if make is None:
                kind = type(stage).__name__.lower()
                what = getattr(stage, "name", None)
                raise SuiteError(f"sensor {sensor!r}: its {kind} noise stage{f' ({what})' if what else ''} cannot be "
                                 "vectorised across simulations (it runs a Python callable once per sample and "
                                 "simulation); use it with the single-simulation Environment, or express it with "
                                 "built-in stages")
            batched.append(make(stage, nsim))
        self.stages = stages
        self.batched = batched
        self.shape = tuple(pipeline.shape)

    def reset(self, i: int, rng: np.random.Generator) -> None:
        """Start simulation i's episode with its sensor stream `rng` (as the Updater resets a pipeline)."""
        self.pipeline.reset(rng)
        for stage, batched in zip(self.stages, self.batched):
            batched.load(i, stage)

    def __call__(self, value: np.ndarray, sims: np.ndarray, steps: np.ndarray,
                 out: np.ndarray | None = None) -> np.ndarray:
        """The noisy samples (m, *shape) of simulations `sims` taken at their physics steps `steps`, in
        `out` when given (it may be `value` itself: every stage reads a value before writing it)."""
        dst = np.empty(value.shape, np.float64) if out is None else out
        src = value
        for stage in self.batched:
            stage(src, dst, sims, steps)
            src = dst
        return dst
