"""The bounds a sensor's values keep through its noise: a spec promises them for every sample.

Start from the observable's own bounds (none: -inf..inf) and map the interval through each stage, in order:
`clip` narrows it to its limits, `lowpass` and `dropout` with `mode: hold` keep it (they average or repeat
values inside it), `dropout` with `mode: zero` adds 0; every other stage (additive noise, bias, scale,
random walk, quantize, outlier, custom, dropout to NaN) can leave any bound, so the interval becomes
unbounded. uint8 images are rounded and clipped to 0..255 after their stages, so they keep 0..255. So
gaussian noise on a depth image drops its minimum 0, unless a `clip: {min: 0}` stage follows it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from . import stages as rt
from .arithmetic import clip_bounds

__all__ = ["noisy_bounds", "own_bounds"]

Interval = tuple[Any, Any]  # (minimum, maximum): scalars or per-value arrays
_UNBOUNDED: Interval = (-np.inf, np.inf)


def _clip(stage: Any, lo: Any, hi: Any) -> Interval:
    low, high = clip_bounds(stage.low, stage.high)
    return np.clip(lo, low, high), np.clip(hi, low, high)


def _dropout(stage: Any, lo: Any, hi: Any) -> Interval:
    if stage.mode == "hold":
        return lo, hi
    if stage.mode == "zero":
        return np.minimum(lo, 0), np.maximum(hi, 0)
    return _UNBOUNDED  # NaN is inside no bounds


# stage class -> how it maps an interval of inputs to the interval of its outputs; absent: unbounded
BOUNDS: dict[type, Callable[[Any, Any, Any], Interval]] = {
    rt.Clip: _clip,
    rt.Lowpass: lambda stage, lo, hi: (lo, hi),
    rt.Dropout: _dropout,
}


def own_bounds(observable: Any) -> Interval | None:
    """The bounds of an observable's own spec, None when it has none (or none yet: a feature's is known once
    bound)."""
    spec = getattr(observable, "array_spec", None)
    minimum, maximum = getattr(spec, "minimum", None), getattr(spec, "maximum", None)
    return None if minimum is None or maximum is None else (minimum, maximum)


def noisy_bounds(pipeline: Any, bounds: Interval | None) -> Interval | None:
    """The (minimum, maximum) every output of `pipeline` lies in, given inputs in `bounds` (None: unbounded);
    None when the outputs are unbounded on both sides."""
    if pipeline is None:
        return bounds
    if np.dtype(pipeline.dtype) == np.uint8:
        return (0, 255) if bounds is None else bounds  # rounded and clipped to the dtype's range
    lo, hi = _UNBOUNDED if bounds is None else bounds
    for stage in pipeline.stages:
        rule = BOUNDS.get(type(stage))
        lo, hi = _UNBOUNDED if rule is None else rule(stage, lo, hi)
    if np.all(np.isneginf(lo)) and np.all(np.isposinf(hi)):
        return None
    return lo, hi
