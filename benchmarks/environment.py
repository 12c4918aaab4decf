"""Environment steps per second with a suite, against a bare loop of mj_step on the same model.

Setting: dm_control's suite/humanoid.xml with the 20-observable suite of benchmarks/_humanoid.py, and the
bundled robot with configs/proprioception.yaml; 5 physics steps per control step, random actions. Both
loops run in this process, interleaved per repeat; medians of the repeats.

    python benchmarks/environment.py [--repeats 9] [--control-steps 500]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _humanoid import humanoid_xml, sensorcfg_observables  # noqa: E402

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402

N = 5


def bare_loop(model: mujoco.MjModel, data: mujoco.MjData, actions: np.ndarray) -> None:
    for action in actions:
        data.ctrl[:] = action
        for _ in range(N):
            mujoco.mj_step(model, data)


def env_loop(env: sensorcfg.Environment, actions: np.ndarray) -> None:
    env.reset()
    for action in actions:
        env.step(action)


def measure(label: str, env: sensorcfg.Environment, repeats: int, steps: int) -> None:
    model = env.physics.model
    data = mujoco.MjData(model)
    spec = env.action_spec()
    rng = np.random.default_rng(0)
    low, high = np.maximum(spec.minimum, -1), np.minimum(spec.maximum, 1)
    actions = rng.uniform(low, high, (steps, model.nu))
    bare, ours = [], []
    env_loop(env, actions[:20])  # warm-up: read layouts are built on first use
    for _ in range(repeats):
        mujoco.mj_resetData(model, data)
        t0 = time.perf_counter()
        bare_loop(model, data, actions)
        bare.append(steps / (time.perf_counter() - t0))
        t0 = time.perf_counter()
        env_loop(env, actions)
        ours.append(steps / (time.perf_counter() - t0))
    b, e = statistics.median(bare), statistics.median(ours)
    print(f"{label:<44}{b:>12.0f}{e:>12.0f}{e / b:>9.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--control-steps", type=int, default=500)
    args = parser.parse_args()
    xml, files = humanoid_xml()
    humanoid = mujoco.MjModel.from_xml_string(xml, files)
    print(f"control steps/s, {N} physics steps each; medians of {args.repeats} repeats x {args.control_steps} "
          f"steps; mujoco {mujoco.__version__}")
    print(f"{'model + suite':<44}{'bare loop':>12}{'env':>12}{'ratio':>9}")
    measure("humanoid + 20-observable suite", sensorcfg.Environment(
        humanoid, sensorcfg_observables(), physics_steps_per_control_step=N, seed=0), args.repeats,
        args.control_steps)
    robot = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
    suite = Path(__file__).parent.parent / "configs"
    for name in ("proprioception.yaml", "sim2real.yaml"):
        measure(f"bundled robot + configs/{name}", sensorcfg.Environment(
            robot, sensorcfg.load(suite / name), physics_steps_per_control_step=N, seed=0), args.repeats,
            args.control_steps)


if __name__ == "__main__":
    main()
