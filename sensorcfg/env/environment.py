"""A dm_env Environment whose observations are a sensor suite's.

It owns the glue every project otherwise writes by hand: one control step is `physics_steps_per_control_step`
MuJoCo steps with the Updater called after each, episodes start from a reset (or a keyframe) and an optional
`initialize_episode`, end on a time limit (truncation, discount 1), a `termination_fn` (discount 0) or a
diverged simulation (discount 0, reported with a warning and `last_divergence`), and no buffer, bias or
random-walk state survives from one episode to the next.
"""

from __future__ import annotations

import functools
import math
import os
import types
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeAlias

import dm_env
import mujoco
import numpy as np
from dm_env import specs

from ..config.files import model_file
from ..errors import ArgumentError, Problem, SuiteError
from ..groups import Group, layout
from ..physics import Physics, read_model
from ..runtime.updater import Updater
from ..selection import keyframe_id
from .episode import episode_end, step_limit, timed

__all__ = ["NOT_COPYABLE", "ControlLoop", "Environment", "make_env", "load_model", "model_source", "random_state_from",
           "steps_per_control_step", "keyframe_index"]

_BAD_STATE = np.array([int(getattr(mujoco.mjtWarning, f"mjWARN_BAD{w}")) for w in ("QPOS", "QVEL", "QACC", "CTRL")])
# adjacent in MuJoCo's enum (3..6): a slice of the counters is then a live view, compared as bytes
_BAD_SPAN = (slice(int(_BAD_STATE.min()), int(_BAD_STATE.max()) + 1)
             if np.array_equal(_BAD_STATE, np.arange(_BAD_STATE.min(), _BAD_STATE.max() + 1)) else None)
_MID = dm_env.StepType.MID
RewardFn = Callable[[Physics], float]
TerminationFn = Callable[[Physics], bool]
InitializeFn = Callable[[Physics, np.random.RandomState], None]
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


def load_model(model: mujoco.MjModel | str | os.PathLike) -> mujoco.MjModel:
    """An MjModel, or one loaded from an MJCF (or MJB) path (or a `package://` or `menagerie://` name, as in
    a suite's `model:`) with a clear error."""
    if isinstance(model, mujoco.MjModel):
        return model
    path = _model_file(model)
    if not os.path.isfile(path):
        raise SuiteError(f"model file {path!r} does not exist")
    try:
        return read_model(path)
    except ValueError as e:
        raise SuiteError(f"{path}: MuJoCo could not load the model: {e}") from None


def _model_file(model: str | os.PathLike) -> str:
    try:
        return model_file(model)
    except ValueError as e:
        raise SuiteError(f"model {os.fspath(model)!r}: {e}") from None


ModelArg: TypeAlias = "mujoco.MjModel | mujoco.MjSpec | str | os.PathLike[str] | None"


def model_source(model: ModelArg, suite: Any) -> tuple[mujoco.MjModel | mujoco.MjSpec | str, Any]:
    """What an environment runs on, and its suite (loaded when given as a path): `model` (a `package://` or
    `menagerie://` name resolved as a suite's `model:` is), or, when it is None, the suite's own `model:`."""
    if isinstance(suite, (str, os.PathLike)):
        from .. import load
        from ..config.overrides import with_model

        suite = load(suite, with_model(None, model))  # a model given: the suite's `model:` is not resolved
    if model is None:
        if isinstance(suite, Mapping):
            raise ArgumentError("model is None, and a dict of observables names no model: pass an MjModel, an "
                                "MjSpec or a model path")
        path = getattr(suite, "model", None)
        if path is None:
            raise SuiteError(Problem("the suite names no model: add 'model: path/to/robot.xml' to the suite, or "
                                     "pass the model (an MjModel, an MjSpec or a path) as the first argument",
                                     "model", getattr(suite, "file", None)))
        return path, suite
    if isinstance(model, (str, os.PathLike)):
        return _model_file(model), suite
    if not isinstance(model, (mujoco.MjModel, mujoco.MjSpec)):
        raise ArgumentError(f"model must be an MjModel, an MjSpec, a model path (package:// and menagerie:// names "
                            f"too) or None for the suite's 'model:'; got {type(model).__name__}")
    return model, suite


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


