"""Train mjlab's Unitree Go1 velocity task on a sensorcfg suite's observations, with mjlab's RSL-RL runner.

    python examples/mjlab/train.py [--num-envs 4096] [--iterations 1500] [--device cuda:0] [--log-dir DIR]

The task is mjlab's `Mjlab-Velocity-Flat-Unitree-Go1` (its terrain, commands, rewards, terminations, events and
curriculum) with its observation groups replaced by `go1_velocity.yaml`'s: the actor reads the suite's noisy,
delayed `policy` group, the critic its clean twins (`critic`), each followed by the task's own `actions` and
`command` terms. Everything else is mjlab's own training script's (`mjlab/scripts/train.py`): the task's PPO
settings, `RslRlVecEnvWrapper`, the task's runner. Needs the `mjlab` extra (`pip install '.[mjlab]'` in the
clone); a GPU to train in earnest (`--device cpu` runs, slowly: the CI runs 2 iterations of 2 worlds).
"""

from __future__ import annotations

import argparse
from dataclasses import asdict
from pathlib import Path
from typing import Any

TASK = "Mjlab-Velocity-Flat-Unitree-Go1"
SUITE = Path(__file__).resolve().parent / "go1_velocity.yaml"
GROUPS = {"actor": "policy", "critic": "critic"}  # mjlab's observation group -> the suite's
KEEP = ("actions", "command")  # the task's terms kept after the suite's columns: not sensors


def make_env(num_envs: int, device: str, seed: int, suite: Path | str = SUITE, world_offset: int = 0) -> Any:
    """mjlab's environment of `TASK` for `num_envs` worlds, its observations `suite`'s (`sensorcfg.mjlab.attach`);
    noise keyed by global world (`world_offset` + w) from `seed`."""
    import mjlab.tasks  # noqa: F401  (registers the tasks)
    from mjlab.envs import ManagerBasedRlEnv
    from mjlab.tasks.registry import load_env_cfg

    from sensorcfg.mjlab import attach

    env_cfg = load_env_cfg(TASK)
    env_cfg.scene.num_envs = num_envs
    env_cfg.seed = seed
    attach(env_cfg, suite, GROUPS, keep=KEEP, seed=seed, world_offset=world_offset)
    return ManagerBasedRlEnv(cfg=env_cfg, device=device)


def train(num_envs: int, iterations: int, device: str, seed: int = 0, log_dir: str | None = None,
          steps_per_env: int | None = None) -> Any:
    """`iterations` of PPO with the task's runner and settings (`steps_per_env`: rollout length, the task's when
    None); the runner, once trained. Without `log_dir` nothing is written."""
    from mjlab.rl import MjlabOnPolicyRunner, RslRlVecEnvWrapper
    from mjlab.tasks.registry import load_rl_cfg, load_runner_cls

    env = make_env(num_envs, device, seed)
    agent_cfg = load_rl_cfg(TASK)
    agent_cfg.seed = seed
    if steps_per_env is not None:
        agent_cfg.num_steps_per_env = steps_per_env
    wrapped = RslRlVecEnvWrapper(env, clip_actions=agent_cfg.clip_actions)
    runner_cls = load_runner_cls(TASK) or MjlabOnPolicyRunner
    runner = runner_cls(wrapped, asdict(agent_cfg), log_dir, device)
    runner.learn(num_learning_iterations=iterations, init_at_random_ep_len=True)
    return runner


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--num-envs", type=int, default=4096)
    parser.add_argument("--iterations", type=int, default=1500)
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--log-dir", default=None, help="where the runner writes checkpoints and logs")
    args = parser.parse_args(argv)
    train(args.num_envs, args.iterations, args.device, args.seed, args.log_dir)


if __name__ == "__main__":
    main()
