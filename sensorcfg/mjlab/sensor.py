"""A sensor suite as an mjlab scene sensor: the Warp engine's sensor layer over mjlab's MuJoCo Warp worlds.

mjlab's `Sensor` protocol, called by its scene and environment:

- `edit_spec(scene_spec, entities)`: the suite's MuJoCo sensors and sites added to the scene's MjSpec
  (`Suite._add_to`: the compile path of `sensorcfg.native`, on the scene itself); its selectors name the
  scene's elements as mjlab names them (`site:robot/imu`, `actuator:*`).
- `initialize(mj_model, model, data, device)`: the suite bound to the compiled model for `decimation` physics
  steps per read (`warp.layer.bind_suite`, refusing at the suite's lines what the Warp engine does not run),
  and its layer built over mjlab's Model and Data for every world (`Worlds.over`), each world's episode keys
  drawn from `seed` as simulation `world_offset + w` of a batch (`layer.EpisodeKeys`).
- `update(dt)` after each physics step: the step counted, every sample its schedule takes recorded, so
  intervals, delays and buffers keep their physics-step meaning.
- `reset(env_ids)`: those worlds' episodes start at the next read, from the state mjlab's reset events and
  forward left (their reset samples, new keys); every world starts its first episode so at initialisation.
- `data`: every observation, `{name: (num_envs, *shape) torch tensor}` (views of the layer's device arrays),
  read at a control step's end; `group(name)`: an observation group of the suite (`groups:`) as one
  `(num_envs, width)` tensor in its stated column order (`sensorcfg.groups`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import torch
import warp as wp
from mjlab.sensor import Sensor, SensorCfg

from ..loop.control import episode_timing
from ..loop.model import model_and_observables
from ..errors import ArgumentError, Problem, SuiteError
from ..groups import Group, layout
from ..noise.level import leveled, set_level
from ..suite import Suite, load
from ..warp.layer import EpisodeKeys, SensorLayer, bind_suite
from ..warp.quiet import quiet
from ..warp.worlds import Worlds

__all__ = ["SuiteSensor", "SuiteSensorCfg"]


@dataclass(kw_only=True)
class SuiteSensorCfg(SensorCfg):
    """A sensor suite in an mjlab scene (`scene.sensors`); `sensorcfg.mjlab.attach` adds one with its
    observation groups."""

    name: str = "sensorcfg"
    """The scene sensor's name (`env.scene["sensorcfg"]`)."""
    suite: str | os.PathLike[str] | Suite
    """The suite: a file's path, or a loaded `sensorcfg.Suite`. Its selectors name the scene's elements."""
    decimation: int
    """Physics steps per control step: the environment's `decimation` (a suite's `options.control_interval`,
    when it gives one, must agree)."""
    seed: int | None = None
    """The root seed of the suite's noise and drawn schedules (None: fresh entropy)."""
    world_offset: int = 0
    """This process's first global world (several processes: rank x num_envs): world w draws as world
    `world_offset + w` of one batch."""
    key_episodes: int = 8
    """Episodes per world whose noise keys the device holds ahead (at least 4)."""

    def build(self) -> SuiteSensor:
        return SuiteSensor(self)


