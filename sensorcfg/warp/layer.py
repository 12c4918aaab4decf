"""A suite's sensor layer over MuJoCo Warp worlds: what the Warp engine runs around the physics, whoever steps it.

`WarpEnvironment` runs it around its own `Worlds`; the mjlab adapter (`sensorcfg.mjlab`) around mjlab's
simulation (`Worlds.over` its Model and Data). The layer is built in two steps, so that what the engine
refuses of a suite is said before MuJoCo Warp is given the model:

- `bind_suite`: the suite's observables bound to the compiled MjModel for `substeps` physics steps per read,
  and refused where the engine does not run them (`support.refusals`, each at its sensor's key);
- `SensorLayer`: the plan (`sensorcfg.plan`) of what is bound, over the worlds: batched generic callables
  (`warp.generic`), height scans (`warp.rays`), cameras (`warp.cameras`) and every other sensor
  (`warp.sensors.Sensors`), each reading MuJoCo Warp's Data as float32 views (no copy).

Its calls, by the worlds' physics steps (`Worlds.steps`, counted since each world's restart):
`record(substep)` after each physics step of every world, `start(mask)` once the masked worlds were restarted
and forwarded (their reset samples), `read()` at a control step's end (every world at a multiple of
`substeps` steps). `EpisodeKeys` draws each world's episode keys on the host, as the CPU engines draw them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

import mujoco
import numpy as np
import warp as wp

from ..draws import episode_entropy, root_seed, sensor_keys, sim_seed
from ..loop.control import random_state_from
from ..errors import Problem, SuiteError
from ..physics import Physics
from ..plan.bind import Bound, Entry, bind
from ..plan.schedule import Schedule
from ..plan.spec import observation_spec
from .cameras import CameraEntry, Cameras
from .episode import episode_values
from .generic import Generics, split
from .rays import Scans, plan as scan_plan
from .sensors import Sensors
from .support import field_refusal, refusals
from .worlds import Worlds

__all__ = ["Binding", "EpisodeKeys", "SensorLayer", "bind_suite", "episode_keys", "refuse"]


class Binding(NamedTuple):
    """A suite bound for the Warp engine (`bind_suite`): the Updater-style `bound` entries (batched generic
    callables aside, in `batched`), the CPU `physics` they were bound on, and how a read is laid out."""

    bound: Bound
    batched: dict[str, Any]
    physics: Physics
    substeps: int
    strip: bool
    pad: bool


def refuse(bound: Bound, model: mujoco.MjModel) -> None:
    """What this engine does not run (`support.refusals`), each at its sensor's key (`validate --engine warp`
    says the same at the suite's lines)."""
    fields = {e.name: source.field for e, source in zip((*bound.fixed, *bound.drawn), bound.sources())}
    problems = [Problem(message, ".".join(map(str, ("sensors", entry.name, *key)))) for entry in bound.entries
                for key, message in refusals(entry.observable, fields.get(entry.name), model)]
    if problems:
        raise SuiteError(problems)


def bind_suite(model: mujoco.MjModel, observables: Mapping[str, Any], substeps: int, strip: bool,
               pad: bool) -> Binding:
    """`observables` (built for a batch, `warp=True`) bound to `model` for reads every `substeps` physics
    steps; SuiteError with everything the engine refuses."""
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    others, batched = split(observables)  # batched generic callables: called by `warp.generic`
    bound = bind(others, physics, substeps, strip)
    refuse(bound, model)
    return Binding(bound, batched, physics, substeps, strip, pad)


def _flat(array: wp.array, nworld: int) -> wp.array:
    """An (nworld, ...) float32 MuJoCo Warp array (of scalars, vectors, quaternions or matrices) as an
    (nworld, values) float32 view."""
    scalar = getattr(array.dtype, "_wp_scalar_type_", array.dtype)
    if scalar != wp.float32 or not array.is_contiguous:
        raise SuiteError(f"a field of dtype {wp.types.type_repr(array.dtype)} cannot be read by the Warp engine")
    size = math.prod(array.shape[1:]) * wp.types.type_size_in_bytes(array.dtype) // 4
    return wp.array(ptr=array.ptr, dtype=wp.float32, shape=(nworld, size), device=array.device, copy=False)


def _camera(entry: Entry) -> CameraEntry:
    """A bound camera as `Cameras` takes it: its observable and its schedule's numbers."""
    schedule = entry.schedule
    assert isinstance(schedule, Schedule)  # (a camera's schedule is fixed: `bind.check_per_simulation`)
    return CameraEntry(entry.name, entry.observable, schedule.interval, schedule.delay, schedule.buffer,
                       schedule.capacity, schedule.needed_mask())