def model_and_observables(model: Any, suite: Any, batch: bool = False, extra: Sequence[Any] = (), nsim: int = 1,
                          warp: bool = False) -> tuple[mujoco.MjModel, dict[str, Any], dict[str, Any]]:
    """The model (a path or an MjSpec compiled with the suite's MuJoCo sensor kinds, then the `extra`
    sensors: a batch's relays), its observables and the Updater's keyword arguments, from a Suite, a suite
    path, or a dict of observables; the suite's `options.keyframe` and its observation `groups` (names in
    column order) too, under "keyframe" and "groups" (the environment pops them). With `batch`, what a
    BatchEnvironment cannot run is a problem too (with `warp`, what a WarpEnvironment cannot), and so is what
    the suite's sensors would keep in `nsim` simulations (`Suite._memory_problems`)."""
    if isinstance(suite, Mapping):
        if isinstance(model, (str, os.PathLike, mujoco.MjSpec)) and (extra or isinstance(model, mujoco.MjSpec)):
            from ..native import compile_model

            if not isinstance(model, mujoco.MjSpec):
                load_model(model)  # a missing or broken file: the same error as without extra sensors
            try:
                return compile_model(model, {}, False, extra)[0], dict(suite), {}
            except ValueError as e:
                raise SuiteError(f"MuJoCo could not compile the model: {str(e).strip()}") from None
        return load_model(model), dict(suite), {}
    if isinstance(suite, (str, os.PathLike)):
        from .. import load

        suite = load(suite)
    if isinstance(model, (str, os.PathLike, mujoco.MjSpec)):
        if not isinstance(model, mujoco.MjSpec):
            load_model(model)  # a missing or broken file: the same error as without a suite
        model = suite._compile(model, batch, extra)
    model = load_model(model)
    observables = suite.build(model, batch=True, warp=warp) if batch else suite.build(model)
    problems = suite._memory_problems(observables, model, nsim, batch) if nsim > 1 else []
    if problems:
        raise SuiteError(problems)
    return model, observables, {**suite.updater_kwargs(model), "keyframe": getattr(suite.options, "keyframe", None),
                                "groups": dict(getattr(suite, "groups", {}))}


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


