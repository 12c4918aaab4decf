"""The noise level across simulations: each simulation's level of the episode, blended with `blend`.

The batch runs a sensor's stages in place, so the raw samples are kept first (the pipeline's `Keep`) for
the final `Blend`; both are rows of the table of batched stages (`batch.noise.BATCHED`). What a batch
knows of its levels (each simulation's level, whether any is not 1, the raw samples of the call under way)
lives in its own batched stages, never on the sensor's stages, which other batches and environments share;
the blend's bounds are the plan's (`NoiseProgram.bounds`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..noise.level import Blend, Keep, blend
from .batched import Batched, Site

__all__ = ["BatchedKeep", "BatchedBlend"]


class BatchedBlend(Batched[Blend]):
    def __init__(self, template: Blend, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.levels = np.ones(nsim)
        self.active = False  # some simulation's level is not 1
        self.raw: np.ndarray | None = None  # the raw samples of the call under way (kept by `BatchedKeep`)
        bounds = site.program.bounds
        self.bounds = None if bounds is None else (bounds[0].reshape(site.shape), bounds[1].reshape(site.shape))

    def set_level(self, ids: np.ndarray, level: float) -> None:
        """The level of the episodes of simulations `ids`, which start now."""
        self.levels[ids] = level
        self.active = bool(np.any(self.levels != 1.0))

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raw = self.raw
        if raw is None:  # every simulation of the call at level 1
            if dst is not src:
                np.copyto(dst, src)
            return
        level = self.levels[sims].reshape((len(sims),) + (1,) * (src.ndim - 1))
        blend(raw, src, level, dst, self.bounds)


class BatchedKeep(Batched[Keep]):
    def __init__(self, template: Keep, site: Site, nsim: int):
        super().__init__(template, site, nsim)
        self.blend: BatchedBlend  # the pipeline's batched blend (`link`)

    def link(self, batched: Sequence[Batched[Any]]) -> None:
        blend_stage = self.template.blend
        self.blend = next(b for b in batched if isinstance(b, BatchedBlend) and b.template is blend_stage)

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        blend_stage = self.blend
        # every simulation at level 1 (the default): nothing to keep
        blend_stage.raw = src.copy() if blend_stage.active else None
        if dst is not src:
            np.copyto(dst, src)
