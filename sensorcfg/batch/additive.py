"""Additive noise steps across simulations: white noise, outliers and biases, alone or fused into one sum.

Each additive step is a term (`TERMS`, by the plan's stage name): numbers of its lanes made into what it adds
(a gaussian's std z, plus its mean where that is not 0; a uniform's low + width u; an outlier's scale z where
its uniform is below p), or a bias's values of the episode. An `Additive` form adds one step's term, or the
terms of a run of adjacent additive steps the program fuses (`NoiseProgram.sums`), added up in order before the
sum is added to the value: x + (a + b), as the single simulation's fused stages add them. Where every term is
numbers x scale (+ offset), the same for every simulation, the form's `terms` let the batch add the sum in one
pass of `streams.add_sums` (into the history, or as a read gathers, `batch.read_noise`).
"""

from __future__ import annotations

import math
import types
from collections.abc import Mapping
from typing import cast

import numpy as np

from ..noise import arithmetic as ar
from ..noise.streams import MAX_TERMS, Affine, Draw
from .forms import Drawn, Episodes, Numbers, Site

__all__ = ["Additive", "TERMS"]


class _Term:
    """What one additive step adds to a sample: its per-sample numbers of each lane (`lanes`: normals or
    uniforms), or a bias's values of the episode."""

    lanes: tuple[bool, ...] = ()
    names: tuple[str, ...] = ()  # the numbers it computes with

    def __init__(self, site: Site, j: int, nsim: int):
        self.site, self.j, self.shape = site, j, site.shape
        self.stream = site.program.steps[j].stream
        self.size = math.prod(site.shape)
        self.numbers = Numbers(site, j, nsim, self.names)

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
        std, mean = self.numbers.get("std", sims), self.numbers.get("mean", sims)
        if not self.numbers.per_sim:
            return ar.scaled(self.fresh(raw[0], sims.size), std, None if self.centred else mean)
        z = ar.scaled(self.fresh(raw[0], sims.size), std)
        offset = np.any(mean.reshape(sims.size, -1), axis=1)  # each episode's own: centred or not
        if offset.any():
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
        numbers = self.numbers
        return ar.scaled(self.fresh(raw[0], sims.size), numbers.get("width", sims), numbers.get("low", sims))

    def affine(self) -> list[Affine] | None:
        return None if self.numbers.per_sim else [Affine(self.flat("width"), self.flat("low"))]


class _Outlier(_Term):
    """scale z where a value is hit (its uniform, lane 0, below p), else 0; z from lane 1."""

    lanes = (False, True)  # hits, jumps
    names = ("p", "scale")

    def __call__(self, raw: list[np.ndarray], sims: np.ndarray) -> np.ndarray:
        return ar.outlier(raw[0].reshape(sims.size, *self.shape), self.fresh(raw[1], sims.size),
                          self.numbers.get("p", sims), self.numbers.get("scale", sims))


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


class Additive(Drawn):
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
