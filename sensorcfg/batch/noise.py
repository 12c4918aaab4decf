"""Noise pipelines across simulations: one counter-based stream per (simulation, sensor), vectorised.

The suite plan is the authority on each episode's start: at simulation i's reset its batched stages take
what the sensor's program draws from i's sensor key (`plan.noise.episodes`: bias and gain draws, a random
walk's start, parameters drawn per episode, a misalignment's matrix), and their kernel numbers (a walk's
coefficients, a low-pass's, a misalignment's matrix, the level's bounds) from its steps. The sensor's
single-simulation `NoisePipeline`, which other environments share, is never reset here. On the per-step
path a batched stage applies to the simulations that sample at this step, all at once, with the stages'
own array arithmetic (`noise.stages`). Per-sample numbers are counter-based (`noise.streams`): a function of
simulation i's episode key and the sample's index, so each control step draws those of the samples taken,
of every sensor and simulation, in one call (`prefetch`), and sample j of simulation i gets exactly the
numbers the single simulation gives it.
Stateful stages (random walk, low-pass, dropout with hold) keep their state as (nsim, ...) arrays.

A stage type without a batched form here (a custom callable) makes `BatchPipeline` raise before stepping.
"""

from __future__ import annotations

import math
import types
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast

import numpy as np

from ..checks import batch_refusal
from ..errors import SuiteError
from ..noise import arithmetic as ar
from ..noise import stages as rt
from ..noise.arithmetic import lowpass_alpha
from ..noise.level import Blend, Keep, LeveledPipeline
from ..noise.misalign import Misalign
from ..noise.redrawn import Redrawn
from ..noise.streams import Affine, Draw, Sum, numbers
from ..plan.noise import episodes
from ..plan.records import NoiseProgram
from .batched import Batched, Episodes, Site
from .level import BatchedBlend, BatchedKeep
from .misalign import BatchedMisalign
from .redrawn import BatchedRedrawn

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline

__all__ = ["BatchPipeline", "BATCHED", "prefetch"]

P = TypeVar("P", bound=rt._PerSample)  # a stage with per-sample numbers
A = TypeVar("A", bound=rt._Additive)  # one that adds them

_BLOCK_BYTES = 8 << 20  # a random walk's stored states per stage, across simulations, at most