class Environment(ControlLoop, dm_env.Environment):
    """A MuJoCo model stepped with zero-cost glue, observed through a sensor suite.

    `model` is an MjModel, an MjSpec or a path (`package://` and `menagerie://` too), or None for the
    suite's own `model:`; `suite` a `Suite`, a suite path, or a dict of observables.
    The control step is `physics_steps_per_control_step` or `control_timestep` when given, else the suite's
    `options.control_interval`, else one physics step.
    """

    def __init__(self, model: ModelArg, suite: Any, *,
                 physics_steps_per_control_step: int | None = None, control_timestep: float | None = None,
                 time_limit: float | None = None,
                 seed: int | np.random.SeedSequence | np.random.RandomState | None = None,
                 reward_fn: RewardFn | None = None, termination_fn: TerminationFn | None = None,
                 initialize_episode: InitializeFn | None = None, keyframe: int | str | None = None):
        """Compile the model with the suite's sensors, bind them and take one reset for the specs (from its
        own random state: the episodes' stream is untouched until the first `reset`).

        Args:
            model: An MjModel (which must carry the suite's MuJoCo sensors and cameras: `Suite.compile`), an
                MjSpec or a model path (`package://` and `menagerie://` names too), compiled with them; or
                None for the suite's own `model:`.
            suite: A `Suite`, a suite file's path, or a dict of observables (name -> `Observable`).
            physics_steps_per_control_step: MuJoCo steps per control step. Default: the suite's
                `options.control_interval`, else 1.
            control_timestep: The control step in seconds, a whole number of physics steps (instead of
                `physics_steps_per_control_step`, or agreeing with it).
            time_limit: Seconds per episode, rounded to whole control steps (at least one); the step that
                reaches it is LAST with discount 1. None: no limit.
            seed: The episodes' random stream: an integer from 0 to 2**32 - 1 or None (as
                `numpy.random.RandomState(seed)`), a SeedSequence (as `BatchEnvironment` seeds a simulation:
                `sensorcfg.batch.sim_seed`), or a RandomState used as it is.
            reward_fn: `reward_fn(physics) -> float`, after each control step's physics; None: reward 0.
            termination_fn: `termination_fn(physics) -> bool`, after each control step that did not diverge;
                True ends the episode with discount 0.
            initialize_episode: `initialize_episode(physics, random_state)`, at each reset after the model's
                reset state (or keyframe) is set and before `mj_forward`.
            keyframe: The keyframe (index or name) every reset starts from. Default: the suite's
                `options.keyframe`, else the model's reset state.

        Raises:
            SuiteError: The suite has problems against the model (all of them, each at its line), the model
                cannot be loaded, or `keyframe` is not one of the model's.
            ArgumentError: A setting it cannot use: a seed out of range, a `control_timestep` that is not a
                whole number of physics steps, a `time_limit` that is not positive, a model of another type.
            UnsupportedError: A camera sensor without a usable OpenGL library.
        """
        self._model, observables, kwargs = model_and_observables(*model_source(model, suite))
        self._physics = Physics(self._model)
        self._warning_counts = self._physics.data.warning.number  # a live view of MjData's counters
        self._bad_counts = None if _BAD_SPAN is None else self._warning_counts[_BAD_SPAN]
        self._ctrl = self._physics.data.ctrl  # a live view too
        self._physics_step = functools.partial(mujoco.mj_step, self._model, self._physics.data)
        suite_keyframe = kwargs.pop("keyframe", None)
        groups = kwargs.pop("groups", {})
        self._n, self._control_timestep, self._step_limit = episode_timing(
            self._model, physics_steps_per_control_step, control_timestep, time_limit,
            kwargs.pop("physics_steps_per_control_step", None))
        self._observables = observables
        self._updater = Updater(observables, self._n, **kwargs)
        self._random_state = random_state_from(seed)
        self._reward_fn, self._termination_fn, self._initialize = reward_fn, termination_fn, initialize_episode
        self._keyframe = keyframe_index(self._model, keyframe, suite_keyframe)
        self._needs_reset = True
        self._steps = 0
        self.last_divergence: str | None = None
        self._action_spec = action_spec(self._model)
        self._action_shape = self._action_spec.shape
        # Specs need one bound reset; it uses its own random state so the episode streams stay untouched.
        self._reset_physics(np.random.RandomState(0), initialize=False)
        self._updater.reset(self._physics, np.random.RandomState(0))
        self._observation_spec = self._updater.observation_spec()
        self._lay_out_groups(groups)

    # -- properties -------------------------------------------------------------------------------

    @property
    def physics(self) -> Physics:
        return self._physics

    @property
    def updater(self) -> Updater:
        return self._updater

    @property
    def random_state(self) -> np.random.RandomState:
        return self._random_state

    def set_noise_level(self, level: float) -> None:
        """Scale every sensor's noise from the next episode on: 0 clean, 1 the suite's (see
        `sensorcfg.noise.level`); for curricula."""
        from ..noise.level import set_level

        set_level(self._observables, level)

    def seed(self, seed: int | np.random.SeedSequence | None) -> None:
        """Restart the episode random stream (the next reset draws from it)."""
        self._random_state = random_state_from(seed)
        self._needs_reset = True

    # -- episodes ---------------------------------------------------------------------------------

    def _reset_physics(self, random_state: np.random.RandomState, initialize: bool = True) -> None:
        model, data = self._model, self._physics.data
        if self._keyframe is None:
            mujoco.mj_resetData(model, data)
        else:
            mujoco.mj_resetDataKeyframe(model, data, self._keyframe)
        if initialize and self._initialize is not None:
            self._initialize(self._physics, random_state)
        mujoco.mj_forward(model, data)

    def reset(self) -> dm_env.TimeStep:
        self._needs_reset = True  # until this reset completes (an `initialize_episode` may raise)
        self._reset_physics(self._random_state)
        self._updater.reset(self._physics, self._random_state)
        self._steps = 0
        self._needs_reset = False
        self.last_divergence = None
        self._bad_qacc = self._warnings()
        return dm_env.restart(self._updater.get_observation())

    def step(self, action: Any) -> dm_env.TimeStep:
        """One control step. An exception raised during it (by a generic sensor, custom noise, `reward_fn` or
        `termination_fn`) propagates and ends the episode: the physics and the sensors' buffers are left
        mid-step, so the next `step` starts a new episode (returns FIRST), as after a LAST step."""
        if self._needs_reset:
            return self.reset()
        ctrl = self._check_action(action)  # a bad action changes nothing
        try:
            return self._step(ctrl)
        except BaseException:
            self._needs_reset = True
            raise

    def _step(self, ctrl: np.ndarray) -> dm_env.TimeStep:
        self._ctrl[...] = ctrl
        updater = self._updater
        updater.control_step(self._physics_step)  # n x (mj_step, then the Updater's update)
        self._steps += 1
        observation = updater.get_observation()
        reward = 0.0 if self._reward_fn is None else float(self._reward_fn(self._physics))
        bad = self._warnings()
        divergence = None if bad == self._bad_qacc else self._diverged(bad)
        if divergence is not None:
            self.last_divergence = divergence
            warnings.warn(f"sensorcfg: the simulation diverged at t={self._physics.data.time:.4f}s ({divergence}); "
                          "the episode ends here (discount 0)", RuntimeWarning, stacklevel=3)
        terminated = divergence is None and self._termination_fn is not None and self._termination_fn(self._physics)
        last, discount = episode_end(divergence is not None, bool(terminated), self._steps, self._step_limit)
        if last:
            self._needs_reset = True
            return dm_env.TimeStep(dm_env.StepType.LAST, reward, float(discount), observation)
        return dm_env.TimeStep(_MID, reward, 1.0, observation)  # dm_env.transition's

    def _check_action(self, action: Any) -> np.ndarray:
        action = np.asarray(action, dtype=np.float64)
        if action.shape != self._action_shape:
            raise ArgumentError(f"action must have shape ({self._model.nu},) (one control per actuator), "
                                f"got {action.shape}")
        return action

    def _warnings(self) -> list[int]:
        """MuJoCo's counts of bad-state warnings. mj_step checks qpos, qvel (at its start) and qacc for
        non-finite or huge values, resets the state and counts a warning, silently otherwise; so a change of
        the counts is the whole divergence test (a NaN written after the last step is caught at the next one)."""
        counts = self._warning_counts.take(_BAD_STATE) if self._bad_counts is None else self._bad_counts
        return counts.tolist()

    def _diverged(self, bad: list[int]) -> str:
        """After the counts changed: remember them, and the reason the episode ends."""
        self._bad_qacc = bad
        return "MuJoCo found a non-finite or huge qpos, qvel, qacc or ctrl and reset the state"

    def close(self) -> None:
        pass


def make_env(suite_path: str | os.PathLike, model: ModelArg = None, **kwargs: Any) -> Environment:
    """An Environment for a suite file, on the suite's own `model:` unless one is given.

    Args:
        suite_path: The suite file.
        model: What `Environment` takes as its model; None: the suite's own `model:` (not read when given).
        **kwargs: `Environment`'s other arguments (`physics_steps_per_control_step`, `seed`, ...).

    Returns:
        The `Environment`.

    Raises:
        SuiteError: As `Environment`, and for the suite file's own problems (all of them, each at its line).
    """
    return Environment(model, suite_path, **kwargs)
