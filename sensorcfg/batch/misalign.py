"""`misalign` across simulations: each simulation's matrix of the episode (the plan's: `plan.noise.episode`),
applied with the same `turn`."""

from __future__ import annotations

import numpy as np

from ..noise.misalign import Misalign, turn
from .batched import Batched, Episodes, Site

__all__ = ["BatchedMisalign"]


class BatchedMisalign(Batched[Misalign]):
    def __init__(self, template: Misalign, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.matrices = np.tile(site.step.number("matrix"), (nsim, 1, 1))  # M, until a rotation is drawn

    def start(self, ids: np.ndarray, keys: np.ndarray, drawn: Episodes) -> None:
        if drawn:
            j = self.site.at[0]
            self.matrices[ids] = np.stack([np.asarray(episode[j].matrix) for episode in drawn])

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        lead = (len(sims),) + (1,) * (src.ndim - 2)
        turn(src, self.matrices[sims].reshape(lead + (3, 3)), dst)
