"""A noise level for curricula: every stage's effect scaled by one number, from the next episode on.

`leveled(pipeline)` wraps a sensor's pipeline; at level x a sample reads raw + x (noisy - raw): the clean
value at 0, the suite's noise at 1 (exactly: the blend is skipped), and for additive stages (gaussian,
uniform, bias, random walk, outliers) their amplitudes times x; a gain's deviation from 1, a misalignment's
deviation from the identity and what quantize, clip, dropout and low-pass change are scaled the same way.
The level a pipeline uses is fixed at each reset (`set_level` sets the next one), so an episode has one.
Random numbers are those of level 1: the blend runs as one more stage at the end, whose stream nobody
else uses. `blend` is the one arithmetic: one simulation and a batch call it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from . import stages as rt
from .pipeline import NoisePipeline

__all__ = ["Blend", "Keep", "LeveledPipeline", "blend", "leveled", "set_level"]


def blend(raw: np.ndarray, noisy: np.ndarray, level: Any, dst: np.ndarray) -> None:
    """dst = raw + level (noisy - raw), where level != 1; noisy itself where level == 1."""
    mixed = raw + level * (noisy - raw)
    np.copyto(dst, np.where(np.equal(level, 1.0), noisy, mixed), casting="unsafe")


class Blend(rt.Stage):
    """The pipeline's last stage: blends its input with the raw sample the pipeline was given."""

    stateful = False
    stream = 0

    def reset(self, *args: Any) -> None:
        """No draws: the level is set by the pipeline at each reset."""

    def __init__(self) -> None:
        self.level = 1.0
        self.raw: np.ndarray | None = None
        self.batch_raw: Any = None  # the raw samples of a batch's current call (kept by `Keep`)

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        if self.level == 1.0:
            if dst is not src:
                np.copyto(dst, src)
            return
        blend(np.asarray(self.raw), src, self.level, dst)


class Keep(rt.Stage):
    """Where a batch, which runs a sensor's stages in place, keeps the raw samples for the `Blend`."""

    stateful = False

    def __init__(self, blend: Blend):
        self.blend = blend

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        if dst is not src:
            np.copyto(dst, src)


class LeveledPipeline(NoisePipeline):
    """A sensor's pipeline with a `Blend` at the end (its stream is the last one: the others keep theirs)."""

    def __init__(self, pipeline: NoisePipeline):
        ctx = rt.Context(pipeline.shape, pipeline.dtype, pipeline._work.dtype, pipeline.timestep)
        self._blend = Blend()
        self._blend.stream = len(pipeline.names)  # a stream no other stage uses
        self._keep = Keep(self._blend)
        self.next_level = 1.0
        super().__init__([*pipeline.stages, self._blend], [*pipeline.names, "level"], ctx)

    @property
    def stages(self) -> tuple[rt.Stage, ...]:
        """For the batch: `Keep` first (it runs the stages in place), then the stages and the `Blend`."""
        return (self._keep, *self._stages)

    @property
    def level(self) -> float:
        return self._blend.level

    def reset(self, key: np.ndarray | np.random.Generator | np.random.RandomState, stride: int = 1) -> None:
        super().reset(key, stride)
        if hasattr(self, "_blend"):
            self._blend.level = self.next_level

    def __call__(self, value: np.ndarray, step: int, out: np.ndarray | None = None) -> np.ndarray:
        self._blend.raw = value
        return super().__call__(value, step, out)


def leveled(observables: Mapping[str, Any]) -> None:
    """Give every noisy observable a level (at 1: its noise unchanged)."""
    for observable in observables.values():
        noise = getattr(observable, "noise", None)
        if isinstance(noise, NoisePipeline) and not isinstance(noise, LeveledPipeline):
            observable.noise = LeveledPipeline(noise)


def set_level(observables: Mapping[str, Any], level: float) -> None:
    """The noise level of every noisy observable from its next reset on."""
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not np.isfinite(level) or level < 0:
        from ..errors import SuiteError

        raise SuiteError(f"a noise level is a number >= 0 (0: clean, 1: the suite's noise); got {level!r}")
    leveled(observables)
    for observable in observables.values():
        noise = getattr(observable, "noise", None)
        if isinstance(noise, LeveledPipeline):
            noise.next_level = float(level)
