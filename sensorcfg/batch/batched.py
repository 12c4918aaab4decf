"""The base of a noise stage across simulations (`batch.noise`'s table holds one form per stage type)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Generic, NamedTuple, TypeVar

import numpy as np

from ..noise.base import Stage
from ..plan.noise import StepEpisode
from ..plan.records import FloatArray, NoiseProgram, NoiseStep

__all__ = ["Batched", "Episodes", "Site"]

S = TypeVar("S", bound=Stage)  # the runtime stage type a batched form runs

Episodes = Sequence[tuple[StepEpisode, ...]]  # per simulation started, what its program draws (`plan.noise.episode`)


class Site(NamedTuple):
    """Where a batched form sits in its sensor's plan: the sensor's noise program, the positions of the steps
    the form runs (one; a fused sum's parts; none for the noise level's stages) and one sample's shape."""

    program: NoiseProgram
    at: tuple[int, ...]
    shape: tuple[int, ...]

    @property
    def step(self) -> NoiseStep:
        """The form's (first) step."""
        return self.program.steps[self.at[0]]

    def number(self, name: str) -> FloatArray:
        """The step's kernel number `name` (`NoiseStep.kernel`), shaped as one sample."""
        return self.step.number(name).reshape(self.shape)

    def values(self, drawn: Episodes, j: int | None = None) -> np.ndarray:
        """Step j's values drawn at this reset (the form's step when None), one row per simulation (m, *shape)."""
        j = self.at[0] if j is None else j
        return np.stack([np.asarray(episode[j].values) for episode in drawn]).reshape(len(drawn), *self.shape)


class Batched(Generic[S]):
    """One stage across simulations; `template` is the sensor's own stage (its per-sample arithmetic is shared,
    never its state, which other batches and environments share), `site` its steps in the plan (their kernel
    numbers and episode draws)."""

    def __init__(self, template: S, site: Site, nsim: int):
        self.template = template
        self.site = site
        self.nsim = nsim
        self.stride = site.program.stride

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        """Start the episodes of simulations `ids` (m,) whose sensor keys are `keys` (m, 2); `drawn`: what the
        program draws at each one's reset (`plan.noise.episode`), empty when it draws nothing."""

    def link(self, batched: Sequence[Batched[Any]]) -> None:
        """Find the other stages of its pipeline this one hands values to (`batched`: all of them, in order)."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raise NotImplementedError
