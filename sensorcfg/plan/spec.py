"""An observable's dm_env spec, from what binding decided of it: the one rule of every engine's
`observation_spec` (the Updater's, the batch's, the Warp engine's) and `sensorcfg spec`'s."""

from __future__ import annotations

import numbers
from typing import TYPE_CHECKING

import numpy as np
from dm_env import specs

from ..noise.bounds import noisy_bounds, own_bounds
from ..observables.aggregators import aggregated_bounds

if TYPE_CHECKING:
    from ..observables.base import Observable

__all__ = ["observation_spec", "shows_zeros"]


def observation_spec(name: str, observable: Observable, buffered_shape: tuple[int, ...],
                     dtype: np.dtype[np.generic[object]], pad: bool) -> specs.Array:
    """One observable's dm_env spec: its own, with the buffer axis (`buffered_shape`: a read's shape before
    any aggregator, of samples of `dtype`) and the aggregator applied; bounds kept where the aggregator
    preserves them. The bounds hold for every value a read can show: its noisy samples (`noise.bounds`),
    and the zeros a read shows before its first samples are delivered (`shows_zeros`; `pad`:
    `pad_with_initial_value`)."""
    array_spec = observable.array_spec
    aggregator = observable.aggregator
    noise = getattr(observable, "noise", None)
    own = own_bounds(observable)
    bounds = noisy_bounds(noise, own)  # the bounds every noisy sample keeps (sensorcfg.noise.bounds)
    if (bounds is not None and (np.any(np.greater(bounds[0], 0)) or np.any(np.less(bounds[1], 0)))
            and shows_zeros(observable, pad)):
        bounds = (np.minimum(bounds[0], 0), np.maximum(bounds[1], 0))
    if aggregator is None and array_spec is not None and noise is None and bounds is own:
        return array_spec.replace(name=name, shape=buffered_shape)
    shape, kind = buffered_shape, dtype
    if aggregator is not None:
        aggregated = np.asarray(aggregator(np.zeros(buffered_shape, dtype=dtype)))
        shape, kind = aggregated.shape, aggregated.dtype
        bounds = aggregated_bounds(aggregator, bounds, buffered_shape[0] if buffered_shape else 1)
    if bounds is not None:
        return specs.BoundedArray(shape=shape, dtype=kind, minimum=bounds[0], maximum=bounds[1], name=name)
    return specs.Array(shape=shape, dtype=kind, name=name)


def shows_zeros(observable: Observable, pad: bool) -> bool:
    """Whether a read of `observable` can show the zeros its window is padded with (dm_control's padding):
    without `pad_with_initial_value`, a buffer of more than one sample is padded until it fills, and a delay
    that can be above 0 leaves the reads before the first delivery empty. (With it, the padding repeats the
    first sample, noise included, which lies within the bounds already.)"""
    if pad:
        return False
    delay = observable.delay or 0
    largest = int(delay) if isinstance(delay, numbers.Integral) else getattr(delay, "largest", None)
    return bool((observable.buffer_size or 1) > 1 or largest is None or largest > 0)
