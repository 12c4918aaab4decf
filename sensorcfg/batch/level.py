"""The noise level across simulations: each simulation's level of the episode, blended with `blend`.

The batch runs a sensor's stages in place, so the raw samples are kept first (the pipeline's `Keep`) for
the final `Blend`; both are rows of the table of batched stages (`batch.noise.BATCHED`).
"""

from __future__ import annotations

import numpy as np

from ..noise import stages as rt
from ..noise.level import blend
from .batched import Batched

__all__ = ["BatchedKeep", "BatchedBlend"]


class BatchedKeep(Batched):
    keyed = True

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        blend_stage = self.template.blend  # type: ignore[attr-defined]
        # every simulation at level 1 (the default): nothing to keep
        blend_stage.batch_raw = src.copy() if blend_stage.batch_active else None
        if dst is not src:
            np.copyto(dst, src)


class BatchedBlend(Batched):
    keyed = True

    def __init__(self, template: rt.Stage, nsim: int, stride: int):
        super().__init__(template, nsim, stride)
        self.levels = np.ones(nsim)
        template.batch_active = False  # type: ignore[attr-defined]  # some simulation's level is not 1

    def load(self, i: int | np.ndarray, stage: rt.Stage) -> None:
        self.levels[i] = stage.level  # type: ignore[attr-defined]
        self.template.batch_active = bool(np.any(self.levels != 1.0))  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raw = self.template.batch_raw  # type: ignore[attr-defined]
        if raw is None:  # every simulation of the call at level 1
            if dst is not src:
                np.copyto(dst, src)
            return
        level = self.levels[sims].reshape((len(sims),) + (1,) * (src.ndim - 1))
        blend(raw, src, level, dst, self.template.bounds)  # type: ignore[attr-defined]
