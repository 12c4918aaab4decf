"""Noise programs across simulations: a sensor's `NoiseProgram` (the suite plan's) run on nsim simulations at once.

The program is all the batch reads of a sensor's noise. Each step's stage name picks its batched form (`BATCHED`),
which computes with the step's kernel numbers, parameters and options and the program's `stride`, `sums`
(adjacent additive steps fused: their terms added up first, x + (a + b)), `leveled`, `bounds`, `timestep` and
`gaps`, through the rules' one home: `noise.arithmetic` (and `noise.misalign.turn`, `noise.level.blend`) for the
arithmetic, `noise.streams` for the numbers. The sensor's single-simulation `NoisePipeline`, which other
environments share, is neither called nor reset here.

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

import math
import types
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple, cast

import numpy as np

from ..checks import batch_refusal
from ..errors import SuiteError
from ..noise import arithmetic as ar
from ..noise.base import block_samples
from ..noise.level import blend
from ..noise.misalign import turn
from ..noise.pipeline import custom_name
from ..noise.streams import MAX_TERMS, Affine, Draw, Sum, numbers
from ..plan.noise import StepEpisode, episodes
from ..plan.records import NoiseProgram, NoiseStep

__all__ = ["BATCHED", "BatchPipeline", "Fused", "Levels", "prefetch"]

_BLOCK_BYTES = 8 << 20  # a random walk's stored states per step, across simulations, at most

Episodes = Sequence[tuple[StepEpisode, ...]]  # per simulation started, what its program draws (`plan.noise.episode`)


class Site(NamedTuple):
    """Where a form sits in its sensor's program: the program, the positions of the steps it runs (one; a fused
    sum's parts) and one sample's shape."""

    program: NoiseProgram
    at: tuple[int, ...]
    shape: tuple[int, ...]

    @property
    def step(self) -> NoiseStep:
        """The form's (first) step."""
        return self.program.steps[self.at[0]]

    def values(self, drawn: Episodes, j: int) -> np.ndarray:
        """Step j's values drawn at this reset, one row per simulation started (m, *shape)."""
        return np.stack([np.asarray(episode[j].values) for episode in drawn]).reshape(len(drawn), *self.shape)


def _number(step: NoiseStep, name: str) -> np.ndarray | None:
    """A step's kernel number `name`, else its parameter of that name (None when it has neither)."""
    kernel = dict(step.kernel)
    return kernel[name] if name in kernel else step.param(name)


