"""`BatchEnvironment`: one sensor suite over nsim simulations of one model, on MuJoCo 4's `mujoco.batch`.

Simulation i behaves exactly as `Environment(model, suite, seed=sim_seed(seed, i))` given the same actions:
the same observations to the bit (intervals, delays, random ones included, buffers, aggregators, noise),
step types, rewards and discounts. One control step of every simulation is one `Batch.rollout` call that
records only the mjData fields the suite reads; observations come from the vectorised `BatchUpdater`.

Seeds: `seed` (an int, a SeedSequence or None) is a `numpy.random.SeedSequence`; simulation i's seed is
its child with spawn key i (`sim_seed(seed, i)`, the same as `SeedSequence(seed).spawn(i + 1)[i]`), whose
full entropy seeds that simulation's episode random state (MT19937, as `Environment` does with a
SeedSequence). Streams therefore depend on the simulation's index only: growing or shrinking `nsim`
leaves the other simulations' streams unchanged. Each sensor's noise then has its own stream per episode
(`sensor_key(episode entropy, sensor name)`), as in the single simulation.

Episodes start from `keyframe` (a name or an index), else the suite's `options.keyframe`, else the model's
reset state. Episodes (auto-reset, by default as dm_env and Gymnasium's next-step mode,
`autoreset="next_step"`): a simulation whose last step ended its episode (time limit: truncation, discount 1;
divergence or `termination_fn`: termination, discount 0; `BatchTimeStep.truncated()` tells them apart) is
reset by the next `step`, which returns FIRST for it and ignores its action; so does every simulation before
the first `reset`. With `autoreset="same_step"` (RSL-RL's, Isaac Lab's and mjlab's rule) the step that ends an
episode starts the next one: it returns LAST with the ended episode's reward and discount, and the new
episode's first observation; the new episode draws what it would draw in next-step mode (its noise's and
schedules' keys, in the same order from the simulation's random state), so its observations are the same given
the same actions. `reset(ids)` restarts the given simulations now (all when None): their physics, buffers and
per-episode noise only. It returns every simulation's observation, FIRST for the reset ones and MID for
the others; rewards are 0 and discounts 1 at FIRST steps. A simulation stepped for the step on which it is
reset costs one control step of physics whose result is discarded (the batch steps all simulations at
once).

Divergence is per simulation, from the batch's own error state: a simulation whose MuJoCo call raised
(`SimulationError`, `Batch.error(i)`) or whose bad-state warning counters rose (the test `Environment`
makes: MuJoCo checks qpos, qvel and qacc at every step) ends its episode with discount 0, its message in
`last_divergence[i]` (and a RuntimeWarning); the others go on. The batch stops stepping a simulation at
its first warning, so the observation of that last step may differ from a single simulation's (which
MuJoCo resets and steps on).

Relays: given the model as a path or an MjSpec, the batch may compile it with a few more MuJoCo sensors,
appended after the model's own (whose `sensordata` positions do not move), that copy the values a suite
reads of a wide field (a body's orientation, a site's frame) so that a control step records `sensordata`
instead of the whole field (`batch.relay`: they are used only where they pay and only once checked to copy
bit for bit; never with RK4). The observations are the same; the batch's model (`batch.get_model()`) has
those sensors. An MjModel is used as it is.

Cameras render per simulation: each sampled frame costs a `get_data` and a render of that simulation
(a Python loop over the simulations that sample it), the batch keeps one MjData per simulation
(`persistent=True`), and a control step becomes one rollout per substep at which a camera samples.
Frames no read can see are never rendered. Generic callables, corruptors and custom aggregators are
rejected before stepping (they would run Python per sample and simulation); so are noise stages without a
batched form (custom) and drawn intervals or delays other than `{uniform}` / `{choice}`.

The control step is chosen as `Environment` chooses it: `physics_steps_per_control_step` or
`control_timestep` when given, else the suite's `options.control_interval`, else one physics step.
Rewards and terminations are vectorised as the physics is: `reward_fn(batch)` returns one reward per
simulation and `termination_fn(batch)` one bool per simulation, from the `mujoco.batch.Batch` after the
step (state fields such as `batch.qpos` are current; derived ones such as `batch.xpos` are current once
bound, `batch.bind(name)`, which MuJoCo then copies out after every call), before the step restarts the
simulations whose previous step ended their episode. Only stepped simulations use them: a simulation's FIRST
step has reward 0. A termination ends the episode with discount 0, as a divergence does (which takes
precedence); without `reward_fn`, rewards are 0. One that raises ends every simulation's episode (`step`).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, NamedTuple

import dm_env
import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..draws import root_seed, sim_seed
from ..errors import ArgumentError, SuiteError, UnsupportedError
from ..loop.control import ControlLoop, action_spec, episode_timing, keyframe_index, random_state_from
from ..loop.episode import BAD_STATE, autoreset_mode, chosen_ids, episode_end, truncated
from ..loop.model import ModelArg, model_and_observables, model_source
from ..noise.level import leveled, set_level
from ..physics import Physics
from . import relay
from .updater import BatchUpdater

if TYPE_CHECKING:
    from mujoco.batch import Batch

__all__ = ["BatchEnvironment", "BatchTimeStep"]

BatchRewardFn = Callable[[Any], Any]  # mujoco.batch.Batch -> (nsim,) rewards
BatchTerminationFn = Callable[[Any], Any]  # mujoco.batch.Batch -> (nsim,) bools

_BAD_INDEX = np.array([int(w) for w in BAD_STATE])
_FIRST: int = int(dm_env.StepType.FIRST)
_MID: int = int(dm_env.StepType.MID)
_LAST: int = int(dm_env.StepType.LAST)


def _batch_module() -> Any:
    try:
        if int(mujoco.__version__.split(".")[0]) < 4:  # MuJoCo 3 has an unrelated `mujoco.batch`
            raise ImportError
        from mujoco import batch
    except (ImportError, ValueError):
        raise UnsupportedError(f"BatchEnvironment needs MuJoCo 4 (its mujoco.batch module); this is mujoco "
                               f"{mujoco.__version__}: pip install 'mujoco>=4', or use sensorcfg.Environment per "
                               "simulation") from None
    return batch


class _Rollout(NamedTuple):
    """A segment's `rollout` call: its substeps, the last one, the fields it records and where, and per field
    bound instead of recorded, (its record slot, the batch's bound view)."""

    length: int
    last: int
    fields: list[str]
    out: dict[str, np.ndarray]
    bound: list[tuple[np.ndarray, np.ndarray]]


def _check_arguments(nsim: Any, nthread: Any, reward_fn: Any, termination_fn: Any) -> None:
    for label, fn in (("reward_fn", reward_fn), ("termination_fn", termination_fn)):
        if fn is not None and not callable(fn):
            raise ArgumentError(f"{label} must be a callable taking the mujoco.batch.Batch, got {fn!r}")
    if not isinstance(nsim, (int, np.integer)) or isinstance(nsim, bool) or nsim < 1:
        raise ArgumentError(f"nsim must be a positive integer (simulations), got {nsim!r}")
    if nthread is not None and (not isinstance(nthread, (int, np.integer)) or nthread < 0):
        raise ArgumentError(f"nthread must be a non-negative integer (0: every CPU), got {nthread!r}")


class BatchTimeStep(NamedTuple):
    """A dm_env TimeStep per simulation: arrays with a leading nsim axis. With `autoreset="same_step"` a LAST
    step's observation is the new episode's first."""

    step_type: NDArray[np.uint8]  # (nsim,) dm_env.StepType values
    reward: np.ndarray  # (nsim,) float64
    discount: np.ndarray  # (nsim,) float64
    observation: dict[str, np.ndarray]  # (nsim, ...) each

    def _is(self, step_type: int) -> NDArray[np.bool_]:
        matches: NDArray[np.bool_] = self.step_type == step_type  # (numpy types == as Any)
        return matches

    def first(self) -> NDArray[np.bool_]:
        return self._is(_FIRST)

    def mid(self) -> NDArray[np.bool_]:
        return self._is(_MID)

    def last(self) -> NDArray[np.bool_]:
        return self._is(_LAST)

    def truncated(self) -> NDArray[np.bool_]:
        """The simulations whose episode this step ended at the time limit (LAST, discount 1)."""
        ended: NDArray[np.bool_] = truncated(self.step_type, self.discount)
        return ended

    def terminated(self) -> NDArray[np.bool_]:
        """The simulations whose episode this step ended by a termination or a divergence (LAST, discount 0)."""
        ended: NDArray[np.bool_] = self.last() & (self.discount == 0)
        return ended


class BatchEnvironment(ControlLoop):
    """nsim simulations of one MuJoCo model, stepped together and observed through one sensor suite.

    `model` is what `Environment` takes: an MjModel, an MjSpec or a path (`package://`, `menagerie://`), or
    None for the suite's own `model:` (`BatchEnvironment(None, "suite.yaml", 64)`).
    """

    def __init__(self, model: ModelArg, suite: Any, nsim: int, *,
                 nthread: int | None = None, physics_steps_per_control_step: int | None = None,
                 control_timestep: float | None = None, time_limit: float | None = None,
                 seed: int | np.random.SeedSequence | None = None, reward_fn: BatchRewardFn | None = None,
                 termination_fn: BatchTerminationFn | None = None, keyframe: int | str | None = None,
                 autoreset: str = "next_step"):
        """Compile the model with the suite's sensors, check that the batch runs every one of them, and make
        the `mujoco.batch.Batch` of `nsim` simulations (each reset by the first `step` or `reset`).

        Args:
            model: What `Environment` takes: an MjModel, an MjSpec or a model path (`package://` and
                `menagerie://` names too), or None for the suite's own `model:`.
            suite: A `Suite`, a suite file's path, or a dict of observables (name -> `Observable`).
            nsim: The number of simulations (a positive integer).
            nthread: Threads `mujoco.batch` steps them with; None or 0: every CPU.
            physics_steps_per_control_step: MuJoCo steps per control step. Default: the suite's
                `options.control_interval`, else 1.
            control_timestep: The control step in seconds, a whole number of physics steps (instead of
                `physics_steps_per_control_step`, or agreeing with it).
            time_limit: Seconds per episode, rounded to whole control steps (at least one); the step that
                reaches it is LAST with discount 1. None: no limit.
            seed: The root seed (a non-negative integer, a SeedSequence or None); simulation i draws from
                `sim_seed(seed, i)`, so it is `Environment(model, suite, seed=sim_seed(seed, i))`.
            reward_fn: `reward_fn(batch) -> (nsim,) rewards` from the `mujoco.batch.Batch` after the step;
                None: rewards 0.
            termination_fn: `termination_fn(batch) -> (nsim,) bools`; True ends that simulation's episode with
                discount 0.
            keyframe: The keyframe (index or name) every reset starts from. Default: the suite's
                `options.keyframe`, else the model's reset state.
            autoreset: When the episode after one that ended starts: "next_step" (the next step, which
                returns FIRST and ignores that simulation's action) or "same_step" (the step that ended it,
                which returns the new episode's first observation with the ended one's LAST).

        Raises:
            UnsupportedError: MuJoCo 3, which has no `mujoco.batch`.
            SuiteError: The suite has problems against the model or a batch does not run one of its sensors
                (all of them, each at its line; `sensorcfg validate --engine batch` reports the same), or
                `keyframe` is not one of the model's.
            ArgumentError: A setting it cannot use: `nsim`, `nthread`, a seed, a callable that is not one,
                a `control_timestep` that is not a whole number of physics steps, a `time_limit` that is not
                positive, an `autoreset` that is not one of the two.
        """
        batch_module = _batch_module()
        _check_arguments(nsim, nthread, reward_fn, termination_fn)
        self._same_step = autoreset_mode(autoreset)
        self._reward_fn, self._termination_fn = reward_fn, termination_fn
        model, suite = model_source(model, suite)  # None: the suite's own `model:`
        self._model, observables, options = model_and_observables(model, suite, batch=True, nsim=int(nsim))
        leveled(observables)  # a noise level per simulation (`set_noise_level`), 1 until set
        self._observables = observables
        self._nsim = int(nsim)
        self._batch_shape = (self._nsim,)
        self._keyframe = keyframe_index(self._model, keyframe, options.pop("keyframe", None))
        groups = options.pop("groups", {})
        self._n, self._control_timestep, self._step_limit = episode_timing(
            self._model, physics_steps_per_control_step, control_timestep, time_limit,
            options.get("physics_steps_per_control_step"))
        flags: dict[str, bool] = {k: bool(options[k]) for k in ("strip_singleton_buffer_dim", "pad_with_initial_value")
                                  if k in options}
        self._updater = self._updater_for(self._model, observables, flags)
        if isinstance(model, (str, os.PathLike, mujoco.MjSpec)):
            self._relay(model, suite, flags)
        cameras = self._updater.cameras
        # cameras render a simulation's whole MjData after its step: one MjData per simulation
        self._batch = batch_module.Batch(self._model, self._nsim, 0 if nthread is None else int(nthread),
                                         persistent=cameras is not None)
        if cameras is not None:
            cameras.batch = self._batch
        self._simulation_error = batch_module.SimulationError
        # one rollout per segment of the control step, each recording only the fields its substeps need;
        # those needed only after its last substep are bound instead, and copied into their record slots
        self._segments = self._rollout_segments()
        # Reset samples come from each reset simulation's own MjData (get_data, then mj_forward unless the
        # batch is persistent), not from bound derived fields (only those read after a segment are bound).
        self._scratch = mujoco.MjData(self._model)
        self._seed = root_seed(seed)
        self._random_states = [random_state_from(sim_seed(self._seed, i)) for i in range(self._nsim)]
        self._needs_reset = np.ones(self._nsim, bool)
        self._control_steps = np.zeros(self._nsim, np.int64)  # what the time limit counts (`control_steps`)
        self._bad = np.zeros(self._nsim, np.int64)
        self.last_divergence: list[str | None] = [None] * self._nsim
        self._action_spec = action_spec(self._model, (self._nsim,))
        self._observation_spec = self._updater.observation_spec()
        self._lay_out_groups(groups)

    def _updater_for(self, model: mujoco.MjModel, observables: dict[str, Any], flags: dict[str, bool],
                     relays: Mapping[str, Mapping[int, int]] | None = None) -> BatchUpdater:
        physics = Physics(model)
        mujoco.mj_forward(model, physics.data)
        return BatchUpdater(observables, physics, self._nsim, self._n, **flags, relays=relays)

    def _relay(self, source: Any, suite: Any, flags: dict[str, bool]) -> None:
        """The model compiled again with relays (`batch.relay`) where they pay and copy exactly, and the
        updater reading them; else the model as it is."""
        layout = self._updater.layout
        chosen = relay.choose(self._model, layout.sources, layout.recorded(), self._n)
        if chosen is None:
            return
        try:
            model, observables, _ = model_and_observables(source, suite, batch=True, extra=chosen.records)
        except (SuiteError, ValueError):  # MuJoCo refused a relay: the model as it is
            return
        where = relay.positions(model, chosen)
        if not relay.exact(model, where):
            return
        leveled(observables)
        self._model, self._observables = model, observables
        self._updater = self._updater_for(model, observables, flags, where)

    def _rollout_segments(self) -> list[_Rollout]:
        """One `rollout` call per segment of the control step (`Layout.segments`)."""
        layout = self._updater.layout
        return [_Rollout(segment.last - segment.first + 1, segment.last, list(out), out,
                         [(slot, self._batch.bind(f).reshape(self._nsim, -1)[:, span])
                          for f, (slot, span) in bound.items()])
                for segment, out, bound in zip(layout.segments, layout.record_out, layout.bound_out)]

    def set_noise_level(self, level: float) -> None:
        """Scale every sensor's noise from each simulation's next episode on: 0 clean, 1 the suite's (see
        `sensorcfg.noise.level`); simulation i at level x equals `Environment` at level x."""
        set_level(self._observables, level)

    # -- properties -------------------------------------------------------------------------------

    @property
    def nsim(self) -> int:
        return self._nsim

    @property
    def batch(self) -> Batch:
        """The `mujoco.batch.Batch` (state fields are writable there; write them before a step)."""
        return self._batch

    @property
    def updater(self) -> BatchUpdater:
        return self._updater

    @property
    def autoreset(self) -> str:
        """When the episode after one that ended starts: "next_step" or "same_step" (`__init__`)."""
        return "same_step" if self._same_step else "next_step"

    @property
    def control_steps(self) -> NDArray[np.int64]:
        """(nsim,) control steps since each simulation's reset: what the time limit counts. Writable (a write
        moves that simulation's time limit, not its sensors' clocks): RSL-RL's `init_at_random_ep_len`
        staggers the first episodes so."""
        return self._control_steps

    @property
    def seed_sequence(self) -> np.random.SeedSequence:
        """The batch's root seed; simulation i's is `sim_seed(seed_sequence, i)`."""
        return self._seed

    def seed(self, seed: int | np.random.SeedSequence | None) -> None:
        """Reseed every simulation (simulation i from `sim_seed(seed, i)`); the next step resets them all."""
        self._seed = root_seed(seed)
        self._random_states = [random_state_from(sim_seed(self._seed, i)) for i in range(self._nsim)]
        self._updater.started[:] = False  # no episode to rewind in the new streams
        self._needs_reset[:] = True

    # -- episodes ---------------------------------------------------------------------------------

    def _ids(self, ids: ArrayLike | None) -> np.ndarray:
        """Validated simulation ids (sorted, unique) from None, integers or a boolean mask."""
        return chosen_ids(ids, self._nsim)

    def _reset_sims(self, ids: np.ndarray) -> None:
        """Physics and updater reset of `ids` (non-empty)."""
        try:
            self._batch.reset(ids, keyframe=-1 if self._keyframe is None else self._keyframe)
        except self._simulation_error as e:  # a reset that raises: report it, keep it for the next step
            raise SuiteError(f"resetting simulations {list(e.ids)[:5]} raised in MuJoCo: {e}") from None
        data, values = self._scratch, self._updater.reset_values
        persistent = self._batch.persistent
        for i in ids:  # per reset simulation: its reset state, forwarded as the reset computed it
            self._batch.get_data(int(i), data)
            if not persistent:
                mujoco.mj_forward(self._model, data)
            for f in values:
                values[f][i] = getattr(data, f)
        self._updater.reset(ids, self._random_states)
        self._needs_reset[ids] = False
        self._control_steps[ids] = 0
        self._bad[ids] = self._bad_counts()[ids]
        for i in ids:
            self.last_divergence[int(i)] = None

    def reset(self, ids: ArrayLike | None = None) -> BatchTimeStep:
        """Start new episodes of simulations `ids` (all when None); the others continue."""
        ids = self._ids(ids)
        if ids.size:
            self._reset_sims(ids)
        step_type = np.full(self._nsim, _MID, np.uint8)
        step_type[ids] = _FIRST
        return BatchTimeStep(step_type, np.zeros(self._nsim), np.ones(self._nsim), self._updater.get_observation())

    def step(self, actions: ArrayLike) -> BatchTimeStep:
        """One control step of every simulation (auto-resetting those whose episode ended: `autoreset`).

        An exception raised during it (by `reward_fn` or `termination_fn`) propagates and ends every
        simulation's episode: the next `step` resets them all (FIRST), as after a LAST step."""
        actions = self._check_actions(actions)  # a bad action changes nothing
        try:
            return self._step(actions)
        except BaseException:
            self._needs_reset[:] = True
            raise

    def _step(self, actions: np.ndarray) -> BatchTimeStep:
        restart = self._needs_reset.copy()
        active = ~restart
        updater = self._updater
        failed = np.zeros(self._nsim, bool)
        messages: dict[int, str] = {}
        if active.any():
            updater.prepare(active)
            self._rollout(actions, active, failed, messages)
            updater.update(active)
            self._control_steps[active] += 1
        # rewards, terminations and episode ends before the restarts (as the Warp engine orders them): one that
        # raises leaves the simulations to restart as they were, and `step` restarts every simulation next
        reward = np.zeros(self._nsim)
        if self._reward_fn is not None:
            reward[active] = self._per_simulation("reward_fn", self._reward_fn, np.float64)[active]
        terminated = (active & self._per_simulation("termination_fn", self._termination_fn, bool)
                      if self._termination_fn is not None else False)
        diverged = self._diverged(active, failed, messages)
        last, ending = episode_end(diverged, terminated, self._control_steps, self._step_limit)
        last &= active
        ids = np.flatnonzero(restart | last if self._same_step else restart)
        if ids.size:
            self._reset_sims(ids)
        observation = updater.get_observation()
        step_type = np.full(self._nsim, _MID, np.uint8)
        discount = np.ones(self._nsim)
        step_type[restart] = _FIRST
        if last.any():
            step_type[last] = _LAST
            discount[last] = ending[last]
            if not self._same_step:
                self._needs_reset |= last
        return BatchTimeStep(step_type, reward, discount, observation)

    def _per_simulation(self, label: str, fn: Callable[[Any], Any], dtype: Any) -> np.ndarray:
        """`fn(batch)` as one value per simulation."""
        try:
            values = np.asarray(fn(self._batch), dtype=dtype)
        except (TypeError, ValueError) as e:
            raise ArgumentError(f"{label} must return {self._nsim} numbers (one per simulation): {e}") from None
        if values.shape != (self._nsim,):
            raise ArgumentError(f"{label} returned shape {values.shape}; it must return one value per simulation, "
                                f"shape ({self._nsim},)")
        return values

    def _rollout(self, actions: np.ndarray, active: np.ndarray, failed: np.ndarray, messages: dict[int, str]) -> None:
        """The control step's physics: one rollout per segment of substeps (`Layout.segments`), recording
        into the updater's store; cameras render after the substeps at which they sample."""
        updater = self._updater
        cameras = updater.cameras
        stops = set() if cameras is None else set(cameras.render_substeps(updater.age, active))
        control = actions[:, None, :]
        for length, last, fields, out, bound in self._segments:
            try:
                self._batch.rollout(length, control=control, record=fields, out=out)
            except self._simulation_error as e:  # those simulations kept their state; the others ran
                failed[e.ids] = True
                for i in e.ids:
                    messages.setdefault(int(i), f"MuJoCo raised: {self._batch.error(int(i))}")
            for slot, values in bound:
                np.copyto(slot, values)
            if cameras is not None and last in stops:  # stops are cameras' substeps
                cameras.sample(last, updater.age, active)

    def _bad_counts(self) -> np.ndarray:
        warning = self._batch.warning  # (nsim, mjNWARNING, (lastinfo, number))
        counts: np.ndarray = warning[:, _BAD_INDEX, 1].sum(axis=1, dtype=np.int64)
        return counts

    def _diverged(self, active: np.ndarray, failed: np.ndarray, messages: dict[int, str]) -> np.ndarray:
        bad = self._bad_counts()
        warned = bad != self._bad
        self._bad = bad
        diverged: np.ndarray = active & (failed | warned)
        if diverged.any():
            for at in np.flatnonzero(diverged):
                i = int(at)
                self.last_divergence[i] = messages.get(i) or (
                    "MuJoCo found a non-finite or huge qpos, qvel, qacc or ctrl")
            first = [int(i) for i in np.flatnonzero(diverged)[:5]]
            warnings.warn(f"sensorcfg: {int(diverged.sum())} of {self._nsim} simulations diverged ({first}"
                          f"{', ...' if diverged.sum() > 5 else ''}; simulation {first[0]}: "
                          f"{self.last_divergence[first[0]]}); their episodes end here (discount 0)",
                          RuntimeWarning, stacklevel=4)
        return diverged

    def _check_actions(self, actions: ArrayLike) -> np.ndarray:
        try:
            arr = np.asarray(actions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ArgumentError(f"actions must be a ({self._nsim}, {self._model.nu}) array of numbers") from None
        if arr.shape != (self._nsim, self._model.nu):
            raise ArgumentError(f"actions must have shape ({self._nsim}, {self._model.nu}) (one control per simulation "
                                f"and actuator), got {arr.shape}")
        return arr

    def close(self) -> None:
        pass
