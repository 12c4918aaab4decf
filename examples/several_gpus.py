"""Train one policy on several GPUs: one process per GPU, each stepping its own slice of one global batch of
MuJoCo Warp worlds, with RSL-RL's PPO (extras `warp` and `rsl-rl`).

    torchrun --nproc-per-node 8 examples/several_gpus.py configs/training.yaml --worlds 4096 --iterations 1000
    torchrun --nproc-per-node 2 examples/several_gpus.py configs/training.yaml --device cpu --worlds 4 \\
        --rollout 12 --out rollout.npz                      # no training: what CI checks, on Warp's CPU device

Process `rank` runs the worlds `rank * worlds .. rank * worlds + worlds - 1` of the batch (`world_offset`), on
`cuda:LOCAL_RANK`: with one seed, the processes together give exactly the worlds of one environment of all of
them (each world's noise, schedules and episodes are keyed by its global index). RSL-RL's `OnPolicyRunner` sets
up torch.distributed (NCCL) under torchrun, starts every process from rank 0's parameters and averages the
gradients. The suite needs a `policy` group (and a `critic` group for privileged observations).

`--rollout K` trains nothing: it steps K control steps with a fixed policy, the same in every process (each
action a function of its world's observation alone), gathers every process's observation groups, dones and
time-outs on rank 0 (torch.distributed: gloo on the CPU, NCCL on GPUs) and saves them in global world order.
The reward here, -|qvel|^2 on the device, stands in for your task's.
"""

from __future__ import annotations

import argparse
import copy
import os
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
import warp as wp

from sensorcfg.rsl_rl import RslRlVecEnv
from sensorcfg.warp.environment import WarpEnvironment


@wp.kernel
def _still(qvel: wp.array2d[float], reward: wp.array[float]):
    w = wp.tid()
    total = float(0.0)
    for i in range(qvel.shape[1]):
        total += qvel[w, i] * qvel[w, i]
    reward[w] = -total


class StayStill:
    """A reward of device work only (a CUDA graph records it): minus each world's squared joint speeds."""

    def __init__(self, nworld: int, device: Any):
        self.out = wp.zeros(nworld, dtype=float, device=device)

    def __call__(self, env: WarpEnvironment) -> wp.array:
        wp.launch(_still, dim=env.nworld, inputs=[env.data.qvel], outputs=[self.out], device=env.device)
        return self.out


def make_env(suite: str, worlds: int, rank: int, device: str, seed: int, time_limit: float,
             model: str | None = None) -> RslRlVecEnv:
    """Process `rank`'s VecEnv: worlds `rank * worlds ..` of the global batch, on `device`."""
    reward = StayStill(worlds, device)
    env = WarpEnvironment(model, suite, worlds, device=device, seed=seed, world_offset=rank * worlds,
                          time_limit=time_limit, reward_fn=reward, autoreset="same_step")
    return RslRlVecEnv(env)


def rollout(vec: RslRlVecEnv, steps: int) -> dict[str, np.ndarray]:
    """`steps` control steps of a fixed policy (`tanh` of a few of each world's own policy values, elementwise:
    the same in every process, whatever its number of worlds); each step's groups, dones and time-outs,
    stacked: (steps + 1, num_envs, ...) groups (the reset's first), (steps, num_envs) the rest."""
    generator = torch.Generator().manual_seed(0)
    observations = vec.get_observations()
    width = observations["policy"].shape[1]
    columns = torch.randint(0, width, (vec.num_actions,), generator=generator)
    gains = torch.randn(vec.num_actions, generator=generator)
    out: dict[str, list[Any]] = {name: [observations[name]] for name in observations.keys()}
    out.update(dones=[], time_outs=[])
    for _ in range(steps):
        actions = torch.tanh(observations["policy"][:, columns] * gains.to(vec.device))
        observations, _, dones, extras = vec.step(actions)
        for name in observations.keys():
            out[name].append(observations[name])
        out["dones"].append(dones)
        out["time_outs"].append(extras["time_outs"])
    return {name: torch.stack(values).cpu().numpy() for name, values in out.items()}


def gathered(local: dict[str, np.ndarray], world_size: int) -> dict[str, np.ndarray] | None:
    """Every process's arrays, worlds in global order (axis 1), on rank 0 (None elsewhere)."""
    parts: list[Any] = [None] * world_size
    dist.gather_object(local, parts if dist.get_rank() == 0 else None, dst=0)
    if dist.get_rank() != 0:
        return None
    return {name: np.concatenate([p[name] for p in parts], axis=1) for name in local}


TRAIN: dict[str, Any] = {
    "num_steps_per_env": 24, "save_interval": 100, "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
    "algorithm": {"class_name": "PPO", "learning_rate": 1e-3, "num_learning_epochs": 5, "num_mini_batches": 4,
                  "entropy_coef": 0.01, "rnd_cfg": None, "symmetry_cfg": None},
    "actor": {"class_name": "MLPModel", "hidden_dims": [256, 128], "activation": "elu", "obs_normalization": True,
              "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
    "critic": {"class_name": "MLPModel", "hidden_dims": [256, 128], "activation": "elu", "obs_normalization": True},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("suite", help="a suite with a 'policy' group (and a 'critic' one)")
    parser.add_argument("--model", help="the model, if not the suite's own 'model:'")
    parser.add_argument("--worlds", type=int, default=4096, help="worlds per process")
    parser.add_argument("--device", default="cuda", help="'cuda' (cuda:LOCAL_RANK per process) or 'cpu'")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--time-limit", type=float, default=10.0, help="seconds per episode")
    parser.add_argument("--iterations", type=int, default=1000)
    parser.add_argument("--log-dir", default=None)
    parser.add_argument("--rollout", type=int, default=0, help="no training: K control steps, saved to --out")
    parser.add_argument("--out", default="rollout.npz")
    args = parser.parse_args()

    rank, local, world_size = (int(os.environ.get(k, d)) for k, d in (("RANK", 0), ("LOCAL_RANK", 0),
                                                                      ("WORLD_SIZE", 1)))
    device = f"cuda:{local}" if args.device == "cuda" else args.device
    if device.startswith("cuda"):
        torch.cuda.set_device(local)
    vec = make_env(args.suite, args.worlds, rank, device, args.seed, args.time_limit, args.model)
    if args.rollout:
        if world_size > 1:
            dist.init_process_group("nccl" if device.startswith("cuda") else "gloo")
        local_arrays = rollout(vec, args.rollout)
        arrays = gathered(local_arrays, world_size) if world_size > 1 else local_arrays
        if arrays is not None:
            np.savez(args.out, **arrays)
        if world_size > 1:
            dist.destroy_process_group()
        return
    from rsl_rl.runners import OnPolicyRunner

    train = copy.deepcopy(TRAIN)  # (RSL-RL takes its settings apart)
    train["obs_groups"]["critic"] = ["critic" if "critic" in vec.env.group_spec() else "policy"]
    runner = OnPolicyRunner(vec, train, log_dir=args.log_dir if rank == 0 else None, device=device)
    runner.learn(num_learning_iterations=args.iterations, init_at_random_ep_len=True)


if __name__ == "__main__":
    main()
