"""Noise parameters drawn per episode, across simulations: one stage per simulation, run row by row.

Each simulation's stage is the template just reset with its stream (copied), so it draws what that
simulation's single `Environment` draws; the cost is a Python call per sample and simulation.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ..noise import stages as rt
from .batched import Batched

__all__ = ["BatchedRedrawn"]


class BatchedRedrawn(Batched):
    def __init__(self, template: rt.Stage, nsim: int, stride: int):
        super().__init__(template, nsim, stride)
        self.stages: list[Any] = [None] * nsim

    def load(self, i: int | np.ndarray, stage: rt.Stage) -> None:
        self.stages[i] = copy.deepcopy(stage.inner)  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        for j, (sim, step) in enumerate(zip(sims.tolist(), steps.tolist())):
            self.stages[sim](src[j, ...], dst[j, ...], int(step))
