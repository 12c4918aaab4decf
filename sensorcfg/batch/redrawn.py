"""Noise parameters drawn per episode, across simulations: one stage per simulation, run row by row.

Each simulation's stage is the template just reset with its stream (copied), so it draws what that
simulation's single `Environment` draws; the cost is a Python call per sample and simulation.
"""

from __future__ import annotations

import copy

import numpy as np

from ..noise import stages as rt
from ..noise.redrawn import Redrawn
from .batched import Batched

__all__ = ["BatchedRedrawn"]


class BatchedRedrawn(Batched[Redrawn]):
    def __init__(self, template: Redrawn, nsim: int, stride: int):
        super().__init__(template, nsim, stride)
        self.stages: list[rt.Stage] = [template.inner] * nsim  # each simulation's, set by `load`

    def load(self, i: int | np.ndarray, stage: Redrawn) -> None:
        self.stages[i] = copy.deepcopy(stage.inner)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        for j, (sim, step) in enumerate(zip(sims.tolist(), steps.tolist())):
            self.stages[sim](src[j, ...], dst[j, ...], int(step))
