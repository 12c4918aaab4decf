"""`sensorcfg.rsl_rl.RslRlVecEnv` over `WarpEnvironment` (Warp's CPU device) and `BatchEnvironment`: RSL-RL's
`OnPolicyRunner` trains on it, its steps return the suite's groups, dones and time-outs (truncations only), the
new episode's first observation at the step that ends one, and its episode lengths are the engines' counters."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()
torch = pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

import sensorcfg  # noqa: E402
from rsl_rl.runners import OnPolicyRunner  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.rsl_rl import RslRlVecEnv  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from test_batch import needs_batch  # noqa: E402

ROBOT = str(assets.path("robot.xml"))
LIMIT = 3  # control steps of 4 ms per episode
SUITE = """
options: {control_interval: 4ms}
sensors:
  q: {kind: qpos, element: ["joint:shoulder", "joint:elbow"], twin: q_clean, noise: [{type: gaussian, std: 0.05}]}
  v: {kind: qvel, element: ["joint:shoulder", "joint:elbow"], twin: v_clean, noise: [{type: gaussian, std: 0.1}]}
  hand: {kind: xpos, element: "site:hand_site", buffer: 2}
groups:
  policy: [q, v]
  critic: ['*_clean', hand]
"""
TRAIN: dict[str, Any] = {
    "num_steps_per_env": 6, "save_interval": 100, "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
    "algorithm": {"class_name": "PPO", "num_learning_epochs": 1, "num_mini_batches": 2, "learning_rate": 1e-3,
                  "rnd_cfg": None, "symmetry_cfg": None},
    "actor": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu",
              "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 0.5}},
    "critic": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu"},
}


def warp_env(nworld: int = 4, **options: Any) -> WarpEnvironment:
    def reward(env: WarpEnvironment) -> wp.array:  # (host arithmetic: Warp's CPU device)
        return wp.array(-np.square(env.data.qvel.numpy()).sum(1).astype(np.float32), device="cpu")

    options.setdefault("autoreset", "same_step")
    return WarpEnvironment(ROBOT, sensorcfg.loads(SUITE), nworld, device="cpu", seed=5, reward_fn=reward,
                           time_limit=LIMIT * 0.004, **options)


def batch_env(nsim: int = 4, **options: Any) -> Any:
    options.setdefault("autoreset", "same_step")
    return sensorcfg.BatchEnvironment(ROBOT, sensorcfg.loads(SUITE), nsim, seed=5, nthread=1,
                                      reward_fn=lambda b: -np.square(b.qvel).sum(1), time_limit=LIMIT * 0.004,
                                      **options)


@pytest.mark.parametrize("make", [warp_env, pytest.param(batch_env, marks=needs_batch)], ids=["warp", "batch"])
def test_the_on_policy_runner_trains_two_iterations(make: Any) -> None:
    vec = RslRlVecEnv(make())
    runner = OnPolicyRunner(vec, copy.deepcopy(TRAIN), log_dir=None, device="cpu")
    before = [p.detach().clone() for p in runner.alg.actor.parameters()]
    runner.learn(num_learning_iterations=2, init_at_random_ep_len=True)
    assert runner.current_learning_iteration == 1
    assert any(not torch.equal(a, b) for a, b in zip(before, runner.alg.actor.parameters()))  # it learned
    assert runner.alg.storage.dones.sum() > 0  # episodes ended within the rollouts


@pytest.mark.parametrize("make", [warp_env, pytest.param(batch_env, marks=needs_batch)], ids=["warp", "batch"])
def test_a_step_returns_groups_dones_time_outs_and_the_next_episode(make: Any) -> None:
    env = make()
    vec = RslRlVecEnv(env)
    widths = {name: g.width for name, g in env.group_spec().items()}
    assert (vec.num_envs, vec.num_actions, vec.device, vec.max_episode_length) == (4, 3, torch.device("cpu"), LIMIT)
    observations = vec.get_observations()
    assert {k: tuple(v.shape) for k, v in observations.items()} == {k: (4, w) for k, w in widths.items()}
    assert all(v.dtype == torch.float32 for v in observations.values())
    vec.episode_length_buf = torch.tensor([0, 1, 2, 2])  # (as `init_at_random_ep_len` staggers episodes)
    actions = torch.full((4, 3), 0.2)
    observations, rewards, dones, extras = vec.step(actions)
    assert dones.tolist() == [0, 0, 1, 1] and extras["time_outs"].tolist() == [False, False, True, True]
    assert rewards.dtype == torch.float32 and rewards.shape == (4,) and vec.episode_length_buf.tolist() == [1, 2, 0, 0]
    # the ended worlds show their new episode's first observation: the suite's reset state, clean
    reset = make(autoreset="next_step")
    first = {k: torch.as_tensor(v).to(torch.float32) for k, v in reset.groups(reset.reset().observation).items()}
    critic = observations["critic"]
    assert torch.equal(critic[2:], first["critic"][2:]) and not torch.equal(critic[:2], first["critic"][:2])


def test_terminations_are_dones_without_time_outs() -> None:
    def termination(env: WarpEnvironment) -> wp.array:
        return wp.array(env.control_steps.numpy() == np.array([1, 0, 0, 0]), dtype=bool, device="cpu")

    vec = RslRlVecEnv(warp_env(termination_fn=termination))
    _, _, dones, extras = vec.step(torch.zeros((4, 3)))
    assert dones.tolist() == [1, 0, 0, 0] and extras["time_outs"].tolist() == [False] * 4


@pytest.mark.parametrize("options, message", [
    pytest.param({"autoreset": "next_step"}, "build the WarpEnvironment with autoreset='same_step'", id="next-step"),
    pytest.param({"suite": {"q": sensorcfg.Feature("qpos", "joint:shoulder")}}, "the suite has no observation groups",
                 id="no-groups"),
])
def test_what_rsl_rl_cannot_train_on_is_said(options: dict[str, Any], message: str) -> None:
    suite = options.pop("suite", None)
    env = (WarpEnvironment(ROBOT, suite, 2, device="cpu", autoreset="same_step") if suite is not None
           else warp_env(**options))
    with pytest.raises(sensorcfg.ArgumentError, match=message):
        RslRlVecEnv(env)
