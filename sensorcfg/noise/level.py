"""A noise level for curricula: every stage's effect scaled by one number, from the next episode on.

`leveled(pipeline)` wraps a sensor's pipeline; at level x a sample reads raw + x (noisy - raw): the clean
value at 0, the suite's noise at 1 (exactly: the blend is skipped), and for additive stages (gaussian,
uniform, bias, random walk, outliers) their amplitudes times x; a gain's deviation from 1, a misalignment's
deviation from the identity and what quantize, dropout and low-pass change are scaled the same way. The
blend is kept inside the bounds the sensor's noisy values keep (`noise.bounds`: a `clip`'s range, the
observable's own bounds where stages keep them), so a spec's bounds hold at every level: a clipped
sensor stays within its clip at level 0 too.
The level a pipeline uses is fixed at each reset (`set_level` sets the next one), so an episode has one;
giving a pipeline a level (`leveled`) leaves its stages as they are, so the episode under way is not
touched either. Random numbers are those of level 1: the blend runs as one more stage at the end, whose
stream nobody else uses. `blend` is the one arithmetic: one simulation and a batch call it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from . import stages as rt
from .bounds import BOUNDS, Interval, noisy_bounds, own_bounds
from .pipeline import NoisePipeline

__all__ = ["Blend", "LeveledPipeline", "blend", "follow", "leveled", "own_bounds", "set_level"]


def blend(raw: np.ndarray, noisy: np.ndarray, level: Any, dst: np.ndarray, bounds: Interval | None = None) -> None:
    """dst = raw + level (noisy - raw) clipped to `bounds` (minimum, maximum: the interval every noisy value
    keeps, broadcast against dst; None: unbounded), where level != 1; noisy itself where level == 1."""
    if np.ndim(level) == 0 and level == 1.0:
        np.copyto(dst, noisy, casting="unsafe")
        return
    mixed = np.asarray(raw + level * (noisy - raw))  # (a 0-d sample's arithmetic gives a scalar: clipped in place)
    if bounds is not None:
        np.clip(mixed, bounds[0], bounds[1], out=mixed)
    if np.ndim(level):  # per simulation: those at level 1 read their noisy values exactly
        mixed = np.where(np.equal(level, 1.0), noisy, mixed)
    np.copyto(dst, mixed, casting="unsafe")


class Blend(rt.Stage):
    """The pipeline's last stage: blends its input with the raw sample the pipeline was given."""

    stateful = False
    stream = 0

    def reset(self, *args: Any) -> None:
        """No draws: the level is set by the pipeline at each reset."""

    def __init__(self) -> None:
        self.level = 1.0
        self.bounds: Interval | None = None  # what the blend is kept within (the stages' bounds; None: none)
        self.raw: np.ndarray | None = None

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        if self.level == 1.0:
            if dst is not src:
                np.copyto(dst, src)
            return
        blend(np.asarray(self.raw), src, self.level, dst, self.bounds)


class LeveledPipeline(NoisePipeline):
    """A sensor's pipeline with a `Blend` at the end (its stream is the last one: the others keep theirs).

    It takes over the stages of `pipeline` as they are, reset or mid-episode: nothing is drawn or cleared
    until its own next reset. `own` gives the observable's own bounds (None: none), asked once, at the first
    reset to a level other than 1 (the observable is bound by then): the blend stays within what
    `pipeline`'s values keep from then on."""

    def __init__(self, pipeline: NoisePipeline, own: Callable[[], Interval | None] = lambda: None):
        ctx = rt.Context(pipeline.shape, pipeline.dtype, pipeline._work.dtype, pipeline.timestep)
        self._inner = pipeline
        self._own = own
        self._blend = Blend()
        self._blend.stream = len(pipeline.names)  # a stream no other stage uses
        self.next_level = 1.0
        self._bounded = False  # the blend's bounds are found once, at the first reset to a level other than 1
        super().__init__([*pipeline.stages, self._blend], [*pipeline.names, "level"], ctx, streams=pipeline.streams)
        self.stride = pipeline.stride
        self.configs = pipeline.configs

    @property
    def level(self) -> float:
        return self._blend.level

    def reset(self, key: np.ndarray | np.random.Generator | np.random.RandomState, stride: int = 1) -> None:
        super().reset(key, stride)
        self._blend.level = self.next_level
        if self.next_level != 1.0 and not self._bounded:
            self._blend.bounds = self.blend_bounds()
            self._bounded = True

    def blend_bounds(self) -> Interval | None:
        """What the blend is kept within: the interval the stages' values keep (`noise.bounds`) given the
        observable's own bounds (bound by now); None: unbounded. The suite plan records it too."""
        return noisy_bounds(self._inner, self._own())

    def __call__(self, value: np.ndarray, step: int, out: np.ndarray | None = None) -> np.ndarray:
        self._blend.raw = value
        return super().__call__(value, step, out)


def _asking(observable: Any) -> Callable[[], Interval | None]:
    """`own_bounds` of `observable` when called: a function, which copies of the pipeline share (a deepcopy
    copies no function) rather than copying the observable."""
    return lambda: own_bounds(observable)


def leveled(observables: Mapping[str, Any]) -> None:
    """Give every noisy observable a level (at 1: its noise unchanged). Its stages are taken over as they
    are: the episode under way reads on through the pipeline it started with."""
    for observable in observables.values():
        noise = getattr(observable, "noise", None)
        if isinstance(noise, NoisePipeline) and not isinstance(noise, LeveledPipeline):
            observable.noise = LeveledPipeline(noise, _asking(observable))


def follow(copy: Any, pipeline: Any) -> None:
    """A copy of a sensor's pipeline (a batch renders each simulation's camera or height scan through its own)
    takes the level `pipeline` is set to, from its next reset on."""
    if isinstance(copy, LeveledPipeline) and isinstance(pipeline, LeveledPipeline):
        copy.next_level = pipeline.next_level


# The blend is kept within what the stages before it keep (`Blend.bounds`).
BOUNDS[Blend] = lambda stage, lo, hi: (lo, hi)


def set_level(observables: Mapping[str, Any], level: float) -> None:
    """The noise level of every noisy observable from its next reset on."""
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not np.isfinite(level) or level < 0:
        from ..errors import ArgumentError  # a Python call's argument, not a suite's line

        raise ArgumentError(f"a noise level is a number >= 0 (0: clean, 1: the suite's noise); got {level!r}")
    leveled(observables)
    for observable in observables.values():
        noise = getattr(observable, "noise", None)
        if isinstance(noise, LeveledPipeline):
            noise.next_level = float(level)
