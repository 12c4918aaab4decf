"""A sensor's noise pipeline as data (`NoiseProgram`): each configured stage's type, stream and parameters."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..config.noise import EpisodeUniform, NoiseStage
from .records import FloatArray, NoiseProgram, NoiseStep, frozen

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline

__all__ = ["ADDITIVE", "program"]

ADDITIVE = frozenset({"gaussian", "uniform"})  # stages that only add numbers drawn per sample
_WORDS = (str,)


def _param(value: object, shape: tuple[int, ...]) -> FloatArray:
    """A numeric parameter broadcast to the sensor's values and raveled (a 3 x 3 matrix stays 3 x 3)."""
    array = np.asarray(value, np.float64)
    if array.shape == (3, 3):
        return frozen(array)
    return frozen(np.broadcast_to(array, shape).ravel())


def step(config: NoiseStage, stream: int, shape: tuple[int, ...]) -> NoiseStep:
    """One stage's config (a validated `config.noise` model) as a `NoiseStep`."""
    params: list[tuple[str, FloatArray]] = []
    options: list[tuple[str, str]] = []
    drawn: list[str] = []
    for name in type(config).model_fields:
        value = getattr(config, name)
        if name == "type" or value is None or callable(value):
            continue
        if isinstance(value, EpisodeUniform):
            drawn.append(name)
            value = value.low
        if isinstance(value, _WORDS):
            options.append((name, value))
        elif isinstance(value, bool):
            options.append((name, str(value).lower()))
        else:
            try:
                params.append((name, _param(value, shape)))
            except (TypeError, ValueError):  # a word list or a callable reference: not numeric
                options.append((name, str(value)))
    return NoiseStep(config.type, stream, tuple(params), tuple(options), tuple(drawn))


def program(pipeline: NoisePipeline | None, shape: tuple[int, ...], stride: int) -> NoiseProgram | None:
    """The program of a sensor's pipeline (`noise.pipeline.NoisePipeline`, leveled or not), or None."""
    if pipeline is None:
        return None
    steps = tuple(step(config, i, shape) for i, config in enumerate(pipeline.configs))
    return NoiseProgram(steps, int(stride), bool(pipeline.stateful), hasattr(pipeline, "next_level"),
                        all(s.stage in ADDITIVE and not s.drawn for s in steps))
