"""A noise step across simulations, as the batch runs it from the suite plan (`batch.noise` holds the table).

A form sits at one step of a sensor's `NoiseProgram`, or at a run of adjacent additive steps the program fuses
(`Site`); it computes with the steps' numbers (`Numbers`: the kernel numbers and parameters of the plan, one row
per simulation where parameters are drawn per episode) and starts each simulation's episode from what the
program draws at its reset (`plan.noise.episodes`). A form with per-sample numbers (`Drawn`) draws those of the
samples taken, of every simulation at once, or takes them drawn ahead (`batch.noise.prefetch`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import NamedTuple, cast

import numpy as np

from ..noise.streams import Draw, numbers
from ..plan.noise import StepEpisode
from ..plan.records import NoiseProgram, NoiseStep

__all__ = ["Drawn", "Episodes", "Form", "Numbers", "Site"]

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


class Numbers:
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


class Form:
    """One step, or a fused run of additive steps, across simulations."""

    def __init__(self, site: Site, nsim: int):
        self.site, self.nsim, self.shape = site, nsim, site.shape
        self.stride = site.program.stride

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        """Start the episodes of simulations `ids` (m,) whose sensor keys are `keys` (m, 2); `drawn`: what the
        program draws at each one's reset (`plan.noise.episode`), empty when it draws nothing."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raise NotImplementedError


class Drawn(Form):
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
