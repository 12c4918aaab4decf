"""When an episode ends, and with which discount: one rule for `Environment`, `BatchEnvironment` and
`WarpEnvironment`.

A diverged simulation or a `termination_fn` ends the episode with discount 0 (termination); otherwise the
time limit ends it with discount 1 (truncation); otherwise it goes on (discount 1). Elementwise: the single
environment passes scalars, the batch one value per simulation (the Warp engine's `_end` kernel is this rule
per world).

Diverged is MuJoCo's bad-state test (`mju_isBad`: NaN, or beyond +-`mujoco.mjMAXVAL`, 1e10) on qpos, qvel,
qacc, or a control as the step applies it (clamped to its `ctrlrange` where the actuator is ctrl-limited,
unless `<flag clampctrl="disable"/>`; NaN stays NaN): `mj_step` counts a warning for each, which the CPU
engines read (the counters `BAD_STATE` names); MuJoCo Warp counts none, and `warp.worlds` makes the same test on
the device.

The time limit is `time_limit` seconds as a whole number of control steps (`step_limit`): None or inf for no
limit; at most `MAX_CONTROL_STEPS`, the most every engine's int64 step counter holds.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from ..config.units import timestep_problem
from ..errors import ArgumentError

__all__ = ["AUTORESETS", "BAD_SPAN", "BAD_STATE", "MAX_CONTROL_STEPS", "autoreset_mode", "chosen_ids", "episode_end",
           "step_limit", "timed", "truncated"]

MAX_CONTROL_STEPS = 2**63 - 1  # int64: the control steps of an episode every engine counts
_LAST = 2  # dm_env.StepType.LAST
# MuJoCo's warnings that count a bad state (the CPU engines' divergence test: a change of these counts)
BAD_STATE = np.array([int(getattr(mujoco.mjtWarning, f"mjWARN_BAD{w}")) for w in ("QPOS", "QVEL", "QACC", "CTRL")])
# adjacent in MuJoCo's enum (3..6): a slice of the counters is then a live view, compared as bytes
BAD_SPAN = (slice(int(BAD_STATE.min()), int(BAD_STATE.max()) + 1)
            if np.array_equal(BAD_STATE, np.arange(BAD_STATE.min(), BAD_STATE.max() + 1)) else None)

# When a many-simulation engine starts the episode after one that ended (Gymnasium's names for the two modes):
# "next_step": the next step does (dm_env's rule: it returns FIRST and ignores that simulation's action);
# "same_step": the step that ended it does, and returns the new episode's first observation with the old one's
# LAST step type, reward and discount (RSL-RL's, Isaac Lab's and mjlab's rule).
AUTORESETS = ("next_step", "same_step")


def autoreset_mode(autoreset: Any) -> bool:
    """Whether `autoreset` (one of `AUTORESETS`) restarts an ended episode in the same step; anything else is an
    ArgumentError naming the choices."""
    if not isinstance(autoreset, str) or autoreset not in AUTORESETS:
        raise ArgumentError(f"autoreset must be one of {', '.join(map(repr, AUTORESETS))} (when the episode after "
                            f"one that ended starts); got {autoreset!r}")
    return autoreset == "same_step"


def truncated(step_type: Any, discount: Any) -> Any:
    """Per simulation, whether this step ended its episode at the time limit (a truncation: LAST with discount
    1), not by a termination or a divergence (LAST with discount 0). Plain operators: numpy arrays, torch
    tensors (the Warp engine's arrays viewed with `wp.to_torch`)."""
    return (step_type == _LAST) & (discount > 0)


def timed(timestep: float, what: str) -> None:
    """`what`, in seconds, needs physics steps that last a time (a suite's own times are checked at binding)."""
    problem = timestep_problem(timestep)
    if problem is not None:
        raise ArgumentError(f"{what} is in seconds: {problem}")


def step_limit(time_limit: Any, timestep: float, control_timestep: float) -> int | None:
    """The control steps an episode lasts for `time_limit` seconds (the nearest whole number, at least 1), or
    None for no limit (None or inf); what does not fit (not a positive number, or more than
    `MAX_CONTROL_STEPS`) is an ArgumentError saying what does. `timestep`: the model's physics timestep."""
    if time_limit is None:
        return None
    expected = "time_limit must be a positive number of seconds, or None or float('inf') for no limit"
    if isinstance(time_limit, bool) or not isinstance(time_limit, (int, float, np.integer, np.floating)):
        raise ArgumentError(f"{expected}; got {time_limit!r}")
    if time_limit == math.inf:
        return None
    if not time_limit > 0:  # (NaN too)
        raise ArgumentError(f"{expected}; got {time_limit!r}")
    timed(timestep, "time_limit")
    longest = MAX_CONTROL_STEPS * control_timestep
    if time_limit > longest:  # (an exact comparison, a huge integer too)
        raise ArgumentError(f"time_limit {time_limit!r}s is more than {MAX_CONTROL_STEPS:,} control steps of "
                            f"{control_timestep:g}s ({longest:.4g}s), the most an episode can count; give at "
                            f"most {longest:.4g}s, or None or float('inf') for no limit")
    return min(MAX_CONTROL_STEPS, max(1, round(float(time_limit) / control_timestep)))


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
