"""Noise parameters drawn per episode (`std: {uniform: [0.01, 0.03]}`): the stage is rebuilt at each reset.

`Redrawn` holds a stage's config whose parameters are `EpisodeUniform` ranges; at reset it draws them
(`params_draw`: low + (high - low) u each, in the config's field order, from the stage's purpose-2 numbers),
builds the stage with those values and resets it
with a generator spawned from the same stream (`rebuilt`). A batch keeps one such stage per simulation, rebuilt
with the values its plan draws for that simulation, so simulation i equals one simulation.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..config.noise import EpisodeUniform
from . import stages as rt
from .arithmetic import width
from .streams import ResetDraw, draw_episode

__all__ = ["Redrawn", "drawn_fields", "params_draw"]


def drawn_fields(config: Any) -> dict[str, EpisodeUniform]:
    """The parameters of a stage config that are drawn per episode, in field order."""
    return {f: v for f in type(config).model_fields if isinstance(v := getattr(config, f), EpisodeUniform)}


def params_draw(stream: int, ranges: list[EpisodeUniform]) -> ResetDraw:
    """The parameters drawn at each reset, one per range (in field order): low + (high - low) u."""
    lows = np.array([r.low for r in ranges], np.float64)
    return ResetDraw(stream, 2, False, width(lows, np.array([r.high for r in ranges], np.float64)), lows)


class Redrawn(rt.Stage):
    """A stage whose parameters are drawn at each reset."""

    needs_rng = True
    stream = 0  # its part of the sensor's streams, where the pipeline keys them by stage

    def __init__(self, config: Any, build: Callable[[Any], rt.Stage]):
        self.config, self.build = config, build
        self.drawn = drawn_fields(config)
        self.values: dict[str, float] = {f: r.low for f, r in self.drawn.items()}
        self.inner = build(config.model_copy(update=self.values))
        self.stateful = bool(getattr(self.inner, "stateful", False))  # the sensor takes every sample if so

    def reset(self, streams: rt.Streams | None, stride: int) -> None:
        """The sensor's counter-based streams: parameters drawn from this stage's purpose-2 numbers, which no
        stage uses; the rebuilt stage is reset with this stage's own part."""
        assert streams is not None
        drawn = draw_episode(params_draw(self.stream, list(self.drawn.values())), streams)
        self.values = {f: float(v) for f, v in zip(self.drawn, drawn)}
        self.inner = self.rebuilt(self.values, streams, stride)

    def rebuilt(self, values: dict[str, float], streams: rt.Streams, stride: int) -> rt.Stage:
        """The stage built with parameters `values` (one per drawn field), reset for the episode of `streams`
        (with this stage's part of them)."""
        inner = self.build(self.config.model_copy(update=values))
        inner.stream = self.stream
        inner.reset(streams, stride)
        return inner

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        self.inner(src, dst, step)
