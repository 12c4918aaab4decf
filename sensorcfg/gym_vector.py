"""A Gymnasium vector environment over a `BatchEnvironment` (extra `gym`: `pip install gymnasium`, or from a
clone `pip install '.[gym]'`).

`GymVectorEnv` has Gymnasium's next-step autoreset (`AutoresetMode.NEXT_STEP`), which is the batch's own:
the step after a simulation's episode ends resets it, returns its first observation, and ignores its
action. `terminated` is an episode end with discount 0 (a diverged simulation), `truncated` one with
discount 1 (the time limit). `reset(seed=s)` reseeds every simulation (simulation i from
`sim_seed(s, i)`); `reset(options={"reset_mask": mask})` resets only the masked simulations.
Observation and action spaces are the single simulation's, batched by `gymnasium.vector.utils.batch_space`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import install_hint

try:
    from gymnasium import spaces
    from gymnasium.vector import AutoresetMode, VectorEnv
    from gymnasium.vector.utils import batch_space
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError(f"sensorcfg.gym_vector needs Gymnasium >= 1.1: {install_hint('gym', 'gymnasium>=1.1')}") from e

from dm_env import specs

from .batch import BatchEnvironment
from .gym import space_from_spec

__all__ = ["GymVectorEnv"]


def _single(spec: specs.Array) -> specs.Array:
    """The spec of one simulation (without the leading nsim axis)."""
    if isinstance(spec, specs.BoundedArray):
        return specs.BoundedArray(spec.shape[1:], spec.dtype, np.broadcast_to(spec.minimum, spec.shape)[0],
                                  np.broadcast_to(spec.maximum, spec.shape)[0], name=spec.name)
    return specs.Array(spec.shape[1:], spec.dtype, name=spec.name)


class GymVectorEnv(VectorEnv):
    """A Gymnasium `VectorEnv` view of a sensorcfg `BatchEnvironment`."""

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, env: BatchEnvironment):
        """Gymnasium's spaces from the batch's specs, one simulation's (`single_observation_space`,
        `single_action_space`) and the batch's; episodes auto-reset at the next step, as the batch's do.

        Args:
            env: The sensorcfg `BatchEnvironment` this view steps, one Gymnasium environment per simulation
                (closed by `close`).
        """
        self.env = env
        self.num_envs = env.nsim
        self.single_observation_space = spaces.Dict(
            {name: space_from_spec(_single(spec)) for name, spec in env.observation_spec().items()})
        self.single_action_space = space_from_spec(_single(env.action_spec()))
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        if seed is not None:
            self.env.seed(seed)
        mask = (options or {}).get("reset_mask")
        timestep = self.env.reset(None if mask is None else np.asarray(mask, bool))
        return dict(timestep.observation), {}

    def step(self, actions: Any) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        timestep = self.env.step(actions)
        last = timestep.last()
        terminated = last & (timestep.discount == 0.0)
        truncated = last & ~terminated
        info: dict[str, Any] = {}
        diverged = terminated & np.array([m is not None for m in self.env.last_divergence])
        if diverged.any():
            info["diverged"] = np.array([m or "" for m in self.env.last_divergence], dtype=object)
            info["_diverged"] = diverged
        return dict(timestep.observation), timestep.reward.copy(), terminated, truncated, info

    def close_extras(self, **kwargs: Any) -> None:
        self.env.close()
