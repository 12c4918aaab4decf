"""The other noise steps across simulations: per-episode values (bias alone, scale), the random walk, the
low-pass, dropout, quantize, clip and misalign, each from its step's numbers (`forms.Numbers`) and its episode's
draws, with the rules' one home (`noise.arithmetic`, `noise.misalign.turn`). Stateful ones keep their state as
(nsim, ...) arrays."""

from __future__ import annotations

import math
from typing import cast

import numpy as np

from ..noise import arithmetic as ar
from ..noise.base import block_samples
from ..noise.misalign import turn
from ..noise.streams import Draw, numbers
from .forms import Drawn, Episodes, Form, Numbers, Site

__all__ = ["Clip", "Dropout", "EpisodeValues", "Lowpass", "Misalign", "Quantize", "RandomWalk"]


class EpisodeValues(Form):
    """Bias or scale: each simulation's values of its episode, added or multiplied."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.values = np.zeros((nsim, *site.shape))
        self.apply = ar.multiply if site.step.stage == "scale" else ar.add

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.values[ids] = self.site.values(drawn, self.site.at[0])

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.apply(src, self.values[sims], dst)


class RandomWalk(Form):
    """The walk's states over every index, one part of `sub` indices at a time per simulation (walked together):
    part p holds indices [p sub, (p + 1) sub); sub is the per-sample path's block (`noise.base.block_samples`)
    unless that would exceed `block_bytes` across simulations. Its coefficients are the step's kernel numbers
    (a Brownian walk, without a correlation time: a None, b_j = b_(j-1) + c z_j), its start the step's draw at
    each reset (0 for a Brownian walk)."""

    def __init__(self, site: Site, nsim: int, block_bytes: int):
        super().__init__(site, nsim)
        self.keys = np.zeros((nsim, 2), np.uint64)
        self.stream, self.size = site.step.stream, math.prod(site.shape)
        self.numbers = Numbers(site, site.at[0], nsim, ("a", "c"))
        self.brownian = site.step.param("correlation_time") is None
        self.carry = np.zeros((nsim, *site.shape))
        sub = block_samples(self.size)
        per_sample = 8 * max(1, self.size) * nsim
        while sub > 1 and sub * per_sample > block_bytes:
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
            samples = (at[moving, None] * self.sub + offsets).ravel()
            keys = np.repeat(self.keys[sims[moving]], self.sub, axis=0)
            z = numbers([Draw(keys, samples, self.stream, 0, self.size, True)])[0]
            z = z.reshape(moving.size, self.sub, *self.shape)
            carry = self.carry[sims[moving]]
            for first in (True, False):  # the episode's first part starts at the drawn start itself
                rows = np.flatnonzero((at[moving] == 0) == first)
                if rows.size:
                    walking = sims[moving[rows]]
                    a = None if self.brownian else self.numbers.get("a", walking)
                    c_rows = carry[rows]
                    states = ar.walk(c_rows, np.moveaxis(z[rows], 1, 0), a, self.numbers.get("c", walking), first)
                    carry[rows] = c_rows
                    out[moving[rows]] = np.moveaxis(states, 0, 1)
            self.carry[sims[moving]] = carry
            at[moving] += 1


def _by_gap(gaps: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(gap, positions) for each distinct number of steps since a simulation's previous sample."""
    if gaps.size and (gaps == gaps[0]).all():
        return [(int(gaps[0]), np.arange(gaps.size))]
    return [(int(g), np.flatnonzero(gaps == g)) for g in np.unique(gaps)]


class Lowpass(Form):
    """The filter's coefficient per gap between samples: the step's kernel numbers (`alpha` for samples a stride
    apart, `alphas` per gap of a drawn schedule); another gap's from its cutoff (`lowpass_alpha`)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.numbers = Numbers(site, site.at[0], nsim, ("alpha", "alphas", "cutoff"))
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


class Dropout(Drawn):
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
        self.numbers = Numbers(site, site.at[0], nsim, ("p",))
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


class Quantize(Form):
    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.numbers = Numbers(site, site.at[0], nsim, ("step",))

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.numbers.start(ids, drawn)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        ar.quantize(src, self.numbers.get("step", sims), dst)


class Clip(Form):
    """Saturation at the step's limits (a limit its config leaves unset: none)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        self.numbers = Numbers(site, site.at[0], nsim, ("low", "high"))
        self.limits = (site.step.param("min") is not None, site.step.param("max") is not None)

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        self.numbers.start(ids, drawn)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        low, high = (self.numbers.get(name, sims) if given else None
                     for name, given in zip(("low", "high"), self.limits))
        ar.clip(src, low, high, dst)


class Misalign(Form):
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
