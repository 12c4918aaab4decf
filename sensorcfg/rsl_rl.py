"""An RSL-RL `VecEnv` over a `WarpEnvironment` (torch tensors on its device, no host copy) or a
`BatchEnvironment` (CPU: numpy arrays as torch tensors). Extra `rsl-rl`: `pip install rsl-rl-lib tensordict`.

`RslRlVecEnv(env)` speaks RSL-RL 5.4's interface (`rsl_rl.env.VecEnv`, what its `OnPolicyRunner` calls):

- observations: a TensorDict of the suite's observation groups (`groups:`), one (num_envs, width) float32
  tensor each, its columns as `env.group_spec()` lists them (RSL-RL's `obs_groups` name these groups; by
  default its actor reads "policy", and its critic "critic" where the suite has one, else "policy");
- `step(actions)` -> (observations, rewards float32, dones long, extras): `dones` is 1 where the step ended a
  world's episode, `extras["time_outs"]` (bool) only where it ended at the time limit (a truncation, for
  bootstrapping), not by a termination or a divergence;
- resets in the same step: `env` is built with `autoreset="same_step"`, so the observations a step returns
  for a world whose episode it ended are its new episode's first;
- `episode_length_buf`: each world's control steps since its reset (`env.control_steps`, a view: writing it,
  as `OnPolicyRunner.learn(init_at_random_ep_len=True)` does, moves the worlds' time limits, not their
  sensors' clocks); `max_episode_length`: the time limit in control steps (`MAX_CONTROL_STEPS` without one);
- `num_envs`, `num_actions`, `device` (a torch device), `cfg` (a dict of the engine's settings, which RSL-RL's
  loggers store).

A `BatchEnvironment`'s float64 observations and rewards are rounded to float32 (the policy's precision) and
its actions taken as float64 from the float32 tensors; a `WarpEnvironment`'s are float32 already.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .loop.episode import MAX_CONTROL_STEPS, truncated
from .errors import ArgumentError, install_hint

try:
    import torch
    from rsl_rl.env import VecEnv
    from tensordict import TensorDict
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError(f"sensorcfg.rsl_rl needs RSL-RL, tensordict and torch: "
                      f"{install_hint('rsl-rl', 'rsl-rl-lib tensordict')}") from e

__all__ = ["RslRlVecEnv"]


def _tensor(array: Any) -> torch.Tensor:
    """A torch view of an engine's array: numpy's shares its memory (`torch.from_numpy`), Warp's its device
    memory (`wp.to_torch`)."""
    if isinstance(array, np.ndarray):
        return torch.from_numpy(array)
    import warp as wp

    view: torch.Tensor = wp.to_torch(array)
    return view


class RslRlVecEnv(VecEnv):
    """RSL-RL's `VecEnv` over a `WarpEnvironment` or a `BatchEnvironment` built with `autoreset="same_step"`
    from a suite with observation groups (see the module's doc)."""

    def __init__(self, env: Any, cfg: Mapping[str, Any] | None = None):
        """Wrap `env` and start every world's episode (`env.reset()`).

        Args:
            env: A `WarpEnvironment` or `BatchEnvironment` with `autoreset="same_step"`, whose suite has
                `groups:`.
            cfg: What `cfg` holds for RSL-RL's loggers (besides the engine's settings, which it always holds).

        Raises:
            ArgumentError: `env` is not one of the two engines, restarts episodes at the next step, or its suite
                has no observation groups.
        """
        if getattr(env, "autoreset", None) is None or not callable(getattr(env, "group_spec", None)):
            raise ArgumentError(f"RslRlVecEnv wraps a WarpEnvironment or a BatchEnvironment; got {type(env).__name__}")
        if env.autoreset != "same_step":
            raise ArgumentError(f"RSL-RL expects the step that ends an episode to return the next episode's first "
                                f"observation: build the {type(env).__name__} with autoreset='same_step'")
        groups = env.group_spec()
        if not groups:
            raise ArgumentError("the suite has no observation groups; RSL-RL reads groups of observations: add "
                                "e.g. 'groups: {policy: [...], critic: [...]}' to the suite (names or globs of its "
                                "sensors)")
        self.env = env
        self.num_envs, self.num_actions = (int(n) for n in env.action_spec().shape)
        device = getattr(env, "device", None)  # a Warp device; a BatchEnvironment has none: the CPU
        self._numpy = device is None  # (a BatchEnvironment's actions: a numpy array)
        if device is None:
            self.device = torch.device("cpu")
        else:
            import warp as wp

            self.device = torch.device(wp.device_to_torch(device))
        limit = env.step_limit
        self.max_episode_length = MAX_CONTROL_STEPS if limit is None else int(limit)
        self.cfg = {"engine": type(env).__name__, "num_envs": self.num_envs, "control_timestep": env.control_timestep,
                    "time_limit_steps": limit, "autoreset": env.autoreset,
                    "groups": {name: group.describe() for name, group in groups.items()}, **dict(cfg or {})}
        self._control_steps = _tensor(env.control_steps)
        self._observation = env.reset().observation

    @property
    def episode_length_buf(self) -> torch.Tensor:
        """(num_envs,) int64: control steps since each world's reset, a view of the engine's counters."""
        return self._control_steps

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        self._control_steps.copy_(torch.as_tensor(value))

    def get_observations(self) -> TensorDict:
        """The groups of the latest observation (the reset's, then each step's)."""
        vectors = {name: torch.as_tensor(vector).to(torch.float32)
                   for name, vector in self.env.groups(self._observation).items()}
        return TensorDict(vectors, batch_size=[self.num_envs], device=self.device)

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict[str, Any]]:
        """One control step of every world with `actions` ((num_envs, num_actions)), restarting the episodes
        it ends."""
        step = self.env.step(actions.detach().cpu().numpy() if self._numpy else actions.detach())
        self._observation = step.observation
        step_type, discount = _tensor(step.step_type), _tensor(step.discount)
        rewards = _tensor(step.reward).to(torch.float32, copy=True)  # (Warp's array is the next step's too)
        dones = (step_type == 2).to(torch.long)
        return self.get_observations(), rewards, dones, {"time_outs": truncated(step_type, discount)}

    def close(self) -> None:
        self.env.close()
