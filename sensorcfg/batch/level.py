"""The noise level across simulations: each simulation's level of the episode, blended with `blend`.

The batch runs a sensor's stages in place, so the raw samples are kept first (the pipeline's `Keep`) for
the final `Blend`; both are stages of the batch's table.
"""

from __future__ import annotations

import numpy as np

from ..noise import stages as rt
from ..noise.level import Blend, Keep, blend
from .noise import BATCHED, _Batched

__all__: list[str] = []


class _BatchedKeep(_Batched):
    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        self.template.blend.batch_raw = src.copy()  # type: ignore[attr-defined]
        if dst is not src:
            np.copyto(dst, src)


class _BatchedBlend(_Batched):
    def __init__(self, template: rt.Stage, nsim: int):
        super().__init__(template, nsim)
        self.levels = np.ones(nsim)

    def load(self, i: int, stage: rt.Stage) -> None:
        self.levels[i] = stage.level  # type: ignore[attr-defined]

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        level = self.levels[sims].reshape((len(sims),) + (1,) * (src.ndim - 1))
        blend(self.template.batch_raw, src, level, dst)  # type: ignore[attr-defined]


BATCHED[Keep] = _BatchedKeep
BATCHED[Blend] = _BatchedBlend
