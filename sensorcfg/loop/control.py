"""The control loop every environment shares (`Environment`, `BatchEnvironment`, `WarpEnvironment`):
`ControlLoop` (its specs, groups and control step; no copies), how many physics steps a control step is and how
long an episode lasts (`steps_per_control_step`, `episode_timing`), the action spec, the keyframe every reset
starts from, and the episode random state for a seed.
"""

from __future__ import annotations

import math
import types
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
from dm_env import specs

from ..errors import ArgumentError
from ..groups import Group, layout
from ..selection import keyframe_id
from .episode import step_limit, timed

__all__ = ["NOT_COPYABLE", "ControlLoop", "action_spec", "episode_timing", "keyframe_index", "not_copyable",
           "random_state_from", "steps_per_control_step"]

# copy.copy, copy.deepcopy and pickle: sensors hold their own physics' MjData (and GL renderers), so a copy
# would read the original's physics; say so instead of returning one.
NOT_COPYABLE = ("{0} cannot be copied or pickled: its sensors are bound to its own MjData and renderers, so a "
                "copy would read the original's physics; build another {1} from the same model and suite{2}")
_HOW_TO_COPY_STATE = {
    "Environment": " (and copy the state with mujoco.mj_copyData(new.physics.data, model, old.physics.data) if "
                   "needed)",
    "BatchEnvironment": ""}


def not_copyable(name: str) -> str:
    """The message for copying or pickling an environment of class `name`."""
    article = "an" if name[:1].lower() in "aeiou" else "a"
    return NOT_COPYABLE.format(f"{article} {name}", name, _HOW_TO_COPY_STATE.get(name, ""))


def random_state_from(seed: int | np.random.SeedSequence | np.random.RandomState | None) -> np.random.RandomState:
    """The episode random state for a seed: an int or None as `numpy.random.RandomState(seed)`; a
    SeedSequence (how `BatchEnvironment` seeds simulation i: `sensorcfg.batch.sim_seed(seed, i)`) seeds
    MT19937 with its full entropy; a RandomState is used as is."""
    if isinstance(seed, np.random.RandomState):
        return seed
    if isinstance(seed, np.random.SeedSequence):
        return np.random.RandomState(np.random.MT19937(seed))
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))
                             or not 0 <= seed <= 2**32 - 1):
        raise ArgumentError(f"seed must be None, an integer from 0 to 2**32 - 1, a numpy SeedSequence or "
                            f"RandomState; got {seed!r}")
    return np.random.RandomState(seed)


def steps_per_control_step(model: mujoco.MjModel, steps: int | None, control_timestep: float | None) -> int:
    """Physics steps per control step from either setting (both: they must agree; neither: 1)."""
    dt = float(model.opt.timestep)
    if control_timestep is not None:
        timed(dt, "control_timestep")
        ratio = float(control_timestep) / dt
        n = round(ratio)
        if n < 1 or not math.isclose(ratio, n, rel_tol=1e-9, abs_tol=1e-9):
            lo, hi = max(1, math.floor(ratio)), max(1, math.ceil(ratio))
            raise ArgumentError(f"control_timestep {control_timestep}s is not a whole number of {dt}s physics steps; "
                                f"use {lo * dt:g}s or {hi * dt:g}s")
        if steps is not None and steps != n:
            raise ArgumentError(f"physics_steps_per_control_step={steps} disagrees with control_timestep="
                                f"{control_timestep}s ({n} steps of {dt}s); give one of them")
        return n
    if steps is None:
        return 1
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 1:
        raise ArgumentError(f"physics_steps_per_control_step must be a positive integer, got {steps!r}")
    return steps


def episode_timing(model: mujoco.MjModel, steps: int | None, control_timestep: float | None,
                   time_limit: float | None, suite_steps: int | None = None) -> tuple[int, float, int | None]:
    """(physics steps per control step, control timestep in s, control steps per episode or None).

    The control step is `steps` or `control_timestep` when given, else the suite's `control_interval`
    (`suite_steps`), else one physics step; `time_limit` (s) becomes a number of control steps (`step_limit`:
    None or inf for no limit).
    """
    if steps is None and control_timestep is None:
        steps = suite_steps
    n = steps_per_control_step(model, steps, control_timestep)
    dt = n * float(model.opt.timestep)
    return n, dt, step_limit(time_limit, float(model.opt.timestep), dt)


