"""Load a sensor suite, run one episode with random actions, print observation shapes and timings.

    python examples/random_episode.py [SUITE.yaml] [--seed 0] [--seconds 2]

Without a suite it runs sensorcfg's bundled demo suite on the bundled robot.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import sensorcfg
from sensorcfg import assets


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("suite", nargs="?", default=str(assets.path("demo.yaml")))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--seconds", type=float, default=2.0, help="episode length (simulated seconds)")
    args = parser.parse_args()

    env = sensorcfg.make_env(args.suite, time_limit=args.seconds, seed=args.seed)
    spec = env.action_spec()
    rng = np.random.default_rng(args.seed)
    print(f"{args.suite}: {env.physics_steps_per_control_step} physics steps per control step "
          f"({env.control_timestep * 1e3:g} ms)")
    for name, s in env.observation_spec().items():
        print(f"  {name:<22} {str(s.shape):<16} {np.dtype(s.dtype).name}")

    timestep = env.reset()
    steps, start = 0, time.perf_counter()
    while not timestep.last():
        timestep = env.step(rng.uniform(np.maximum(spec.minimum, -1), np.minimum(spec.maximum, 1)))
        steps += 1
    elapsed = time.perf_counter() - start
    print(f"{steps} control steps in {elapsed:.3f} s: {steps / elapsed:.0f} steps/s, "
          f"{steps * env.control_timestep / elapsed:.1f}x real time")
    for name, count in env.updater.samples_taken().items():
        print(f"  {name:<22} {count} samples taken")


if __name__ == "__main__":
    main()
