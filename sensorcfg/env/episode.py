"""When an episode ends, and with which discount: one rule for `Environment` and `BatchEnvironment`.

A diverged simulation or a `termination_fn` ends the episode with discount 0 (termination); otherwise the
time limit ends it with discount 1 (truncation); otherwise it goes on (discount 1). Elementwise: the single
environment passes scalars, the batch one value per simulation.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ArgumentError

__all__ = ["chosen_ids", "episode_end"]


def chosen_ids(ids: Any, count: int, unit: str = "simulation", whole: str = "the batch") -> np.ndarray:
    """Validated ids of `count` simulations (or worlds: `unit`), sorted and unique, from None (all), integers
    or a boolean mask; a mistake is an ArgumentError saying what was expected."""
    if ids is None:
        return np.arange(count)
    arr = np.asarray(ids)
    if arr.dtype == bool:
        if arr.shape != (count,):
            raise ArgumentError(f"a boolean mask of {unit}s must have shape ({count},), got {arr.shape}")
        return np.flatnonzero(arr)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1 or (arr.size and not np.issubdtype(arr.dtype, np.integer)):
        raise ArgumentError(f"ids must be {unit} indices (a 1-D array of integers) or a boolean mask, got {ids!r}")
    bad = arr[(arr < 0) | (arr >= count)]
    if bad.size:
        raise ArgumentError(f"{unit} id {int(bad[0])} is out of range: {whole} has {count} {unit}s "
                            f"(ids 0 to {count - 1})")
    return np.unique(arr.astype(np.intp))


def episode_end(diverged: Any, terminated: Any, control_steps: Any, step_limit: int | None) -> tuple[Any, Any]:
    """(last, discount): whether this step ends the episode, and its discount (bools and numbers for
    scalars, arrays for arrays: plain operators, no numpy call on the single environment's path)."""
    terminal = diverged | terminated
    last = terminal if step_limit is None else terminal | (control_steps >= step_limit)
    return last, 1.0 - terminal
