"""Noise programs across simulations: a sensor's `NoiseProgram` (the suite plan's) run on nsim simulations at once.

The program is all the batch reads of a sensor's noise. Each step's stage name picks its batched form (`BATCHED`:
`batch/additive.py`'s and `batch/steps.py`'s, on `batch/forms.py`'s base), which computes with the step's kernel
numbers, parameters and options and the program's `stride`, `sums` (adjacent additive steps fused: their terms
added up first, x + (a + b)), `leveled`, `bounds`, `timestep` and `gaps`, through the rules' one home:
`noise.arithmetic` (and `noise.misalign.turn`, `noise.level.blend`) for the arithmetic, `noise.streams` for the
numbers. The sensor's single-simulation `NoisePipeline`, which other environments share, is neither called nor
reset here.

At simulation i's reset the forms take what the program draws from i's sensor key (`plan.noise.episodes`: bias
and gain values, a random walk's start, a misalignment's matrix; a step with parameters drawn per episode
takes that episode's step, `StepEpisode.step`, and computes with its kernel numbers, one row per simulation).
On the per-step path a form applies to the simulations that sample at this step, all at once. Per-sample
numbers are counter-based (`noise.streams`): a function of simulation i's episode key and the sample's index
`step // stride`, so each control step draws those of the samples taken, of every sensor and simulation, in
one call (`prefetch`), and sample j of simulation i gets exactly the numbers the single simulation gives it.
Stateful forms (random walk, low-pass, dropout with hold) keep their state as (nsim, ...) arrays.

A step without a batched form (a custom callable, stage "custom") makes `BatchPipeline` raise before stepping.
"""

from __future__ import annotations

import types
from collections.abc import Callable, Mapping, Sequence
from typing import cast

import numpy as np

from ..refusals import batch_refusal
from ..errors import SuiteError
from ..noise.level import blend
from ..noise.pipeline import custom_name
from ..noise.streams import Draw, Sum, numbers
from ..plan.noise import episodes
from ..plan.records import NoiseProgram
from .additive import Additive
from .forms import Drawn, Form, Site
from .steps import Clip, Dropout, EpisodeValues, Lowpass, Misalign, Quantize, RandomWalk

__all__ = ["BATCHED", "BatchPipeline", "Fused", "Levels", "prefetch"]

_BLOCK_BYTES = 8 << 20  # a random walk's stored states per step, across simulations, at most

Fused = Additive  # a program's one additive form (a fused sum): added as a read or in place


# One row per stage name of the plan (`NoiseStep.stage`); a stage missing here (custom) cannot be batched. A run
# of adjacent additive steps (`NoiseProgram.sums`) is one `Additive` of their terms (`plan.terms`).
BATCHED: Mapping[str, Callable[[Site, int], Form]] = types.MappingProxyType({
    "gaussian": Additive,
    "uniform": Additive,
    "outlier": Additive,
    "bias": EpisodeValues,
    "scale": EpisodeValues,
    "random_walk": lambda site, nsim: RandomWalk(site, nsim, _BLOCK_BYTES),
    "lowpass": Lowpass,
    "quantize": Quantize,
    "clip": Clip,
    "dropout": Dropout,
    "misalign": Misalign,
})


class Levels:
    """Each simulation's noise level of its episode (`noise.level`: raw + level (noisy - raw)), and whether any
    is not 1 (`active`): the batch's own, never the sensor's pipeline's."""

    def __init__(self, nsim: int):
        self.levels = np.ones(nsim)
        self.active = False

    def set(self, ids: np.ndarray, level: float) -> None:
        """The level of the episodes of simulations `ids`, which start now."""
        self.levels[ids] = level
        self.active = bool(np.any(self.levels != 1.0))


def _forms(program: NoiseProgram, shape: tuple[int, ...], nsim: int) -> list[Form]:
    """The program's forms in order: one per step, one per fused sum (`NoiseProgram.sums`)."""
    sums = dict(program.sums)
    forms, j = [], 0
    while j < len(program.steps):
        stop = sums.get(j, j + 1)
        at = tuple(range(j, stop))
        make = Additive if len(at) > 1 else BATCHED[program.steps[j].stage]
        forms.append(make(Site(program, at, shape), nsim))
        j = stop
    return forms


