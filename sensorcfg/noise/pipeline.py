"""A sequence of noise stages applied in order (interim: gaussian only; the noise issue extends it)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config.noise import GaussianStage, NoiseStage

__all__ = ["NoisePipeline", "build_noise"]


class NoisePipeline:
    def __init__(self, stages: Sequence[NoiseStage], shape: tuple[int, ...], dtype: np.dtype, timestep: float):
        self.stages = tuple(stages)
        self.shape = tuple(shape)
        self.dtype = np.dtype(dtype)
        self.timestep = float(timestep)
        self.rng = np.random.Generator(np.random.PCG64(0))

    def reset(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def __call__(self, value: np.ndarray, step: int) -> np.ndarray:
        out = np.asarray(value, dtype=np.float64)
        for stage in self.stages:
            if isinstance(stage, GaussianStage):
                out = out + stage.mean + stage.std * self.rng.standard_normal(self.shape)
        return out.astype(self.dtype, copy=False)


def build_noise(stages: Sequence[NoiseStage], shape: tuple[int, ...], dtype: Any, timestep: float) -> NoisePipeline | None:
    """A pipeline for one sensor, or None when it has no stages."""
    if not stages:
        return None
    return NoisePipeline(stages, shape, dtype, timestep)