class _Stateless(Batched[rt.Stage]):
    """Elementwise stages (quantize, clip): the single-simulation stage broadcasts over the leading axis."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.template(src, dst, 0)


class _Drawn(Batched[P], Generic[P]):
    """Per-sample numbers: each call draws those of the samples taken, of every simulation at once (the
    counter-based numbers are a function of the simulation's episode key and the sample index only)."""

    def __init__(self, template: P, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.keys = np.zeros((nsim, 2), np.uint64)
        self.ready: deque[np.ndarray] = deque()  # rows drawn ahead (`prefetch`), in the order of the calls

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.keys[ids] = keys
        self.ready.clear()

    def draws(self, sims: np.ndarray, steps: np.ndarray) -> list[Draw]:
        return self.template.draws(steps // self.stride, self.keys[sims])

    def shape(self, sims: np.ndarray, raw: list[np.ndarray]) -> np.ndarray:
        return self.template.shape(raw, sims.size)

    def take(self, sims: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """This sample's rows for `sims` at their `steps`, (m, ...): drawn ahead, or now."""
        if self.ready:
            return self.ready.popleft()
        return self.shape(sims, numbers(self.draws(sims, steps)))


class _Additive(_Drawn[A], Generic[A]):
    """White noise, outliers, and the fused sum of additive stages: one addition per sample."""

    def __init__(self, template: A, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        # per bias part of a sum: its step, and each simulation's draw
        self.biases = [at for at, p in zip(site.at, getattr(template, "parts", ())) if isinstance(p, rt.EpisodeDraw)]
        self.values = [np.zeros((nsim, *site.shape)) for _ in self.biases]
        # numbers x scale (+ offset), added up: added in place in one pass (`streams.add_sums`) where nothing
        # per episode joins
        self.terms: list[Affine] | None = None if self.values else template.affine()

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        super().start(ids, keys, drawn)
        for values, at in zip(self.values, self.biases):
            values[ids] = self.site.values(drawn, at)

    def shape(self, sims: np.ndarray, raw: list[np.ndarray]) -> np.ndarray:
        if self.values and isinstance(self.template, rt.Sum):  # (values: a sum's bias parts)
            return self.template.shape(raw, sims.size, [v[sims] for v in self.values])
        return super().shape(sims, raw)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        ar.add(src, self.take(sims, steps), dst)


Fused = _Additive[rt._Additive]  # a pipeline's one additive stage (a fused sum): added as a read or in place


class _RandomWalk(_Additive[rt.RandomWalk]):
    """The walk's states over every index, one part of `sub` indices at a time per simulation (walked
    together): part p holds indices [p sub, (p + 1) sub); sub is the block unless that would exceed
    `_BLOCK_BYTES` across simulations. Its coefficients are the step's kernel numbers (a Brownian walk's a:
    None, b_j = b_(j-1) + c z_j), its start the step's draw at each reset (0 for a Brownian walk)."""

    def __init__(self, template: rt.RandomWalk, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.carry = np.zeros((nsim, *site.shape))
        self.a = None if site.step.param("correlation_time") is None else site.number("a")
        self.c = site.number("c")
        sub = template.ctx.block
        per_sample = 8 * max(1, math.prod(site.shape)) * nsim
        while sub > 1 and sub * per_sample > _BLOCK_BYTES:
            sub //= 2
        self.sub = sub
        self.part = np.full(nsim, -1, np.int64)  # the part each simulation holds
        self.rows: np.ndarray | None = None  # (nsim, sub, *shape)

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        super().start(ids, keys, drawn)
        self.carry[ids] = 0.0 if self.site.step.episode is None else self.site.values(drawn)
        self.part[ids] = -1

    def take(self, sims: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """The walk's states at `steps`, (m, ...): the start at sample 0, else from the held parts (walking
        on to the parts that are due)."""
        if not steps.any():  # reset samples: the walk at sample 0 is its start
            start: np.ndarray = self.carry[sims]
            return start
        part, j = np.divmod(steps // self.stride, self.sub)
        stale = part != self.part[sims]
        if stale.any():
            fresh = self.draw(sims[stale], part[stale])
            if self.rows is None:
                self.rows = np.zeros((self.nsim, *fresh.shape[1:]), fresh.dtype)
            self.rows[sims[stale]] = fresh
            self.part[sims[stale]] = part[stale]
        rows = cast(np.ndarray, self.rows)
        if sims.size == self.nsim and (j == j[0]).all():  # every simulation (sims is sorted), in step: a view
            return rows[:, j[0]]
        taken: np.ndarray = rows[sims, j]
        return taken

    def draw(self, sims: np.ndarray, parts: np.ndarray) -> np.ndarray:
        """Walk each simulation from its held part to `parts` (every part in between, in order)."""
        a, c = self.a, self.c
        held = self.part[sims]
        if (parts < held).any():
            raise ValueError("a batched random walk was asked for an earlier sample")
        shape = self.site.shape
        out = np.empty((sims.size, self.sub, *shape))
        at = held + 1
        offsets = np.arange(self.sub)
        while True:
            moving = np.flatnonzero(at <= parts)
            if not moving.size:
                return out
            samples = (at[moving, None] * self.sub + offsets).ravel()
            z = self.template.numbers(samples, np.repeat(self.keys[sims[moving]], self.sub, axis=0))
            z = z.reshape(moving.size, self.sub, *shape)
            carry = self.carry[sims[moving]]
            for first in (True, False):  # the episode's first part starts at the drawn start itself
                rows = np.flatnonzero((at[moving] == 0) == first)
                if rows.size:
                    c_rows = carry[rows]
                    states = ar.walk(c_rows, np.moveaxis(z[rows], 1, 0), a, c, first)
                    carry[rows] = c_rows
                    out[moving[rows]] = np.moveaxis(states, 0, 1)
            self.carry[sims[moving]] = carry
            at[moving] += 1


class _Episode(Batched[rt.EpisodeDraw]):
    """Bias or scale: each simulation's per-episode draw."""

    def __init__(self, template: rt.EpisodeDraw, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.values = np.zeros((nsim, *site.shape))
        self.apply = ar.multiply if site.step.stage == "scale" else ar.add

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.values[ids] = self.site.values(drawn)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.apply(src, self.values[sims], dst)


def _by_gap(gaps: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(gap, positions) for each distinct number of steps since a simulation's previous sample."""
    if gaps.size and (gaps == gaps[0]).all():
        return [(int(gaps[0]), np.arange(gaps.size))]
    return [(int(g), np.flatnonzero(gaps == g)) for g in np.unique(gaps)]


class _Lowpass(Batched[rt.Lowpass]):
    """The filter's coefficient per gap between samples: the step's kernel numbers (`alpha` for samples a
    stride apart, `alphas` per gap of a drawn schedule); another gap's from its cutoff (`lowpass_alpha`)."""

    def __init__(self, template: rt.Lowpass, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.state = np.zeros((nsim, *site.shape))
        self.fresh = np.ones(nsim, bool)
        self.last = np.zeros(nsim, np.int64)
        kernel = dict(site.step.kernel)
        self.alphas = {gap: row.reshape(site.shape) for gap, row in enumerate(kernel.get("alphas", ()))}
        self.alphas[self.stride] = site.number("alpha")

    def alpha(self, gap: int) -> np.ndarray:
        alpha = self.alphas.get(gap)
        if alpha is None:
            program = self.site.program
            cutoff = self.site.step.param("cutoff")
            alpha = self.alphas[gap] = np.reshape(lowpass_alpha(cutoff, gap * program.timestep), self.site.shape)
        return alpha

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.fresh[ids] = True  # (the state and the last sample's step are set at its first sample)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        state = self.state[sims]
        fresh = self.fresh[sims]
        if fresh.any():
            state[fresh] = src[fresh]
        gaps = steps - self.last[sims]
        moving = np.flatnonzero(~fresh & (gaps != 0))
        for gap, at in _by_gap(gaps[moving]):
            rows = moving[at]
            s, d = state[rows], np.empty_like(state[rows])
            ar.lowpass(s, src[rows], self.alpha(gap), d)
            state[rows] = s
        self.state[sims] = state
        self.fresh[sims] = False
        self.last[sims] = steps
        np.copyto(dst, state)


class _Dropout(_Drawn[rt.Dropout]):
    def __init__(self, template: rt.Dropout, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.per_value = template.per_value
        self.fill = template.fill
        self.held = None if template.held is None else np.zeros((nsim, *site.shape))
        self.fresh = np.ones(nsim, bool)

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        super().start(ids, keys, drawn)
        self.fresh[ids] = True  # (the held values are set at its first sample, which is always delivered)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        lost = self.take(sims, steps)
        fresh = self.fresh[sims]
        if fresh.any():
            self.fresh[sims] = False
            if self.held is not None:  # nothing delivered yet: the first sample always is
                lost = lost.copy()  # (it may be a view of the block)
                lost[fresh] = False
        if not self.per_value:
            lost = lost.reshape(lost.shape + (1,) * (dst.ndim - 1))
        held = self.held[sims] if self.held is not None else None
        ar.dropout(src, lost, held if held is not None else cast(float, self.fill), dst)
        if self.held is not None:
            self.held[sims] = dst


# One row per runtime stage type (`sensorcfg.noise.stages`); a stage type missing here cannot be batched.
BATCHED: Mapping[type, Callable[[Any, Site, int], Batched[Any]]] = types.MappingProxyType({
    rt.Gaussian: _Additive,
    rt.Uniform: _Additive,
    rt.Outlier: _Additive,
    rt.Sum: _Additive,
    rt.EpisodeDraw: _Episode,
    rt.RandomWalk: _RandomWalk,
    rt.Lowpass: _Lowpass,
    rt.Quantize: _Stateless,
    rt.Clip: _Stateless,
    rt.Dropout: _Dropout,
    Keep: BatchedKeep,
    Blend: BatchedBlend,
    Misalign: BatchedMisalign,
    Redrawn: BatchedRedrawn,
})


def _steps(stage: rt.Stage) -> tuple[int, ...]:
    """The positions in its program of the steps a runtime stage runs: a fused sum's parts', none for the noise
    level's stages (`Keep`, `Blend`), else its own (its stream)."""
    if isinstance(stage, rt.Sum):
        return tuple(part.stream for part in stage.parts)
    return () if isinstance(stage, (Keep, Blend)) else (stage.stream,)


class BatchPipeline:
    """A sensor's noise pipeline for nsim simulations: its runtime stages (`pipeline`, the sensor's own, whose
    arithmetic the batched forms call and which the batch never resets) and its plan (`program`: each
    episode's start, kernel numbers, `stride`: its constant interval, 1 when drawn)."""

    def __init__(self, pipeline: NoisePipeline, program: NoiseProgram, nsim: int, sensor: str):
        self.program = program
        self.stride = program.stride
        if np.dtype(pipeline.dtype) != np.float64:
            raise SuiteError(f"sensor {sensor!r}: its noise cannot be vectorised across simulations: the batch runs "
                             f"noise on float64 values, the observation is {np.dtype(pipeline.dtype)}")
        shape = tuple(pipeline.shape)
        batched = []
        for stage in pipeline.stages:  # the pipeline's runtime stages (after fusing)
            make = BATCHED.get(type(stage))
            if make is None:
                what = getattr(stage, "name", None)
                raise SuiteError(f"sensor {sensor!r}: " + batch_refusal(
                    "noise stage", kind=type(stage).__name__.lower(), detail=f" ({what})" if what else ""))
            batched.append(make(stage, Site(program, _steps(stage), shape), nsim))
        for form in batched:
            form.link(batched)
        self.batched = batched
        # the sensor's level setting (`noise.level.set_level`), read at each reset; None without a level
        self._leveled = pipeline if isinstance(pipeline, LeveledPipeline) else None
        self._draws = any(s.episode is not None or s.redraw is not None for s in program.steps)
        # a pipeline that only adds numbers x scale (+ offset), but for the noise level's stages (which pass
        # values through while every simulation is at level 1): applied in place by `streams.add_sums`
        core = [b for b in batched if not isinstance(b.template, (Keep, Blend))]
        only = core[0] if len(core) == 1 else None
        self._fusable: Fused | None = only if isinstance(only, _Additive) and only.terms is not None else None
        self._blend = next((b for b in batched if isinstance(b, BatchedBlend)), None)

    @property
    def blend(self) -> BatchedBlend | None:
        """The pipeline's batched `Blend` (its per-simulation levels), None without a noise level."""
        return self._blend

    @property
    def additive(self) -> Fused | None:
        """The fused sum when the pipeline only adds numbers x scale (+ offset), at any noise level (a level
        other than 1 blends after it): a batch may add it as it reads (`batch.read_noise`)."""
        return self._fusable

    @property
    def fused(self) -> Fused | None:
        """`additive` while every simulation is at noise level 1 (in the history the sum is added in place,
        where a blend would need the raw values)."""
        blending = self._blend is not None and self._blend.active
        return None if blending else self.additive

    def sum(self, table: np.ndarray, lo: int, sims: np.ndarray, steps: np.ndarray) -> Sum:
        """The fused pipeline's noise of `sims` at `steps`, added to table[sims, lo:...] (`streams.add_sums`)."""
        stage = self.fused
        if stage is None or stage.terms is None:
            raise RuntimeError("BatchPipeline.sum of a pipeline that is not a fused sum (the caller checks `fused`)")
        return Sum(stage.draws(sims, steps), stage.terms, table, lo, sims)

    def start(self, ids: np.ndarray, keys: np.ndarray) -> None:
        """Start the episodes of simulations `ids` with their sensor keys (m, 2): what each draws at its reset
        from its key (`plan.noise.episodes`, where the program draws anything), at the sensor's level."""
        if not ids.size:
            return
        drawn = episodes(self.program, keys) if self._draws else []
        for form in self.batched:
            form.start(ids, keys, drawn)
        if self._blend is not None and self._leveled is not None:
            self._blend.set_level(ids, self._leveled.next_level)

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


def prefetch(calls: Sequence[tuple[BatchPipeline, np.ndarray, np.ndarray]]) -> None:
    """Draw ahead the per-sample numbers of the pipeline calls (pipeline, sims, steps) that follow, in
    that order, from one Philox call over every sensor, stage and simulation (`streams.numbers`). A
    random walk walks its own parts."""
    jobs: list[tuple[_Drawn[rt._PerSample], np.ndarray, int, int]] = []
    draws: list[Draw] = []
    for pipeline, sims, steps in calls:
        for stage in pipeline.batched:
            if isinstance(stage, _Drawn) and not isinstance(stage, _RandomWalk):
                drawn = stage.draws(sims, steps)
                jobs.append((stage, sims, len(draws), len(drawn)))
                draws.extend(drawn)
    raw = numbers(draws)
    for stage, sims, at, count in jobs:
        stage.ready.append(stage.shape(sims, raw[at:at + count]))