class BatchPipeline:
    """A sensor's noise program (`program`, the plan's) for nsim simulations; `shape`: one sample's; `dtype`: the
    observation's (the batch noises float64 values only)."""

    def __init__(self, program: NoiseProgram, nsim: int, sensor: str, shape: tuple[int, ...],
                 dtype: np.dtype | type = np.float64):
        if np.dtype(dtype) != np.float64:
            raise SuiteError(f"sensor {sensor!r}: its noise cannot be vectorised across simulations: the batch runs "
                             f"noise on float64 values, the observation is {np.dtype(dtype)}")
        for step in program.steps:
            if step.stage not in BATCHED:
                reference = dict(step.options).get("callable")
                detail = f" ({custom_name(reference)})" if reference is not None else ""
                raise SuiteError(f"sensor {sensor!r}: " + batch_refusal("noise stage", kind=step.stage, detail=detail))
        self.program = program
        self.stride = program.stride
        self.forms = _forms(program, tuple(shape), nsim)
        # each simulation's noise level, set at each reset (`start`); None without a level
        self.levels = Levels(nsim) if program.leveled else None
        bounds = program.bounds
        self.bounds = None if bounds is None else (bounds[0].reshape(shape), bounds[1].reshape(shape))
        self._draws = any(s.episode is not None or s.redraw is not None for s in program.steps)
        only = self.forms[0] if len(self.forms) == 1 else None
        self._fusable = only if isinstance(only, Additive) and only.terms is not None else None

    @property
    def additive(self) -> Fused | None:
        """The fused sum when the program only adds numbers x scale (+ offset), at any noise level (a level other
        than 1 blends after it): a batch may add it as it reads (`batch.read_noise`)."""
        return self._fusable

    @property
    def fused(self) -> Fused | None:
        """`additive` while every simulation is at noise level 1 (in the history the sum is added in place, where
        a blend would need the raw values)."""
        blending = self.levels is not None and self.levels.active
        return None if blending else self.additive

    def sum(self, table: np.ndarray, lo: int, sims: np.ndarray, steps: np.ndarray) -> Sum:
        """The fused program's noise of `sims` at `steps`, added to table[sims, lo:...] (`streams.add_sums`)."""
        form = self.fused
        if form is None or form.terms is None:
            raise RuntimeError("BatchPipeline.sum of a program that is not a fused sum (the caller checks `fused`)")
        return Sum(form.draws(sims, steps), form.terms, table, lo, sims)

    def start(self, ids: np.ndarray, keys: np.ndarray, level: float = 1.0) -> None:
        """Start the episodes of simulations `ids` with their sensor keys (m, 2) at noise level `level` (the
        sensor's `LeveledPipeline.next_level`; 1 without a level): what each draws at its reset from its key
        (`plan.noise.episodes`, where the program draws anything)."""
        if not ids.size:
            return
        drawn = episodes(self.program, keys) if self._draws else []
        for form in self.forms:
            form.start(ids, keys, drawn)
        if self.levels is not None:
            self.levels.set(ids, level)

    def __call__(self, value: np.ndarray, sims: np.ndarray, steps: np.ndarray,
                 out: np.ndarray | None = None) -> np.ndarray:
        """The noisy samples (m, *shape) of simulations `sims` taken at their physics steps `steps`, in `out` when
        given (it may be `value` itself: every form reads a value before writing it). Where some simulation's
        level is not 1, the raw samples are kept first and blended with the result (`noise.level.blend`, within
        the program's `bounds`)."""
        dst = np.empty(value.shape, np.float64) if out is None else out
        levels = self.levels
        raw = value.copy() if levels is not None and levels.active else None
        src = value
        for form in self.forms:
            form(src, dst, sims, steps)
            src = dst
        if raw is not None:
            level = cast(Levels, levels).levels[sims].reshape((len(sims),) + (1,) * (value.ndim - 1))
            blend(raw, dst, level, dst, self.bounds)
        return dst


def prefetch(calls: Sequence[tuple[BatchPipeline, np.ndarray, np.ndarray]]) -> None:
    """Draw ahead the per-sample numbers of the pipeline calls (pipeline, sims, steps) that follow, in that
    order, from one Philox call over every sensor, step and simulation (`streams.numbers`). A random walk walks
    its own parts."""
    jobs: list[tuple[Drawn, np.ndarray, int, int]] = []
    draws: list[Draw] = []
    for pipeline, sims, steps in calls:
        for form in pipeline.forms:
            if isinstance(form, Drawn):
                drawn = form.draws(sims, steps)
                jobs.append((form, sims, len(draws), len(drawn)))
                draws.extend(drawn)
    raw = numbers(draws)
    for form, sims, at, count in jobs:
        form.ready.append(form.rows(sims, raw[at:at + count]))
