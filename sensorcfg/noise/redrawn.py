"""Noise parameters drawn per episode (`std: {uniform: [0.01, 0.03]}`): the stage is rebuilt at each reset.

`Redrawn` holds a stage's config whose parameters are `EpisodeUniform` ranges; at reset it draws each one
from its own generator (in the config's field order), builds the stage with those values and resets it
with a generator spawned from the same stream. A batch keeps one such stage per simulation (each taken
from the template just reset with that simulation's stream), so simulation i equals one simulation.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..config.noise import EpisodeUniform
from . import stages as rt

__all__ = ["Redrawn", "drawn_fields"]


def drawn_fields(config: Any) -> dict[str, EpisodeUniform]:
    """The parameters of a stage config that are drawn per episode, in field order."""
    return {f: v for f in type(config).model_fields if isinstance(v := getattr(config, f), EpisodeUniform)}


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

    def reset(self, rng: Any, stride: int | None = None) -> None:
        """`rng`: the stage's generator, or the sensor's counter-based streams (parameters drawn from a part
        no stage uses; the rebuilt stage gets this stage's own part)."""
        assert rng is not None
        streams = rng if hasattr(rng, "at") else None
        source = streams.at(self.stream, 0, purpose=2) if streams is not None else rng
        self.values = {f: r.draw(source) for f, r in self.drawn.items()}
        self.inner = self.build(self.config.model_copy(update=self.values))
        inner: Any = self.inner  # either reset signature (see `reset`)
        if streams is not None:
            inner.stream = self.stream
            inner.reset(streams, stride)
            return
        inner.reset(np.random.Generator(np.random.PCG64(rng.integers(0, 2**63))) if inner.needs_rng else None)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        self.inner(src, dst, step)