def _positive(name: str, value: Any, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise ArgumentError(f"SuiteSensorCfg.{name} must be an integer of at least {least}; got {value!r}")
    return int(value)


class SuiteSensor(Sensor[dict[str, torch.Tensor]]):
    """The suite of a `SuiteSensorCfg` over mjlab's worlds (see the module's doc)."""

    def __init__(self, cfg: SuiteSensorCfg):
        super().__init__()
        self.cfg = cfg
        self._decimation = _positive("decimation", cfg.decimation, 1)
        self._offset = _positive("world_offset", cfg.world_offset, 0)
        self._key_episodes = _positive("key_episodes", cfg.key_episodes, 4)
        self.suite = cfg.suite if isinstance(cfg.suite, Suite) else load(cfg.suite)
        if getattr(self.suite.options, "keyframe", None) is not None:  # mjlab's events set each reset's state
            message = "mjlab resets the worlds (its reset events): a suite in an mjlab scene names no keyframe"
            pos = self.suite._loaded.doc.pos(("options", "keyframe"))
            raise SuiteError(pos.problem(message, "options.keyframe") if pos else
                             Problem(message, "options.keyframe", self.suite.file))
        self._layer: SensorLayer | None = None

    # -- mjlab's Sensor -------------------------------------------------------------------------------

    def edit_spec(self, scene_spec: mujoco.MjSpec, entities: dict[str, Any]) -> None:
        del entities  # (the suite names the scene's elements)
        self.suite._add_to(scene_spec)

    @quiet
    def initialize(self, mj_model: mujoco.MjModel, model: Any, data: Any, device: str) -> None:
        del device  # (the Data's own)
        model, data = getattr(model, "struct", model), getattr(data, "struct", data)  # mjlab's WarpBridge
        nworld = int(data.qpos.shape[0])
        mj_model, observables, options = model_and_observables(mj_model, self.suite, True, (), nworld, warp=True)
        leveled(observables)
        self._observables = observables
        n, _, _ = episode_timing(mj_model, self._decimation, None, None, options.get("physics_steps_per_control_step"))
        binding = bind_suite(mj_model, observables, n, bool(options.get("strip_singleton_buffer_dim", False)),
                             bool(options.get("pad_with_initial_value", False)))
        self.worlds = Worlds.over(mj_model, model, data, data.qpos.device)
        self._layer = layer = SensorLayer(mj_model, observables, binding, self.worlds, self._key_episodes)
        self._keys = EpisodeKeys(layer.sensors, self._key_episodes, self._offset)
        self.seed_sequence = self._keys.seed(self.cfg.seed)
        self._n, self._substep = n, 0
        with wp.ScopedDevice(self.worlds.device):
            self._pending = wp.ones(nworld, dtype=wp.int32)  # every world starts its first episode at the first read
        self._pending_torch = wp.to_torch(self._pending)
        self._any_pending = True
        self._outputs = {name: wp.to_torch(array) for name, array in layer.read().items()}  # fixed arrays: views
        self.groups: dict[str, Group] = layout(self.suite.groups, {k: tuple(s.shape) for k, s in layer.spec.items()})

    @property
    def layer(self) -> SensorLayer:
        if self._layer is None:
            raise RuntimeError("the suite's sensor is not initialised yet: mjlab's scene initialises it with the "
                               "simulation")
        return self._layer

    @property
    def num_envs(self) -> int:
        return self.worlds.nworld

    @property
    def physics_steps_per_control_step(self) -> int:
        return self._n

    @quiet
    def update(self, dt: float) -> None:
        super().update(dt)
        layer = self.layer
        self._substep = self._substep % self._n + 1
        self.worlds.count()
        layer.record(self._substep)

    def reset(self, env_ids: torch.Tensor | slice | None = None) -> None:
        """Worlds `env_ids` (all when None) start new episodes at the next read: from the state mjlab's reset
        left them in once its forward ran (their reset samples), with their next episodes' keys."""
        super().reset(env_ids)
        if self._layer is None:
            return
        if env_ids is None or isinstance(env_ids, slice):
            self._pending_torch[env_ids if isinstance(env_ids, slice) else slice(None)] = 1
            self._any_pending = True
        elif torch.as_tensor(env_ids).numel():
            self._pending_torch[torch.as_tensor(env_ids, device=self._pending_torch.device)] = 1
            self._any_pending = True

    @quiet
    def _compute_data(self) -> dict[str, torch.Tensor]:
        layer = self.layer
        if self._substep not in (0, self._n):
            raise RuntimeError(f"the suite is read at a control step's end; this is physics step {self._substep} of "
                               f"{self._n}")
        if self._any_pending:
            self._start()
        layer.read()
        return self._outputs

    # -- sensorcfg ------------------------------------------------------------------------------------

    def _start(self) -> None:
        """The pending worlds' episodes start (their physics already restarted and forwarded by mjlab). The key
        table is topped up every `key_episodes // 4` starts: each world starts at most one episode per start."""
        self._keys.ahead()
        self.worlds.restarted(self._pending)
        self.layer.start(self._pending)
        self._pending.zero_()
        self._any_pending = False
        self._substep = 0

    def group(self, name: str) -> torch.Tensor:
        """Observation group `name` of the suite (`groups:`): `(num_envs, width)` float32, its columns in the
        suite's order (`groups[name].columns`)."""
        if name not in self.groups:
            known = ", ".join(self.groups) or "none"
            raise ArgumentError(f"the suite has no observation group {name!r}; its groups: {known} (add it under "
                                "'groups:')")
        return self.groups[name].concatenate(self.data, batch_dims=1)

    def set_noise_level(self, level: float) -> None:
        """Scale every sensor's noise from each world's next episode on: 0 clean, 1 the suite's."""
        set_level(self._observables, level)
        self.layer.sensors.episodes.next_level.fill_(float(level))

    @property
    def episodes(self) -> np.ndarray:
        """Per world, the episodes it started (a host copy)."""
        return self.layer.sensors.episodes.count.numpy().astype(np.int64)
