"""The CPU reference of the Warp engine's environment tests: `BatchEnvironment` where MuJoCo 4 runs it (its
`mujoco.batch`), else its simulations as `Environment`s (MuJoCo 3.11, the line mjlab 1.6 pins): simulation i
of a batch is `Environment(seed=sim_seed(seed, i))` bit for bit (tests/batch/test_batch.py), so either gives
the same observations, step types, rewards and discounts."""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import dm_env
import mujoco
import numpy as np
from dm_env import specs

from sensorcfg import Environment
from sensorcfg.draws import root_seed, sim_seed

__all__ = ["cpu_batch"]


def cpu_batch(model: Any, make: Callable[[], Any], nsim: int, **options: Any) -> Any:
    """`nsim` simulations of `make()`'s suite (called once per simulation: observables are not shared) with
    `BatchEnvironment`'s keywords `options`."""
    if hasattr(mujoco, "batch"):
        from sensorcfg.batch.environment import BatchEnvironment

        return BatchEnvironment(model, make(), nsim, **options)
    return Simulations(model, make, nsim, **options)


class Simulations:
    """`BatchEnvironment`'s interface (the calls these tests make) over one `Environment` per simulation. A
    `reward_fn` or `termination_fn` is a batch's (one value per simulation), called once per step as the batch
    calls it (the reward first); one that raises ends every simulation's episode, as in a batch. With
    `autoreset="same_step"` a LAST step shows the new episode's first observation, as a batch's."""

    def __init__(self, model: Any, make: Callable[[], Any], nsim: int, seed: Any = None,
                 reward_fn: Callable[[Any], Any] | None = None, termination_fn: Callable[[Any], Any] | None = None,
                 autoreset: str = "next_step", **options: Any):
        root = root_seed(seed)
        self._same_step = autoreset == "same_step"
        self._fns = (reward_fn, termination_fn)
        self._values: list[Any] = [np.zeros(nsim), np.zeros(nsim, bool)]
        per_sim = {name: (lambda i, k=k: (lambda physics: self._values[k][i]))
                   for k, name in enumerate(("reward_fn", "termination_fn")) if self._fns[k] is not None}
        self._envs = [Environment(model, make(), seed=sim_seed(root, i), **options,
                                  **{name: make_fn(i) for name, make_fn in per_sim.items()}) for i in range(nsim)]

    def observation_spec(self) -> dict[str, specs.Array]:
        out: dict[str, specs.Array] = {}
        n = len(self._envs)
        for name, spec in self._envs[0].observation_spec().items():
            shape = (n, *spec.shape)
            out[name] = specs.Array(shape, spec.dtype, name=name) if not isinstance(spec, specs.BoundedArray) else \
                specs.BoundedArray(shape, spec.dtype, np.broadcast_to(spec.minimum, shape),
                                   np.broadcast_to(spec.maximum, shape), name=name)
        return out

    def _stacked(self, steps: list[dm_env.TimeStep]) -> SimpleNamespace:
        return SimpleNamespace(step_type=np.array([int(s.step_type) for s in steps], np.uint8),
                               reward=np.array([s.reward or 0.0 for s in steps], np.float64),
                               discount=np.array([1.0 if s.discount is None else s.discount for s in steps]),
                               observation={name: np.stack([s.observation[name] for s in steps])
                                            for name in steps[0].observation})

    def reset(self, ids: Any = None) -> SimpleNamespace:
        """Simulations `ids` (all when None) restart; the others show their observation, MID, as a batch's."""
        chosen = set(range(len(self._envs)) if ids is None else np.asarray(ids).tolist())
        return self._stacked([env.reset() if i in chosen else
                              dm_env.TimeStep(dm_env.StepType.MID, 0.0, 1.0, env.updater.get_observation())
                              for i, env in enumerate(self._envs)])

    def step(self, actions: Any) -> SimpleNamespace:
        try:
            for k, fn in enumerate(self._fns):
                if fn is not None:
                    self._values[k] = np.asarray(fn(self))
        except BaseException:
            for env in self._envs:
                env._needs_reset = True
            raise
        steps = []
        for env, action in zip(self._envs, np.asarray(actions)):
            step = env.step(action)
            if self._same_step and step.last():  # the next episode starts in this step: its first observation
                step = step._replace(observation=env.reset().observation)
            steps.append(step)
        return self._stacked(steps)

    def seed(self, seed: Any) -> None:
        root = root_seed(seed)
        for i, env in enumerate(self._envs):
            env.seed(sim_seed(root, i))

    def set_noise_level(self, level: float) -> None:
        for env in self._envs:
            env.set_noise_level(level)
