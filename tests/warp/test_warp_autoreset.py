"""`WarpEnvironment(autoreset="same_step")` on Warp's CPU device: the step that ends a world's episode returns
its next episode's first observation, truncations told from terminations on the device, and each new episode
the same as in next-step mode (the same keys, so the same observations given the same actions); and the
suite's observation groups, in the order tests/env/test_environment_groups.py pins."""

from __future__ import annotations

from typing import Any

import numpy as np

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from test_batch_autoreset import LIMIT, ROBOT, STOP, SUBSTEPS, SUITE, assert_same_episodes, record  # noqa: E402
from test_environment_groups import COLUMNS, SUITE as GROUPED  # noqa: E402


def worlds(autoreset: str, nworld: int = 3) -> WarpEnvironment:
    """Worlds of the suite whose world 1 terminates at control step `STOP` of each of its episodes."""
    env: WarpEnvironment | None = None

    def termination(_: Any) -> wp.array:
        assert env is not None
        ends = (np.arange(nworld) == 1) & (env.control_steps.numpy() == STOP)
        return wp.array(ends, dtype=bool, device="cpu")

    env = WarpEnvironment(ROBOT, sensorcfg.loads(SUITE), nworld, device="cpu", seed=7, termination_fn=termination,
                          time_limit=LIMIT * SUBSTEPS * 0.002, autoreset=autoreset)
    return env


def test_same_step_episodes_are_the_next_step_episodes() -> None:
    assert_same_episodes(record(worlds("same_step"), 14), record(worlds("next_step"), 20))


def test_the_ending_step_starts_the_next_episode_on_the_device() -> None:
    env = worlds("same_step")
    episodes = record(env, 6)
    assert [e["end"] for e in episodes[0][:1]] == ["truncated"] and [len(e["observations"]) for e in
                                                                        episodes[0][:1]] == [LIMIT]
    assert [e["end"] for e in episodes[1][:2]] == ["terminated", "terminated"]
    step = env.step(np.zeros((3, env.action_spec().shape[1]), np.float32))
    assert env.control_steps.numpy().tolist() == [3, 1, 3] and step.step_type.numpy().tolist() == [1, 1, 1]
    assert env.steps.numpy().tolist() == [3 * SUBSTEPS, SUBSTEPS, 3 * SUBSTEPS]  # the new episode's physics steps


def test_the_groups_are_the_cpu_engines_columns_as_torch_tensors() -> None:
    import torch

    env = WarpEnvironment(ROBOT, sensorcfg.loads(GROUPED), 2, device="cpu", seed=3)
    assert {name: [(c.name, c.start, c.stop, c.shape) for c in g.columns]
            for name, g in env.group_spec().items()} == COLUMNS
    step = env.step(np.full((2, env.action_spec().shape[1]), 0.3, np.float32))
    for name, vector in env.groups(step.observation).items():
        assert isinstance(vector, torch.Tensor) and vector.dtype == torch.float32
        expected = np.concatenate([step.observation[c].numpy().reshape(2, -1) for c, *_ in COLUMNS[name]], axis=-1)
        assert vector.shape == (2, env.group_spec()[name].width) and vector.numpy().tobytes() == expected.tobytes()
