"""`WarpEnvironment`: one sensor suite over `nworld` MuJoCo Warp worlds, on a GPU or Warp's CPU device.

`BatchEnvironment`'s interface and episode rules (auto-reset per world, time limits, keyframes, rewards and
terminations vectorised, divergence ending a world's episode with discount 0), with actions in and
observations out as Warp arrays on the device: `wp.to_torch` / DLPack views, no host copy per step.

The suite runs as its plan (`sensorcfg.plan`) executed by `warp.sensors`: world w of a process with
`world_offset` o draws the streams of global world o + w (its seed is `sim_seed(seed, o + w)`, as simulation
o + w of a `BatchEnvironment`), so N processes of n worlds give exactly the worlds of one batch of N n.

What is exact and what agrees to float32 rounding (README, "The GPU engine"): schedules, which samples each
read shows and which random numbers each sample draws are the CPU engines' exactly; a noise-free read
without aggregator is a copy of MuJoCo Warp's float32 field at the step its window names; noise arithmetic
and aggregators run on float32 samples, so they agree with the CPU's to float32 rounding.

Per control step: actions into `ctrl` (worlds about to restart ignore theirs), `substeps` physics steps each
followed by the batched generic callables (`warp.generic`) and the sensors' record, the rewards, terminations
and step types (`_end`), the restart of the worlds whose previous step ended their episode (with
`autoreset="same_step"`: of those whose episode this step ended, in this step, as `BatchEnvironment` does; on
the device, a mask and a conditional node of the step's graph), one `mjw.forward` of every world when any
restarts (the restarted worlds' reset samples need their derived fields), then the reads. Episode keys are
drawn on the host, a table of `key_episodes` episodes per world ahead; the host tops it up every
`key_episodes // 4` control steps (one small copy).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import dm_env
import numpy as np
import warp as wp
from dm_env import specs

from ..errors import ArgumentError
from ..loop.control import ControlLoop, action_spec, episode_timing, keyframe_index
from ..loop.episode import autoreset_mode, chosen_ids
from ..loop.model import ModelArg, model_and_observables, model_source
from ..noise.level import leveled, set_level
from .layer import EpisodeKeys, SensorLayer, bind_suite
from .philox import MODULE_OPTIONS
from .quiet import quiet
from .worlds import Worlds

__all__ = ["WarpEnvironment", "WarpTimeStep"]

wp.set_module_options(MODULE_OPTIONS)

WarpFn = Callable[["WarpEnvironment"], wp.array]  # the environment -> (nworld,) device array
_FIRST, _MID, _LAST = (int(t) for t in (dm_env.StepType.FIRST, dm_env.StepType.MID, dm_env.StepType.LAST))


class WarpTimeStep(NamedTuple):
    """A dm_env TimeStep per world: (nworld,) device arrays, observations (nworld, ...) float32
    (a camera's: its CPU dtype, as vectors of its channels: `warp.cameras`). With `autoreset="same_step"` a
    LAST step's observation is the new episode's first."""

    step_type: wp.array
    reward: wp.array
    discount: wp.array
    observation: dict[str, wp.array]

    def truncated(self) -> wp.array:
        """(nworld,) bool, on the device: the worlds whose episode this step ended at the time limit (LAST,
        discount 1; `loop.episode.truncated`)."""
        return self._ended(True)

    def terminated(self) -> wp.array:
        """(nworld,) bool, on the device: the worlds whose episode this step ended by a termination or a
        divergence (LAST, discount 0)."""
        return self._ended(False)

    def _ended(self, by_time: bool) -> wp.array:
        out = wp.empty(self.step_type.shape, dtype=bool, device=self.step_type.device)
        wp.launch(_ended, dim=out.shape, inputs=[self.step_type, self.discount, int(by_time)], outputs=[out],
                  device=out.device)
        return out


@wp.struct
class EpisodeRules:
    """When an episode ends and the next starts (`loop.episode`): after `limit` control steps (0: no limit), and
    with `same_step` (1) in the step that ended it, else (0) in the next."""

    limit: wp.int64
    same_step: wp.int32


@wp.struct
class EpisodeState:
    """Per world, where its episode is: `needs_reset` (1: the next step restarts it), `restarting` (1: this step
    restarts it), `starting` (1: its episode starts now, after this step's physics) and `control_steps` since
    its reset (what the time limit counts)."""

    needs_reset: wp.array[wp.int32]
    restarting: wp.array[wp.int32]
    starting: wp.array[wp.int32]
    control_steps: wp.array[wp.int64]


@wp.struct
class StepFields:
    """Per world, the control step's dm_env TimeStep fields (`WarpTimeStep`'s arrays)."""

    step_type: wp.array[wp.int32]
    reward: wp.array[wp.float32]
    discount: wp.array[wp.float32]


@wp.kernel
def _control(
    # In:
    actions: wp.array2d[wp.float32], restart: wp.array[wp.int32],
    # Data out:
    ctrl: wp.array2d[wp.float32],
):
    w, a = wp.tid()
    if restart[w] == 0:
        ctrl[w, a] = actions[w, a]


@wp.kernel
def _to_float32(
    # In:
    actions: wp.array2d[wp.float64],
    # Out:
    out: wp.array2d[wp.float32],
):
    """float64 actions rounded to float32 (to nearest, as numpy's `astype(np.float32)` rounds a host array)."""
    w, a = wp.tid()
    out[w, a] = wp.float32(actions[w, a])


@wp.kernel
def _begin(
    # In and out: `needs_reset` into `restarting`; `control_steps` advanced, or 0 where it restarts
    episode: EpisodeState,
):
    w = wp.tid()
    episode.restarting[w] = episode.needs_reset[w]
    if episode.needs_reset[w] == 1:
        episode.control_steps[w] = wp.int64(0)
    else:
        episode.control_steps[w] = episode.control_steps[w] + wp.int64(1)


@wp.kernel
def _end(
    # In: the episode rules, and per world this step's divergence, termination and reward
    rules: EpisodeRules, diverged: wp.array[bool], terminated: wp.array[bool], reward_in: wp.array[wp.float32],
    # In and out: `restarting` and `control_steps` in; `needs_reset`, `starting` (and `control_steps`) out
    episode: EpisodeState,
    # Out:
    fields: StepFields,
):
    """The step's types, rewards and discounts, and the worlds whose episode starts now (`starting`): those
    that needed a reset, and with `same_step` those whose episode this step ended (their time limit's count
    restarts: `control_steps` 0); without it, those are reset by the next step (`needs_reset`)."""
    w = wp.tid()
    if episode.restarting[w] == 1:
        fields.step_type[w] = 0
        fields.reward[w] = wp.float32(0.0)
        fields.discount[w] = wp.float32(1.0)
        episode.needs_reset[w] = 0
        episode.starting[w] = 1
        return
    limit = rules.limit
    terminal = diverged[w] or terminated[w]
    last = terminal or (limit > wp.int64(0) and episode.control_steps[w] >= limit)  # (`loop.episode.episode_end`)
    fields.step_type[w] = wp.where(last, 2, 1)
    fields.reward[w] = reward_in[w]
    fields.discount[w] = wp.where(terminal, wp.float32(0.0), wp.float32(1.0))
    now = last and rules.same_step == 1
    episode.needs_reset[w] = wp.where(last and not now, 1, 0)
    episode.starting[w] = wp.where(now, 1, 0)
    if now:
        episode.control_steps[w] = wp.int64(0)


@wp.kernel
def _ended(
    # In:
    step_type: wp.array[wp.int32], discount: wp.array[wp.float32], by_time: int,
    # Out:
    out: wp.array[bool],
):
    """LAST steps with discount 1 (`by_time`: truncations) or 0 (terminations)."""
    w = wp.tid()
    out[w] = step_type[w] == 2 and (discount[w] > wp.float32(0.0)) == (by_time == 1)


@wp.kernel
def _mask(
    # In:
    ids: wp.array[wp.int32],
    # Out:
    mask: wp.array[wp.int32],
):
    mask[ids[wp.tid()]] = 1


@wp.kernel
def _any(
    # In:
    mask: wp.array[wp.int32],
    # Out:
    out: wp.array[wp.int32],
):
    w = wp.tid()
    if mask[w] == 1:
        out[0] = 1


@wp.kernel
def _started(
    # In:
    mask: wp.array[wp.int32],
    # Out: the masked worlds' `needs_reset` and `control_steps` 0
    episode: EpisodeState,
):
    w = wp.tid()
    if mask[w] == 1:
        episode.needs_reset[w] = 0
        episode.control_steps[w] = wp.int64(0)


class WarpEnvironment(ControlLoop):
    """`nworld` MuJoCo Warp worlds of one model, observed through one sensor suite (see the module's doc and
    `__init__`'s arguments)."""

    @quiet
    def __init__(self, model: ModelArg, suite: Any, nworld: int, *, device: str | None = None,
                 physics_steps_per_control_step: int | None = None, control_timestep: float | None = None,
                 time_limit: float | None = None, seed: int | np.random.SeedSequence | None = None,
                 reward_fn: WarpFn | None = None, termination_fn: WarpFn | None = None,
                 keyframe: int | str | None = None, world_offset: int = 0, key_episodes: int = 8,
                 nconmax: int | None = None, njmax: int | None = None, capture: bool | None = None,
                 autoreset: str = "next_step"):
        """Compile the model with the suite's sensors, check that the engine runs every one of them, and put
        the model and `nworld` worlds on `device` (each reset by the first `step` or `reset`).

        Args:
            model: What `Environment` takes: an MjModel, an MjSpec or a model path (`package://` and
                `menagerie://` names too), or None for the suite's own `model:`.
            suite: A `Suite`, a suite file's path, or a dict of observables (name -> `Observable`).
            nworld: The number of worlds in this process (a positive integer).
            device: A Warp device ("cuda:0", "cpu"); None: Warp's default.
            physics_steps_per_control_step: MuJoCo steps per control step. Default: the suite's
                `options.control_interval`, else 1.
            control_timestep: The control step in seconds, a whole number of physics steps (instead of
                `physics_steps_per_control_step`, or agreeing with it).
            time_limit: Seconds per episode, rounded to whole control steps (at least one); the step that
                reaches it is LAST with discount 1. None: no limit.
            seed: The root seed (a non-negative integer, a SeedSequence or None): world w draws as simulation
                `world_offset + w` of a `BatchEnvironment` with this seed.
            reward_fn: `reward_fn(env) -> (nworld,) float32 device array` from `env.data` as the step's physics
                left it, before any restart (on a GPU it is recorded into the step's CUDA graph: device work
                only, no host reads); None: rewards 0.
            termination_fn: `termination_fn(env) -> (nworld,) bool device array`, as `reward_fn`; True ends
                that world's episode with discount 0.
            keyframe: The keyframe (index or name) every reset starts from. Default: the suite's
                `options.keyframe`, else the model's reset state.
            world_offset: This process's first global world (under torchrun: rank x nworld), so that N
                processes of n worlds run the worlds of one batch of N n.
            key_episodes: Episodes per world whose noise keys the device holds ahead (at least 4); the host
                tops the table up every `key_episodes // 4` control steps.
            nconmax: MuJoCo Warp's contacts per world. Default: at least 64, and four times what
                `mj_forward` finds at the initial state.
            njmax: MuJoCo Warp's constraint rows per world. Default: at least 128, and four times what
                `mj_forward` finds at the initial state.
            capture: Replay each control step as one CUDA graph (recorded at the second step). Default: on
                CUDA devices; ignored on the CPU.
            autoreset: When the episode after one that ended starts: "next_step" (the next step, which
                returns FIRST and ignores that world's action) or "same_step" (the step that ended it, which
                returns the new episode's first observation with the ended one's LAST), as `BatchEnvironment`.

        Raises:
            SuiteError: The suite has problems against the model or the engine does not run one of its
                sensors (all of them, each at its line; `sensorcfg validate --engine warp` reports the same),
                or `keyframe` is not one of the model's.
            ArgumentError: A setting it cannot use: `nworld`, `world_offset`, `key_episodes`, a seed, a
                `control_timestep` that is not a whole number of physics steps, a `time_limit` that is not
                positive, an `autoreset` that is not one of the two.
            UnsupportedError: A model MuJoCo Warp itself does not run (its `put_model` refuses it).
        """
        if isinstance(nworld, bool) or not isinstance(nworld, (int, np.integer)) or nworld < 1:
            raise ArgumentError(f"nworld must be a positive integer; got {nworld!r}")
        if isinstance(world_offset, bool) or not isinstance(world_offset, (int, np.integer)) or world_offset < 0:
            raise ArgumentError(f"world_offset must be a non-negative integer; got {world_offset!r}")
        integral = isinstance(key_episodes, (int, numbers.Integral))  # any integer, numpy's too (int: for mypy)
        if isinstance(key_episodes, bool) or not integral or key_episodes < 4:
            raise ArgumentError(f"key_episodes must be an integer of at least 4; got {key_episodes!r}")
        key_episodes = int(key_episodes)
        self._same_step = autoreset_mode(autoreset)
        self._nworld, self._offset = int(nworld), int(world_offset)
        self._batch_shape = (self._nworld,)
        self._reward_fn, self._termination_fn = reward_fn, termination_fn
        model, suite = model_source(model, suite)
        self._model, observables, options = model_and_observables(model, suite, True, (), self._nworld, warp=True)
        leveled(observables)
        self._observables = observables
        self._keyframe = keyframe_index(self._model, keyframe, options.pop("keyframe", None))
        groups = options.pop("groups", {})
        self._n, self._control_timestep, self._step_limit = episode_timing(
            self._model, physics_steps_per_control_step, control_timestep, time_limit,
            options.get("physics_steps_per_control_step"))
        # (0: none; at most `MAX_CONTROL_STEPS`, an int64)
        self._limit = 0 if self._step_limit is None else int(self._step_limit)
        self._rules = rules = EpisodeRules()
        rules.limit, rules.same_step = self._limit, int(self._same_step)
        pad = bool(options.get("pad_with_initial_value", False))
        strip = bool(options.get("strip_singleton_buffer_dim", False))
        binding = bind_suite(self._model, observables, self._n, strip, pad)
        self.device = wp.get_device(device)
        self._worlds = Worlds(self._model, self._nworld, self.device, self._keyframe, nconmax, njmax)
        layer = SensorLayer(self._model, observables, binding, self._worlds, key_episodes)
        self._layer, self._keys = layer, EpisodeKeys(layer.sensors, key_episodes, self._offset)
        self._spec, self._sensors, self._scans, self._cameras = layer.spec, layer.sensors, layer.scans, layer.cameras
        self._key_episodes = key_episodes
        self.seed(seed)
        with wp.ScopedDevice(self.device):
            n = self._nworld
            self._actions = wp.zeros((n, self._model.nu), dtype=wp.float32)
            self._episode = episode = EpisodeState()
            episode.needs_reset = wp.ones(n, dtype=wp.int32)
            episode.restarting = wp.zeros(n, dtype=wp.int32)
            episode.starting = wp.zeros(n, dtype=wp.int32)
            episode.control_steps = wp.zeros(n, dtype=wp.int64)
            self._diverged = wp.zeros(n, dtype=bool)
            self._fields = fields = StepFields()
            fields.step_type = wp.zeros(n, dtype=wp.int32)
            fields.reward = wp.zeros(n, dtype=wp.float32)
            fields.discount = wp.ones(n, dtype=wp.float32)
            self._no_reward = wp.zeros(n, dtype=wp.float32)
            self._no_termination = wp.zeros(n, dtype=bool)
            self._mask = wp.zeros(n, dtype=wp.int32)
            self._any = wp.zeros(1, dtype=wp.int32)
        self._action_spec = action_spec(self._model, (self._nworld,), np.float32)  # MuJoCo Warp's ctrl
        dtypes = {name: spec.dtype if name in self._cameras.names else np.dtype(np.float32)  # cameras: the CPU's
                  for name, spec in self._spec.items()}
        self._observation_spec = {name: specs.Array((self._nworld, *spec.shape), dtypes[name], name=name)
                                  if not isinstance(spec, specs.BoundedArray) else
                                  specs.BoundedArray((self._nworld, *spec.shape), dtypes[name],
                                                     np.broadcast_to(spec.minimum, spec.shape),
                                                     np.broadcast_to(spec.maximum, spec.shape), name=name)
                                  for name, spec in self._spec.items()}
        self._names = list(self._spec)
        self._lay_out_groups(groups)
        # a CUDA graph of the control step's device work, recorded at the second step (the first loads modules)
        self._capture = self.device.is_cuda if capture is None else bool(capture) and self.device.is_cuda
        self._graph: Any = None
        self._warm = False

    # -- construction ---------------------------------------------------------------------------------

    # -- seeds and keys -------------------------------------------------------------------------------

    def seed(self, seed: int | np.random.SeedSequence | None) -> None:
        """Reseed every world (world w from `sim_seed(seed, world_offset + w)`); the next step resets them all."""
        self._seed = self._keys.seed(seed)
        if hasattr(self, "_episode"):
            self._episode.needs_reset.fill_(1)

    # -- properties -----------------------------------------------------------------------------------

    @property
    def nworld(self) -> int:
        return self._nworld

    @property
    def world_offset(self) -> int:
        return self._offset

    @property
    def data(self) -> Any:
        """MuJoCo Warp's Data of every world (device arrays, (nworld, ...))."""
        return self._worlds.data

    @property
    def worlds(self) -> Worlds:
        return self._worlds

    @property
    def autoreset(self) -> str:
        """When the episode after one that ended starts: "next_step" or "same_step" (`__init__`)."""
        return "same_step" if self._same_step else "next_step"

    @property
    def control_steps(self) -> wp.array:
        """(nworld,) int64 on the device: control steps since each world's reset, what the time limit counts.
        Writable (a write moves that world's time limit, not its sensors' clocks): RSL-RL's
        `init_at_random_ep_len` staggers the first episodes so."""
        return self._episode.control_steps

    @property
    def steps(self) -> wp.array:
        """(nworld,) int64: physics steps since each world's reset."""
        return self._worlds.steps

    def set_noise_level(self, level: float) -> None:
        """Scale every sensor's noise from each world's next episode on: 0 clean, 1 the suite's."""
        set_level(self._observables, level)  # validates `level` as the CPU engines do
        self._sensors.episodes.next_level.fill_(float(level))

    # -- episodes -------------------------------------------------------------------------------------

    def _start_episodes(self, mask: wp.array) -> None:
        """Restart the worlds of `mask` ((nworld,) int32): physics, forward, sensors; nothing when no world is
        masked (a conditional node of the step's CUDA graph: `wp.capture_if`)."""
        self._any.zero_()
        wp.launch(_any, dim=self._nworld, inputs=[mask], outputs=[self._any], device=self.device)
        wp.capture_if(self._any, on_true=self._restart_masked, mask=mask)

    def _restart_masked(self, mask: wp.array) -> None:
        self._worlds.reset(mask)
        self._worlds.forward()  # MuJoCo Warp has no per-world forward: every world's derived fields, again
        self._layer.start(mask)

    @quiet
    def reset(self, ids: Any = None) -> WarpTimeStep:
        """Start new episodes of worlds `ids` (all when None: indices, or a boolean mask); the others continue.
        An exception raised during it (by a batched generic callable) propagates and ends every world's
        episode, as one raised during `step` does."""
        chosen = chosen_ids(ids, self._nworld, "world", "this environment")
        try:
            return self._reset(chosen)
        except BaseException:
            self._episode.needs_reset.fill_(1)
            raise

    def _reset(self, chosen: np.ndarray) -> WarpTimeStep:
        self._mask.zero_()
        if chosen.size:
            wp.launch(_mask, dim=chosen.size, inputs=[wp.array(chosen.astype(np.int32), dtype=wp.int32,
                                                                 device=self.device)],
                      outputs=[self._mask], device=self.device)
            self._keys.top_up()
            self._start_episodes(self._mask)
            wp.launch(_started, dim=self._nworld, inputs=[self._mask], outputs=[self._episode], device=self.device)
        step_type = np.full(self._nworld, _MID, np.int32)
        step_type[chosen] = _FIRST
        fields = self._fields
        fields.step_type.assign(step_type)
        fields.reward.zero_()
        fields.discount.fill_(1.0)
        return WarpTimeStep(fields.step_type, fields.reward, fields.discount, self._observe())

    @quiet
    def step(self, actions: Any) -> WarpTimeStep:
        """One control step of every world (auto-resetting those whose episode ended).

        `actions`: (nworld, nu) controls, float32 as `action_spec()` says: a Warp array, a torch or JAX array
        (DLPack, on any device) or anything numpy takes; float64 is rounded to float32 (to nearest, on the
        device for a device array, as numpy rounds a host one), and a torch tensor that requires grad is read
        detached (the step copies its values into `ctrl`: no gradient flows through the environment).

        An exception raised during it (by `reward_fn`, `termination_fn` or a batched generic callable)
        propagates and ends every world's episode: the physics and the sensors may have run, so the next `step`
        restarts every world (FIRST), as `BatchEnvironment` does."""
        self._set_actions(actions)  # a bad action changes nothing
        try:
            self._run_step()
        except BaseException:
            self._episode.needs_reset.fill_(1)
            raise
        self._keys.ahead()
        fields = self._fields
        return WarpTimeStep(fields.step_type, fields.reward, fields.discount, self._observation)

    def _run_step(self) -> None:
        """The control step's device work: replayed as the CUDA graph once captured (at the second step)."""
        if self._graph is not None:
            wp.capture_launch(self._graph)
        elif self._capture and self._warm:
            with wp.ScopedCapture(device=self.device) as capture:
                self._device_step()
            self._graph = capture.graph
            wp.capture_launch(self._graph)
        else:
            self._device_step()
            self._warm = True

    def _device_step(self) -> None:
        """The control step's device work, from the actions in `_actions` to the step types: no host copy, no
        allocation of its own, the same launches every step (so that it can be replayed as a CUDA graph)."""
        n, device = self._nworld, self.device
        wp.launch(_begin, dim=n, inputs=[], outputs=[self._episode], device=device)
        if self._model.nu:
            wp.launch(_control, dim=(n, self._model.nu), inputs=[self._actions, self._episode.restarting],
                      outputs=[self._worlds.data.ctrl], device=device)
        for substep in range(1, self._n + 1):
            self._worlds.step(1)
            self._layer.record(substep)
        wp.copy(self._diverged, self._worlds.diverged)
        # rewards and terminations from the Data the physics steps left, before a restart's forward recomputes
        # every world's derived fields (a restarting world's are ignored: its step is FIRST)
        reward = self._reward_fn(self) if self._reward_fn is not None else self._no_reward
        terminated = self._termination_fn(self) if self._termination_fn is not None else self._no_termination
        wp.launch(_end, dim=n, inputs=[self._rules, self._diverged, terminated, reward],
                  outputs=[self._episode, self._fields], device=device)
        self._start_episodes(self._episode.starting)  # those that needed a reset (same step: and those that just ended)
        self._observation = self._observe()

    def _set_actions(self, actions: Any) -> None:
        """`actions` into `_actions` (float32 on the device), as `step` says; anything else is an ArgumentError."""
        shape = (self._nworld, self._model.nu)
        if getattr(actions, "requires_grad", False) and callable(getattr(actions, "detach", None)):
            actions = actions.detach()  # (torch's DLPack export refuses a tensor that requires grad)
        if isinstance(actions, wp.array):
            array = actions
        elif hasattr(actions, "__dlpack__") and not isinstance(actions, np.ndarray):
            try:
                array = wp.from_dlpack(actions)
            except (BufferError, RuntimeError, TypeError, ValueError) as e:
                raise ArgumentError(f"actions must be a {shape} float32 or float64 array; DLPack could not pass this "
                                    f"{type(actions).__name__} to Warp: {e}") from None
        else:
            try:
                host = np.asarray(actions, np.float32)  # float64 rounded to nearest
            except (TypeError, ValueError):
                raise ArgumentError(f"actions must be a {shape} array of numbers") from None
            array = wp.array(host, dtype=wp.float32, device=self.device)
        if tuple(array.shape) != shape or array.dtype not in (wp.float32, wp.float64):
            raise ArgumentError(f"actions must be a {shape} float32 or float64 array (one control per world and "
                                f"actuator; float64 is rounded to float32); got {tuple(array.shape)} "
                                f"{wp.types.type_repr(array.dtype)}")
        if array.dtype == wp.float32:
            wp.copy(self._actions, array)
        else:
            wp.launch(_to_float32, dim=shape, inputs=[array.to(self.device)], outputs=[self._actions],
                      device=self.device)

    def _observe(self) -> dict[str, wp.array]:
        return self._layer.read()

    def close(self) -> None:
        pass


def torch_views(observation: Mapping[str, wp.array]) -> dict[str, Any]:
    """Zero-copy torch tensors of an observation (`wp.to_torch`)."""
    return {name: wp.to_torch(array) for name, array in observation.items()}