def action_spec(model: mujoco.MjModel, leading: tuple[int, ...] = (), dtype: Any = np.float64) -> specs.BoundedArray:
    """One control per actuator, bounded by `ctrlrange` where the actuator is control-limited, of the `dtype`
    the engine's `ctrl` holds (float64 on the CPU engines, float32 on MuJoCo Warp's)."""
    lo, hi = model.actuator_ctrlrange.T.copy()
    limited = model.actuator_ctrllimited.astype(bool)
    return specs.BoundedArray(shape=leading + (model.nu,), dtype=dtype, name="action",
                              minimum=np.where(limited, lo, -np.inf), maximum=np.where(limited, hi, np.inf))


def keyframe_index(model: mujoco.MjModel, keyframe: int | str | None, suite_keyframe: int | str | None) -> int | None:
    """The keyframe every reset starts from: `keyframe` when given, else the suite's `options.keyframe`."""
    chosen = suite_keyframe if keyframe is None else keyframe
    return None if chosen is None else keyframe_id(model, chosen)


class ControlLoop:
    """What every environment exposes about its control loop; subclasses set `_n`, `_control_timestep`,
    `_step_limit`, `_action_spec`, `_observation_spec` and `_batch_shape` (() for one simulation, (nsim,) for a
    batch), then lay out the suite's groups (`_lay_out_groups`). No environment can be copied or pickled
    (`NOT_COPYABLE` says why)."""

    _n: int
    _control_timestep: float
    _step_limit: int | None
    _action_spec: specs.BoundedArray
    _observation_spec: dict[str, specs.Array]
    _batch_shape: tuple[int, ...] = ()
    _groups: Mapping[str, Group] = types.MappingProxyType({})

    def _lay_out_groups(self, groups: Mapping[str, tuple[str, ...]]) -> None:
        """The suite's observation groups (names in column order) laid out by the observation spec's shapes."""
        lead = len(self._batch_shape)
        shapes = {name: tuple(spec.shape[lead:]) for name, spec in self._observation_spec.items()}
        self._groups = types.MappingProxyType(layout(groups, shapes))

    @property
    def step_limit(self) -> int | None:
        """Control steps per episode (the time limit), or None for no limit."""
        return self._step_limit

    def group_spec(self) -> Mapping[str, Group]:
        """The suite's observation groups (`groups:`), in the suite's order: each group's columns (which
        observation lies at which columns of its vector, `Group.columns`) and `width`; empty when the suite has
        none (or the environment was given a dict of observables)."""
        return self._groups

    def groups(self, observation: Mapping[str, Any]) -> dict[str, Any]:
        """Each group's vector from an `observation` of this environment (a step's or a reset's): (width,) for
        one simulation, (n, width) for a batch; numpy arrays from the CPU engines, torch tensors (no copy before
        the concatenation) from the Warp engine's arrays (`Group.concatenate`)."""
        lead = len(self._batch_shape)
        return {name: group.concatenate(observation, lead) for name, group in self._groups.items()}

    @property
    def physics_steps_per_control_step(self) -> int:
        return self._n

    @property
    def control_timestep(self) -> float:
        return self._control_timestep

    def action_spec(self) -> specs.BoundedArray:
        return self._action_spec

    def observation_spec(self) -> dict[str, specs.Array]:
        return self._observation_spec

    def reward_spec(self) -> specs.Array:
        return specs.Array(shape=self._batch_shape, dtype=np.float64, name="reward")

    def discount_spec(self) -> specs.BoundedArray:
        return specs.BoundedArray(shape=self._batch_shape, dtype=np.float64, minimum=0.0, maximum=1.0,
                                  name="discount")

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise TypeError(not_copyable(type(self).__name__))

    def __copy__(self) -> Any:
        raise TypeError(not_copyable(type(self).__name__))

    def __deepcopy__(self, memo: Any) -> Any:
        raise TypeError(not_copyable(type(self).__name__))