class SensorLayer:
    """The sensors of `binding` (of `observables`, in their order) over `worlds`, with `key_episodes`
    episodes of keys ahead per world (`EpisodeKeys` fills them). `spec`: each observation's spec for one world."""

    def __init__(self, model: mujoco.MjModel, observables: Mapping[str, Any], binding: Binding, worlds: Worlds,
                 key_episodes: int):
        bound, physics, n, pad = binding.bound, binding.physics, binding.substeps, binding.pad
        self.worlds, self.device, self.substeps = worlds, worlds.device, n
        self.generics = Generics(binding.batched, worlds, model)  # each called once: its shape
        bound = self.generics.bind(bound, list(observables), n, binding.strip)
        bound, plan = scan_plan(bound, physics, worlds.nworld, n, pad,  # height scans read their own rays
                                self.generics.sizes)
        self.spec = {e.name: observation_spec(e.name, e.observable, e.buffered_shape, e.dtype, pad)
                     for e in bound.entries}
        self.scans = Scans(model, plan, bound, self.device)
        own = {**self.scans.heights, **self.generics.values}
        self.fields = {**self._field_views([f for f, _ in plan.fields if f not in own] + self.scans.pose_fields),
                       **own}
        self.cameras = Cameras([_camera(e) for e in bound.cameras], model, worlds, n, pad,
                               {e.name: tuple(self.spec[e.name].shape) for e in bound.cameras})
        self.sensors = Sensors(plan, self.device, key_episodes)
        self.names = list(self.spec)

    def _field_views(self, fields: list[str]) -> dict[str, wp.array]:
        data = self.worlds.data
        missing = [f for f in fields if getattr(data, f, None) is None]  # (an installed MuJoCo Warp unlike FIELDS')
        if missing:
            raise SuiteError(field_refusal(missing[0]))
        return {f: _flat(getattr(data, f), self.worlds.nworld) for f in fields}

    def record(self, substep: int) -> None:
        """After physics step `substep` (1-based, of a control step) of every world, counted in `worlds.steps`:
        the scans cast, the batched callables called, the samples each schedule takes recorded."""
        steps = self.worlds.steps
        self.scans.cast(self.fields, steps)
        self.generics.run()
        self.sensors.record(self.fields, steps)
        self.cameras.record(substep)

    def start(self, mask: wp.array) -> None:
        """The episodes of the worlds of `mask` ((nworld,) int32) start: their physics restarted and forwarded
        (MuJoCo Warp has no per-world forward: every world's derived fields are those of its current state),
        their step counts 0 (`Worlds.restarted`); their reset samples taken."""
        steps = self.worlds.steps
        self.scans.cast(self.fields, steps, every=True)
        self.generics.run()
        self.sensors.reset(mask, self.fields, steps)
        self.cameras.reset(mask)

    def read(self) -> dict[str, wp.array]:
        """Every observation of every world at its step ((nworld, *shape) device arrays, in the suite's order;
        the same arrays every call, overwritten by the next)."""
        outputs = {**self.sensors.read(self.worlds.steps), **self.cameras.read()}
        return {name: outputs[name] for name in self.names}


def episode_keys(sensors: Sensors, entropy: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """An episode's keys of the noisy and drawn sensors (`Sensors.key_names`; `draws.sensor_keys`, as the CPU
    engines key them) and what the noisy ones' programs draw at its reset (`episode.episode_values`), from the
    episode's entropy."""
    keys = sensor_keys(entropy, sensors.key_names)
    return keys, episode_values(sensors.plan, sensors.noise, keys)


class EpisodeKeys:
    """Each world's episode keys, drawn on the host in order from its random state as the CPU engines draw
    them (`BatchEnvironment`: world w of a process with `world_offset` o is simulation o + w), into the key
    table of `sensors` (a layer's) `key_episodes` episodes ahead; topped up every `key_episodes // 4` control
    steps."""

    def __init__(self, sensors: Sensors, key_episodes: int, world_offset: int = 0):
        self._sensors = sensors
        self._size, self._offset, self._nworld = key_episodes, world_offset, sensors.plan.nsim
        self._steps = 0

    def seed(self, seed: int | np.random.SeedSequence | None) -> np.random.SeedSequence:
        """Every world's stream from `seed` (world w from `sim_seed(seed, world_offset + w)`), its episodes
        counted from 0; the root seed."""
        root = root_seed(seed)
        self.start([random_state_from(sim_seed(root, self._offset + w)) for w in range(self._nworld)])
        return root

    def start(self, random_states: list[np.random.RandomState]) -> None:
        """Every world's stream from its random state (a test's own), its episodes counted from 0."""
        self._random_states = random_states
        self._keyed = np.zeros(self._nworld, np.int64)  # episodes whose keys are in the table, per world
        self._table = np.zeros(self._sensors.episodes.key_table.shape, np.uint64)
        self._values = np.zeros(self._sensors.episodes.value_table.shape, np.float64)
        wp.copy(self._sensors.episodes.count, wp.zeros(self._nworld, dtype=wp.int32, device=self._sensors.device))
        self.top_up(np.zeros(self._nworld, np.int64))

    @property
    def keyed(self) -> np.ndarray:
        """Per world, the episodes whose keys were drawn."""
        return self._keyed

    def top_up(self, used: np.ndarray | None = None) -> None:
        """Keys of each world's episodes up to `used + key_episodes - 1` (`used`: the episodes each world
        started; None: the layer's count), only when some sensor is noisy or drawn."""
        sensors = self._sensors
        if not sensors.key_names:
            return
        used = sensors.episodes.count.numpy().astype(np.int64) if used is None else used
        table, values, size = self._table, self._values, self._size
        worlds = np.flatnonzero(self._keyed < used + size)
        for w in worlds.tolist():
            while self._keyed[w] < used[w] + size:
                e = int(self._keyed[w]) % size
                table[w, e], values[w, e] = episode_keys(sensors, episode_entropy(self._random_states[w]))
                self._keyed[w] += 1
        sensors.set_keys(worlds, table[worlds], values[worlds])

    def ahead(self) -> None:
        """After (or before) each event that starts at most one episode per world (a control step of
        `WarpEnvironment`, a start of the mjlab adapter): the table topped up every `key_episodes // 4` of them."""
        self._steps += 1
        if self._steps >= self._size // 4 and self._sensors.key_names:
            self._steps = 0
            self.top_up()
