"""A dm_env Environment whose observations are a sensor suite's.

It owns the glue every project otherwise writes by hand: one control step is `physics_steps_per_control_step`
MuJoCo steps with the Updater called after each, episodes start from a reset (or a keyframe) and an optional
`initialize_episode`, end on a time limit (truncation, discount 1), a `termination_fn` (discount 0) or a
diverged simulation (discount 0, reported with a warning and `last_divergence`), and no buffer, bias or
random-walk state survives from one episode to the next. What it shares with the other environments (the
control loop, the model and suite loading, the episode rules) is `sensorcfg/loop/`.
"""

from __future__ import annotations

import functools
import os
import warnings
from collections.abc import Callable
from typing import Any

import dm_env
import mujoco
import numpy as np

from ..errors import ArgumentError
from ..loop.control import ControlLoop, action_spec, episode_timing, keyframe_index, random_state_from
from ..loop.episode import BAD_SPAN, BAD_STATE, episode_end
from ..loop.model import ModelArg, model_and_observables, model_source
from ..physics import Physics
from ..runtime.updater import Updater

__all__ = ["Environment", "make_env"]

_MID = dm_env.StepType.MID
RewardFn = Callable[[Physics], float]
TerminationFn = Callable[[Physics], bool]
InitializeFn = Callable[[Physics, np.random.RandomState], None]


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
        self._bad_counts = None if BAD_SPAN is None else self._warning_counts[BAD_SPAN]
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
        counts = self._warning_counts.take(BAD_STATE) if self._bad_counts is None else self._bad_counts
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
