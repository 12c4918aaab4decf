"""Additive noise steps across simulations: white noise, outliers and biases, alone or fused into one sum.

An `Additive` form adds one step's term, or the terms of a run of adjacent additive steps the program fuses
(`NoiseProgram.sums`), added up in order before the sum is added to the value: x + (a + b). What a term draws
and the values it makes of its numbers are `plan/terms.py`'s, the rule the single simulation's banks run
too; the batch gives it, for a step whose parameters are drawn per episode, each simulation's own
numbers (`Numbers`: one row per simulation), and a bias's values of each simulation's episode. Where every
term is numbers x scale (+ offset), the same for every simulation, the form's `terms` let the batch add the sum
in one pass of `streams.add_sums` (into the history, or as a read gathers, `batch.read_noise`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..noise import arithmetic as ar
from ..noise.streams import Affine, Draw
from ..plan import terms as tm
from ..plan.records import NoiseStep
from .forms import Drawn, Episodes, Numbers, Site

__all__ = ["Additive"]


class Additive(Drawn):
    """White noise, outliers, and a fused sum of additive steps: one addition per sample, of the steps' terms
    added up in order (`plan.terms.values`: the first drawn term itself, or zeros plus a first bias)."""

    def __init__(self, site: Site, nsim: int):
        super().__init__(site, nsim)
        size = math.prod(site.shape)
        self.term = tm.term_of(site.program, site.at[0], size)
        steps = self.term.steps
        # the steps whose parameters are drawn per episode: their numbers, one row per simulation
        self.numbers = {s.stream: Numbers(site, s.stream, nsim, tm.NUMBERS[s.stage])
                        for s in steps if s.redraw is not None and s.stage in tm.NUMBERS}
        self.biases = {s.stream: np.zeros((nsim, size)) for s in steps if s.stage == "bias"}
        # numbers x scale (+ offset), added up: added in place in one pass (`streams.add_sums`) where nothing
        # per episode joins
        self.terms: list[Affine] | None = None if self.numbers else tm.affine(self.term)

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        super().start(ids, keys, drawn)
        for numbers in self.numbers.values():
            numbers.start(ids, drawn)
        for j, values in self.biases.items():
            values[ids] = self.site.values(drawn, j).reshape(len(ids), -1)

    def draws(self, sims: np.ndarray, steps: np.ndarray) -> list[Draw]:
        return tm.draws(self.term, steps // self.stride, self.keys[sims])

    def _number(self, sims: np.ndarray) -> Callable[[NoiseStep, str], np.ndarray | None]:
        """The steps' numbers for simulations `sims`: the program's, or each one's episode's (rows)."""
        def number(step: NoiseStep, name: str) -> np.ndarray | None:
            numbers = self.numbers.get(step.stream)
            if numbers is None:
                return tm.kernel_number(step, name)
            return numbers.get(name, sims).reshape(sims.size, -1) if name in numbers else None

        return number

    def rows(self, sims: np.ndarray, raw: list[np.ndarray]) -> np.ndarray:
        episode = [values[sims] for values in self.biases.values()]
        total = tm.values(self.term, raw, sims.size, episode, self._number(sims))
        return total.reshape(sims.size, *self.shape)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        ar.add(src, self.take(sims, steps), dst)
