"""The base of a noise stage across simulations (`batch.noise`'s table holds one form per stage type)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Generic, TypeVar

import numpy as np

from ..noise.base import Stage

__all__ = ["Batched"]

S = TypeVar("S", bound=Stage)  # the runtime stage type a batched form runs


class Batched(Generic[S]):
    """One stage across simulations; `template` is the sensor's own stage (its parameters are shared).

    `keyed`: the stage draws nothing at reset (its episode start is its key, and a state that is the
    same for every episode), so `load` may take many simulations at once (`BatchPipeline.start`)."""

    keyed = False

    def __init__(self, template: S, nsim: int, stride: int):
        self.template = template
        self.nsim = nsim
        self.stride = stride

    def load(self, i: int | np.ndarray, stage: S) -> None:
        """Take simulation i's episode start from `stage`, the template just reset with i's stream (i: an index
        array for a keyed stage: every episode start but the key is the same)."""

    def link(self, batched: Sequence[Batched[Any]]) -> None:
        """Find the other stages of its pipeline this one hands values to (`batched`: all of them, in order)."""

    def __call__(self, src: np.ndarray, dst: np.ndarray, sims: np.ndarray, steps: np.ndarray) -> None:
        raise NotImplementedError
