"""Gymnasium adapters (extra `gym`: `pip install gymnasium`, or from a clone `pip install '.[gym]'`).

`GymEnv` wraps an `Environment`: a `Dict` observation space from the suite's specs, a `Box` action space
from the actuators' control ranges, and `terminated` / `truncated` from the TimeStep (a discount of 0 ends
an episode by termination, a last step with discount 1, the time limit, by truncation).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import install_hint

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError(f"sensorcfg.gym needs Gymnasium: {install_hint('gym', 'gymnasium')}") from e

from dm_env import specs

from .env.environment import Environment

__all__ = ["GymEnv", "space_from_spec"]


def space_from_spec(spec: specs.Array) -> spaces.Box:
    """A Box for a dm_env spec: its bounds when bounded, else the dtype's full range.

    Args:
        spec: A dm_env `Array` or `BoundedArray` spec (an observation's, or the action's).

    Returns:
        The Gymnasium `Box` of the spec's shape and dtype.
    """
    dtype = np.dtype(spec.dtype)
    if isinstance(spec, specs.BoundedArray):
        low = np.broadcast_to(spec.minimum, spec.shape).astype(dtype)
        high = np.broadcast_to(spec.maximum, spec.shape).astype(dtype)
    elif np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        low, high = np.full(spec.shape, info.min, dtype), np.full(spec.shape, info.max, dtype)
    else:
        low, high = np.full(spec.shape, -np.inf, dtype), np.full(spec.shape, np.inf, dtype)
    return spaces.Box(low=low, high=high, shape=spec.shape, dtype=dtype)


class GymEnv(gymnasium.Env):
    """A Gymnasium view of a sensorcfg `Environment`."""

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(self, env: Environment):
        """Gymnasium's spaces from the environment's specs (a Dict of Boxes for the observations, a Box for the
        action); `step` reports a LAST step with discount 0 as terminated, otherwise as truncated.

        Args:
            env: The sensorcfg `Environment` this view steps (closed by `close`).
        """
        self.env = env
        self.observation_space = spaces.Dict(
            {name: space_from_spec(spec) for name, spec in env.observation_spec().items()})
        self.action_space = space_from_spec(env.action_spec())

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        if seed is not None:
            self.env.seed(seed)
        timestep = self.env.reset()
        return dict(timestep.observation), {}

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        timestep = self.env.step(action)
        last = timestep.last()
        terminated = bool(last and timestep.discount == 0.0)
        truncated = bool(last and not terminated)
        info = {"diverged": self.env.last_divergence} if self.env.last_divergence else {}
        return dict(timestep.observation), float(timestep.reward or 0.0), terminated, truncated, info

    def close(self) -> None:
        self.env.close()
