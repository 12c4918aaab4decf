"""A suite's observation groups as mjlab observation terms, and `attach`, which puts a suite into an mjlab
environment config.

`SuiteGroup` is a class term (mjlab instantiates it with its term config and the environment): each call
returns one of the suite's groups (`groups:`) as a `(num_envs, width)` torch tensor, read from the scene's
`SuiteSensor`; `reset(env_ids)` starts those worlds' episodes. It is valid from the scene's initialisation on
(mjlab's observation manager calls each term once for its shape, before any reset). The suite already
applies its noise, delays and buffers at physics-step resolution, so mjlab's own noise, delay, history, clip
and scale on the term are refused rather than stacked on them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import torch
from mjlab.managers.manager_base import ManagerTermBase
from mjlab.managers.observation_manager import ObservationGroupCfg, ObservationTermCfg

from ..errors import ArgumentError
from ..suite import Suite
from .sensor import SuiteSensor, SuiteSensorCfg

__all__ = ["SuiteGroup", "attach"]

# what mjlab would apply to a term after it, which the suite does itself: (setting, its value when off)
_OFF = (("noise", None), ("clip", None), ("scale", None), ("delay_max_lag", 0), ("history_length", 0))


class SuiteGroup(ManagerTermBase):
    """An observation term: the suite's group `group` from the scene sensor `sensor_name` (its params)."""

    def __init__(self, cfg: ObservationTermCfg, env: Any):
        super().__init__(env)
        self._cfg = cfg
        name = cfg.params.get("sensor_name", "sensorcfg")
        sensor = env.scene.sensors.get(name)
        if not isinstance(sensor, SuiteSensor):
            raise ArgumentError(f"the scene has no sensorcfg suite named {name!r} (a SuiteSensorCfg in "
                                f"scene.sensors); its sensors: {', '.join(env.scene.sensors) or 'none'}")
        if sensor.physics_steps_per_control_step != env.cfg.decimation:
            raise ArgumentError(f"the suite {name!r} reads every {sensor.physics_steps_per_control_step} physics "
                                f"steps, the environment's decimation is {env.cfg.decimation}: set "
                                f"SuiteSensorCfg.decimation to the environment's")
        self.sensor = sensor
        self.group = str(cfg.params["group"])
        sensor.group(self.group)  # (a group the suite has: said here, at the manager's construction)
        self._checked = False

    def _check(self) -> None:
        """mjlab's processing left off (the manager sets a group's history on its terms after building them)."""
        on = [f"{key}={getattr(self._cfg, key)!r}" for key, off in _OFF if getattr(self._cfg, key, off) != off]
        if on:
            raise ArgumentError(f"observation term of suite group {self.group!r}: {', '.join(on)} would be applied "
                                "after the suite's own noise, delays and buffers; leave mjlab's off for this term "
                                "(and its group's history_length) and write them in the suite")
        self._checked = True

    def __call__(self, env: Any, **params: Any) -> torch.Tensor:
        del env, params
        if not self._checked:
            self._check()
        return self.sensor.group(self.group)

    def reset(self, env_ids: torch.Tensor | slice | None = None) -> None:
        """Worlds `env_ids` start new episodes at the next read (`SuiteSensor.reset`)."""
        self.sensor.reset(env_ids)


def attach(env_cfg: Any, suite: str | os.PathLike[str] | Suite, groups: Mapping[str, str], *,
           keep: Sequence[str] = (), name: str = "sensorcfg", seed: int | None = None, world_offset: int = 0,
           key_episodes: int = 8) -> SuiteSensorCfg:
    """Put `suite` into mjlab environment config `env_cfg` (a `ManagerBasedRlEnvCfg`, edited in place): a
    `SuiteSensorCfg` in its scene (the environment's decimation, `seed` or else the config's own seed), and
    each observation group named in `groups` (mjlab's group -> the suite's group, e.g. `{"actor": "policy",
    "critic": "critic"}`) replaced by the suite's group, followed by the terms of the config's own group named
    in `keep` (a task's commands and last actions: not sensors), concatenated, mjlab's noise off.

    Raises ArgumentError for a group or term `env_cfg` does not have."""
    cfg = SuiteSensorCfg(name=name, suite=suite, decimation=int(env_cfg.decimation),
                         seed=env_cfg.seed if seed is None else seed, world_offset=world_offset,
                         key_episodes=key_episodes)
    observations = dict(env_cfg.observations)
    for mjlab_group, suite_group in groups.items():
        own = observations.get(mjlab_group)
        kept: dict[str, ObservationTermCfg] = {}
        for term in keep:
            if own is None or term not in own.terms:
                have = ", ".join(own.terms) if own is not None else "none (no such group)"
                raise ArgumentError(f"observation group {mjlab_group!r} has no term {term!r} to keep; its terms: "
                                    f"{have}")
            kept[term] = own.terms[term]
        terms = {name: ObservationTermCfg(func=SuiteGroup, params={"sensor_name": name, "group": suite_group}),
                 **kept}
        observations[mjlab_group] = ObservationGroupCfg(terms=terms, concatenate_terms=True,
                                                        enable_corruption=False)
    env_cfg.observations = observations
    env_cfg.scene.sensors = (*env_cfg.scene.sensors, cfg)
    return cfg