def _shaped(name: str, value: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A number as one sample's values (a misalign's matrix stays 3 x 3, a low-pass's `alphas` one row per gap)."""
    if name == "matrix":
        return value
    return value.reshape(-1, *shape) if name == "alphas" else value.reshape(shape)


class _Numbers:
    """One step's numbers of `names` (its kernel numbers, else its parameters) across simulations, each shaped as
    one sample: the program's, which every simulation shares; for a step with parameters drawn per episode
    (`NoiseStep.redraw`), one row per simulation, set at each reset from its episode's step."""

    def __init__(self, site: Site, j: int, nsim: int, names: Sequence[str]):
        step = site.program.steps[j]
        self.j, self.shape = j, site.shape
        self.per_sim = step.redraw is not None
        self.shared = {name: _shaped(name, value, site.shape) for name in names
                       if (value := _number(step, name)) is not None}
        self.rows = {name: np.repeat(value[None], nsim, axis=0) for name, value in self.shared.items()
                     } if self.per_sim else {}

    def __contains__(self, name: str) -> bool:
        return name in self.shared

    def start(self, ids: np.ndarray, drawn: Episodes) -> None:
        for name, rows in self.rows.items():
            rows[ids] = [_shaped(name, cast(np.ndarray, _number(episode[self.j].step, name)), self.shape)
                         for episode in drawn]

    def get(self, name: str, sims: np.ndarray) -> np.ndarray:
        """Number `name` of simulations `sims`: (m, ...) rows, or the shared one (broadcasting against them)."""
        return self.rows[name][sims] if self.per_sim else self.shared[name]


class _Form:
    """One step, or a fused run of additive steps, across simulations."""

    def __init__(self, site: Site, nsim: int):
        self.site, self.nsim, self.shape = site, nsim, site.shape
        self.stride = site.program.stride

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        """Start the episodes of simulations `ids` (m,) whose sensor keys are `keys` (m, 2); `drawn`: what the
        program draws at each one's reset (`plan.noise.episode`), empty when it draws nothing."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raise NotImplementedError


class _Drawn(_Form):
    """Per-sample numbers: each call draws those of the samples taken, of every simulation at once (a function of
    the simulation's episode key and the sample index only)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.keys = np.zeros((nsim, 2), np.uint64)
        self.ready: deque[np.ndarray] = deque()  # rows drawn ahead (`prefetch`), in the order of the calls

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.keys[ids] = keys
        self.ready.clear()

    def draws(self, sims: np.ndarray, steps: np.ndarray) -> list[Draw]:
        """What `rows` needs for the samples of `sims` at `steps`."""
        raise NotImplementedError

    def rows(self, sims: np.ndarray, raw: list[np.ndarray]) -> np.ndarray:
        """The rows (m, ...) of `sims` from the drawn numbers of each draw."""
        raise NotImplementedError

    def take(self, sims: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """This sample's rows for `sims` at their `steps`, (m, ...): drawn ahead, or now."""
        if self.ready:
            return self.ready.popleft()
        return self.rows(sims, numbers(self.draws(sims, steps)))


# -- additive steps: what each adds, alone or in a fused sum -----------------------------------------

class _Term:
    """What one additive step adds to a sample: its per-sample numbers of each lane (`lanes`: normals or
    uniforms), or a bias's values of the episode."""

    lanes: tuple[bool, ...] = ()
    names: tuple[str, ...] = ()  # the numbers it computes with

    def __init__(self, site: Site, j: int, nsim: int):
        self.site, self.j, self.shape = site, j, site.shape
        self.stream = site.program.steps[j].stream
        self.size = math.prod(site.shape)
        self.numbers = _Numbers(site, j, nsim, self.names)

    def sizes(self) -> tuple[int, ...]:
        """Values per sample of each lane."""
        return (self.size,) * len(self.lanes)

    def start(self, ids: np.ndarray, drawn: Episodes) -> None:
        self.numbers.start(ids, drawn)

    def __call__(self, raw: list[np.ndarray], sims: np.ndarray) -> np.ndarray:
        """The terms (m, *shape) of `sims` from their lanes' numbers: a new array where the step draws."""
        raise NotImplementedError

    def affine(self) -> list[Affine] | None:
        """Where the term is, lane by lane, numbers x scale (+ offset), the same for every simulation
        (`streams.add_sums` computes it in one pass): those terms; else None."""
        return None

    def fresh(self, raw: np.ndarray, m: int) -> np.ndarray:
        """Drawn numbers as a new (m, *shape) float64 array."""
        return np.array(raw.reshape(m, *self.shape), dtype=np.float64)

    def flat(self, name: str) -> np.ndarray:
        return np.ascontiguousarray(self.numbers.shared[name], np.float64).ravel()


class _Gaussian(_Term):
    """std z, plus the mean where it is not 0 (a centred gaussian adds std z alone)."""

    lanes = (True,)
    names = ("std", "mean")

    def __init__(self, site: Site, j: int, nsim: int):
        super().__init__(site, j, nsim)
        self.centred = not np.any(self.numbers.shared["mean"])

    def __call__(self, raw: list[np.ndarray], sims: np.ndarray) -> np.ndarray:
        z = self.fresh(raw[0], sims.size)
        z *= self.numbers.get("std", sims)
        mean = self.numbers.get("mean", sims)
        if not self.numbers.per_sim:
            if not self.centred:
                z += mean
            return z
        offset = np.any(mean.reshape(sims.size, -1), axis=1)  # each episode's own: centred or not
        if offset.all():
            z += mean
        elif offset.any():
            z[offset] += mean[offset]
        return z

    def affine(self) -> list[Affine] | None:
        if self.numbers.per_sim:
            return None
        return [Affine(self.flat("std"), None if self.centred else self.flat("mean"))]


class _Uniform(_Term):
    """low + width u."""

    lanes = (False,)
    names = ("low", "width")

    def __call__(self, raw: list[np.ndarray], sims: np.ndarray) -> np.ndarray:
        u = self.fresh(raw[0], sims.size)
        u *= self.numbers.get("width", sims)
        u += self.numbers.get("low", sims)
        return u

    def affine(self) -> list[Affine] | None:
        return None if self.numbers.per_sim else [Affine(self.flat("width"), self.flat("low"))]


class _Outlier(_Term):
    """scale z where a value is hit (its uniform, lane 0, below p), else 0; z from lane 1."""

    lanes = (False, True)  # hits, jumps
    names = ("p", "scale")

    def __call__(self, raw: list[np.ndarray], sims: np.ndarray) -> np.ndarray:
        hit = raw[0].reshape(sims.size, *self.shape) < self.numbers.get("p", sims)
        jump = self.fresh(raw[1], sims.size)
        jump *= self.numbers.get("scale", sims)
        jump[~hit] = 0
        return jump


class _Bias(_Term):
    """A bias's values of each simulation's episode."""

    def __init__(self, site: Site, j: int, nsim: int):
        super().__init__(site, j, nsim)
        self.values = np.zeros((nsim, *site.shape))

    def start(self, ids: np.ndarray, drawn: Episodes) -> None:
        self.values[ids] = self.site.values(drawn, self.j)

    def __call__(self, raw: list[np.ndarray], sims: np.ndarray) -> np.ndarray:
        term: np.ndarray = self.values[sims]
        return term


# the additive steps a sum fuses (`NoiseProgram.sums`), and a lone gaussian, uniform or outlier step
TERMS: Mapping[str, type[_Term]] = types.MappingProxyType({
    "gaussian": _Gaussian, "uniform": _Uniform, "outlier": _Outlier, "bias": _Bias})


class _Additive(_Drawn):
    """White noise, outliers, and a fused sum of additive steps: one addition per sample, of the steps' terms
    added up in order (the first drawn term itself, or zeros plus a first bias)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.parts = [TERMS[site.program.steps[j].stage](site, j, nsim) for j in site.at]
        self.drawing = [p for p in self.parts if p.lanes]
        terms = [p.affine() if p.lanes else None for p in self.parts]
        flat = [a for t in terms if t is not None for a in t]
        # numbers x scale (+ offset), added up: added in place in one pass (`streams.add_sums`) where nothing
        # per episode joins
        self.terms: list[Affine] | None = flat if None not in terms and len(flat) <= MAX_TERMS else None

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        super().start(ids, keys, drawn)
        for part in self.parts:
            part.start(ids, drawn)

    def draws(self, sims: np.ndarray, steps: np.ndarray) -> list[Draw]:
        samples, keys = steps // self.stride, self.keys[sims]
        return [Draw(keys, samples, p.stream, lane, size, normal)
                for p in self.drawing for lane, (size, normal) in enumerate(zip(p.sizes(), p.lanes))]

    def rows(self, sims: np.ndarray, raw: list[np.ndarray]) -> np.ndarray:
        total: np.ndarray | None = None
        at = 0
        for part in self.parts:
            term = part(raw[at:at + len(part.lanes)], sims)
            at += len(part.lanes)
            if total is None:  # the first part's numbers (a fresh array), or zeros plus a first bias
                total = term if part.lanes else np.zeros((sims.size, *self.shape)) + term
            else:
                total += term
        return cast(np.ndarray, total)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        ar.add(src, self.take(sims, steps), dst)


Fused = _Additive  # a program's one additive form (a fused sum): added as a read or in place


# -- the other steps ------------------------------------------------------------------------------

class _Episode(_Form):
    """Bias or scale: each simulation's values of its episode, added or multiplied."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.values = np.zeros((nsim, *site.shape))
        self.apply = ar.multiply if site.step.stage == "scale" else ar.add

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.values[ids] = self.site.values(drawn, self.site.at[0])

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.apply(src, self.values[sims], dst)


class _RandomWalk(_Form):
    """The walk's states over every index, one part of `sub` indices at a time per simulation (walked together):
    part p holds indices [p sub, (p + 1) sub); sub is the per-sample path's block (`noise.base.block_samples`)
    unless that would exceed `_BLOCK_BYTES` across simulations. Its coefficients are the step's kernel numbers
    (a Brownian walk, without a correlation time: a None, b_j = b_(j-1) + c z_j), its start the step's draw at
    each reset (0 for a Brownian walk)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.keys = np.zeros((nsim, 2), np.uint64)
        self.stream, self.size = site.step.stream, math.prod(site.shape)
        self.numbers = _Numbers(site, site.at[0], nsim, ("a", "c"))
        self.brownian = site.step.param("correlation_time") is None
        self.carry = np.zeros((nsim, *site.shape))
        sub = block_samples(self.size)
        per_sample = 8 * max(1, self.size) * nsim
        while sub > 1 and sub * per_sample > _BLOCK_BYTES:
            sub //= 2
        self.sub = sub
        self.part = np.full(nsim, -1, np.int64)  # the part each simulation holds
        self.rows: np.ndarray | None = None  # (nsim, sub, *shape)

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.keys[ids] = keys
        self.numbers.start(ids, drawn)
        self.carry[ids] = 0.0 if self.site.step.episode is None else self.site.values(drawn, self.site.at[0])
        self.part[ids] = -1

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        ar.add(src, self.take(sims, steps), dst)

    def take(self, sims: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """The walk's states at `steps`, (m, ...): the start at sample 0, else from the held parts (walking on to
        the parts that are due)."""
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
        held = self.part[sims]
        if (parts < held).any():
            raise ValueError("a batched random walk was asked for an earlier sample")
        out = np.empty((sims.size, self.sub, *self.shape))
        at = held + 1
        offsets = np.arange(self.sub)
        while True:
            moving = np.flatnonzero(at <= parts)
            if not moving.size:
                return out
            walking = sims[moving]
            samples = (at[moving, None] * self.sub + offsets).ravel()
            keys = np.repeat(self.keys[walking], self.sub, axis=0)
            z = numbers([Draw(keys, samples, self.stream, 0, self.size, True)])[0]
            z = z.reshape(moving.size, self.sub, *self.shape)
            carry = self.carry[walking]
            a = None if self.brownian else self.numbers.get("a", walking)
            c = self.numbers.get("c", walking)
            for first in (True, False):  # the episode's first part starts at the drawn start itself
                rows = np.flatnonzero((at[moving] == 0) == first)
                if rows.size:
                    c_rows = carry[rows]
                    states = ar.walk(c_rows, np.moveaxis(z[rows], 1, 0), _rows(a, rows, self.numbers),
                                     _rows(c, rows, self.numbers), first)
                    carry[rows] = c_rows
                    out[moving[rows]] = np.moveaxis(states, 0, 1)
            self.carry[walking] = carry
            at[moving] += 1


def _rows(value: np.ndarray | None, rows: np.ndarray, numbers: _Numbers) -> np.ndarray | None:
    """Rows `rows` of numbers taken per simulation; shared ones as they are."""
    return value[rows] if value is not None and numbers.per_sim else value


def _by_gap(gaps: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(gap, positions) for each distinct number of steps since a simulation's previous sample."""
    if gaps.size and (gaps == gaps[0]).all():
        return [(int(gaps[0]), np.arange(gaps.size))]
    return [(int(g), np.flatnonzero(gaps == g)) for g in np.unique(gaps)]


class _Lowpass(_Form):
    """The filter's coefficient per gap between samples: the step's kernel numbers (`alpha` for samples a stride
    apart, `alphas` per gap of a drawn schedule); another gap's from its cutoff (`lowpass_alpha`)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.numbers = _Numbers(site, site.at[0], nsim, ("alpha", "alphas", "cutoff"))
        self.gaps = len(self.numbers.shared["alphas"]) if "alphas" in self.numbers else 0
        self.others: dict[int, np.ndarray] = {}  # another gap's coefficient (shared numbers only)
        self.state = np.zeros((nsim, *site.shape))
        self.fresh = np.ones(nsim, bool)
        self.last = np.zeros(nsim, np.int64)

    def alpha(self, gap: int, sims: np.ndarray) -> np.ndarray:
        """The coefficient of samples `gap` steps apart of simulations `sims`."""
        numbers = self.numbers
        if gap == self.stride:
            return numbers.get("alpha", sims)
        if gap < self.gaps:
            row: np.ndarray = np.take(numbers.get("alphas", sims), gap, axis=-1 - len(self.shape))
            return row
        alpha = self.others.get(gap)
        if alpha is None:
            alpha = np.asarray(ar.lowpass_alpha(numbers.get("cutoff", sims), gap * self.site.program.timestep))
            if not numbers.per_sim:
                self.others[gap] = alpha
        return alpha

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.fresh[ids] = True  # (the state and the last sample's step are set at its first sample)
        self.numbers.start(ids, drawn)

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
            ar.lowpass(s, src[rows], self.alpha(gap, sims[rows]), d)
            state[rows] = s
        self.state[sims] = state
        self.fresh[sims] = False
        self.last[sims] = steps
        np.copyto(dst, state)


class _Dropout(_Drawn):
    """Lost samples (`per` sample: one uniform each) or values (`per` value), below p: held (`mode` hold: the
    last delivered value; a simulation's first sample of an episode is always delivered), 0 or NaN."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        options = dict(site.step.options)
        self.per_value = options.get("per") == "value"
        mode = options.get("mode", "hold")
        self.fill = {"zero": 0.0, "nan": math.nan}.get(mode)
        self.held = np.zeros((nsim, *site.shape)) if mode == "hold" else None
        self.fresh = np.ones(nsim, bool)
        self.numbers = _Numbers(site, site.at[0], nsim, ("p",))
        self.size = math.prod(site.shape) if self.per_value else 1

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        super().start(ids, keys, drawn)
        self.numbers.start(ids, drawn)
        self.fresh[ids] = True  # (the held values are set at its first sample, which is always delivered)

    def draws(self, sims: np.ndarray, steps: np.ndarray) -> list[Draw]:
        return [Draw(self.keys[sims], steps // self.stride, self.site.step.stream, 0, self.size, False)]

    def rows(self, sims: np.ndarray, raw: list[np.ndarray]) -> np.ndarray:
        p = self.numbers.get("p", sims)
        if self.per_value:
            lost: np.ndarray = raw[0].reshape(sims.size, *self.shape) < p
            return lost
        first = p.reshape(sims.size, -1)[:, 0] if self.numbers.per_sim else p.flat[0]  # (one p per sample)
        lost = raw[0][:, 0] < first
        return lost

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


class _Quantize(_Form):
    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.numbers = _Numbers(site, site.at[0], nsim, ("step",))

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.numbers.start(ids, drawn)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        ar.quantize(src, self.numbers.get("step", sims), dst)


class _Clip(_Form):
    """Saturation at the step's limits (a limit its config leaves unset: none)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.numbers = _Numbers(site, site.at[0], nsim, ("low", "high"))
        self.limits = (site.step.param("min") is not None, site.step.param("max") is not None)

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.numbers.start(ids, drawn)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        low, high = (self.numbers.get(name, sims) if given else None
                     for name, given in zip(("low", "high"), self.limits))
        ar.clip(src, low, high, dst)


class _Misalign(_Form):
    """R M x on the last axis, with each simulation's matrix of its episode (`StepEpisode.matrix`)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.matrices = np.tile(site.step.number("matrix"), (nsim, 1, 1))  # M, until a rotation is drawn

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        if drawn:
            j = self.site.at[0]
            self.matrices[ids] = np.stack([np.asarray(episode[j].matrix) for episode in drawn])

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        lead = (len(sims),) + (1,) * (src.ndim - 2)
        turn(src, self.matrices[sims].reshape(lead + (3, 3)), dst)


# One row per stage name of the plan (`NoiseStep.stage`); a stage missing here (custom) cannot be batched. A run
# of adjacent additive steps (`NoiseProgram.sums`) is one `_Additive` of their terms (`TERMS`).
BATCHED: Mapping[str, Callable[[Site, int], _Form]] = types.MappingProxyType({
    "gaussian": _Additive,
    "uniform": _Additive,
    "outlier": _Additive,
    "bias": _Episode,
    "scale": _Episode,
    "random_walk": _RandomWalk,
    "lowpass": _Lowpass,
    "quantize": _Quantize,
    "clip": _Clip,
    "dropout": _Dropout,
    "misalign": _Misalign,
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


def _forms(program: NoiseProgram, shape: tuple[int, ...], nsim: int) -> list[_Form]:
    """The program's forms in order: one per step, one per fused sum (`NoiseProgram.sums`)."""
    sums = dict(program.sums)
    forms, j = [], 0
    while j < len(program.steps):
        stop = sums.get(j, j + 1)
        at = tuple(range(j, stop))
        make = _Additive if len(at) > 1 else BATCHED[program.steps[j].stage]
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
        self._fusable = only if isinstance(only, _Additive) and only.terms is not None else None

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
    jobs: list[tuple[_Drawn, np.ndarray, int, int]] = []
    draws: list[Draw] = []
    for pipeline, sims, steps in calls:
        for form in pipeline.forms:
            if isinstance(form, _Drawn):
                drawn = form.draws(sims, steps)
                jobs.append((form, sims, len(draws), len(drawn)))
                draws.extend(drawn)
    raw = numbers(draws)
    for form, sims, at, count in jobs:
        form.ready.append(form.rows(sims, raw[at:at + count]))
