"""`misalign` across simulations: each simulation's matrix of the episode, applied with the same `turn`."""

from __future__ import annotations

import numpy as np

from ..noise.misalign import Misalign, turn
from .batched import Batched

__all__ = ["BatchedMisalign"]


class BatchedMisalign(Batched[Misalign]):
    def __init__(self, template: Misalign, nsim: int, stride: int):
        super().__init__(template, nsim, stride)
        self.matrices = np.tile(np.eye(3), (nsim, 1, 1))

    def load(self, i: int | np.ndarray, stage: Misalign) -> None:
        self.matrices[i] = stage.matrix

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        lead = (len(sims),) + (1,) * (src.ndim - 2)
        turn(src, self.matrices[sims].reshape(lead + (3, 3)), dst)
