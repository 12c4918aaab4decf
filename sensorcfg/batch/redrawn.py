"""Noise parameters drawn per episode, across simulations: one stage per simulation, run row by row.

At each reset a simulation's stage is rebuilt with the parameters its plan draws from its sensor key
(`plan.noise.episode`) and reset with its own streams (`Redrawn.rebuilt`), so it draws what that simulation's
single `Environment` draws; the cost is a Python call per sample and simulation.
"""

from __future__ import annotations

import numpy as np

from ..noise import stages as rt
from ..noise.redrawn import Redrawn
from ..noise.streams import Streams
from .batched import Batched, Episodes, Site

__all__ = ["BatchedRedrawn"]


class BatchedRedrawn(Batched[Redrawn]):
    def __init__(self, template: Redrawn, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.stages: list[rt.Stage] = [template.inner] * nsim  # each simulation's, set by `start`

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        j, names = self.site.at[0], self.site.step.drawn
        for i, key, episode in zip(ids.tolist(), keys, drawn):
            step = episode[j].step  # with this episode's parameters
            values = {name: float(np.asarray(step.param(name)).flat[0]) for name in names}
            self.stages[i] = self.template.rebuilt(values, Streams(key), self.stride)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        for j, (sim, step) in enumerate(zip(sims.tolist(), steps.tolist())):
            self.stages[sim](src[j, ...], dst[j, ...], int(step))
