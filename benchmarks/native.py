"""What the new kinds cost per control step, against the physics of that control step; single and batched.

Setting: tests/models/terrain.xml (a floating base, two legs, four feet, a floor and a heightfield),
10 physics steps of 2 ms per control step, random actions. Each suite below runs in an Environment (and a
BatchEnvironment of --nsim simulations); the physics alone is the same model (compiled with that suite's
MuJoCo sensors, which MuJoCo computes inside mj_step) stepped with the same actions and no observation.
Cost = time per control step with the suite minus time of the bare physics; medians of the repeats,
interleaved in one process.

    python benchmarks/native.py [--repeats 7] [--control-steps 200] [--nsim 64] [--model PATH --base BODY]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np

import sensorcfg

ROOT = Path(__file__).resolve().parent.parent
TERRAIN = ROOT / "tests" / "models" / "terrain.xml"

SUITES = {
    "no sensor (the Environment's own loop)": "",
    "6 native kinds (the issue's example)": """
  base_lin_vel: {kind: velocimeter, element: body:BASE}
  base_ang_vel: {kind: gyro, element: body:BASE}
  up_in_base: {kind: framezaxis, element: body:world, frame: body:BASE}
  feet_in_base: {kind: framepos, element: ["geom:FL", "geom:FR"], frame: body:BASE}
  imu_acc: {kind: accelerometer, element: site:imu}
  feet_contact: {kind: contact, element: ["geom:FL", "geom:FR"], with: geom:floor, data: [found, force],
                 reduce: netforce, interval: 1, buffer: 10, aggregator: max}""",
    "heightscan 17 x 11 (187 rays), once per control step": """
  scan: {kind: heightscan, element: body:BASE, scan: {size: [1.6, 1.0], resolution: 0.1}, interval: 10}""",
    "heightscan ring 2 x 12 (24 rays), once per control step": """
  scan: {kind: heightscan, element: body:BASE, scan: {pattern: ring, radii: [0.3, 0.6], count: 12}, interval: 10}""",
}


def _suite(body: str, base: str) -> sensorcfg.Suite:
    return sensorcfg.loads("options: {control_interval: 10}\nsensors:" + (body.replace("BASE", base) or " {}"))


def single(suite: sensorcfg.Suite, model_path: str, actions: np.ndarray, repeats: int) -> tuple[float, float]:
    env = sensorcfg.Environment(model_path, suite, seed=0)
    model = env.physics.model
    data = mujoco.MjData(model)
    bare, ours = [], []
    for _ in range(repeats):
        mujoco.mj_resetData(model, data)
        t0 = time.perf_counter()
        for action in actions:
            data.ctrl[:] = action
            mujoco.mj_step(model, data, 10)
        bare.append((time.perf_counter() - t0) / len(actions))
        env.reset()
        t0 = time.perf_counter()
        for action in actions:
            env.step(action)
        ours.append((time.perf_counter() - t0) / len(actions))
    return statistics.median(bare), statistics.median(ours)


def batched(suite: sensorcfg.Suite, model_path: str, actions: np.ndarray, repeats: int, nsim: int) -> tuple[float, float]:
    from mujoco import batch

    env = sensorcfg.BatchEnvironment(model_path, suite, nsim, seed=0)
    raw = batch.Batch(env._model, nsim)
    controls = np.repeat(actions[:, None, None, :], 10, axis=2)  # (steps, 1, 10, nu), broadcast over sims
    bare, ours = [], []
    for _ in range(repeats):
        raw.reset()
        t0 = time.perf_counter()
        for control in controls:
            raw.rollout(10, control=np.broadcast_to(control, (nsim, 10, control.shape[-1])), record=())
        bare.append((time.perf_counter() - t0) / len(actions))
        env.reset()
        t0 = time.perf_counter()
        for action in actions:
            env.step(np.broadcast_to(action, (nsim, action.size)))
        ours.append((time.perf_counter() - t0) / len(actions))
    return statistics.median(bare), statistics.median(ours)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--control-steps", type=int, default=200)
    parser.add_argument("--nsim", type=int, default=0, help="also run batched with this many simulations")
    parser.add_argument("--model", default=str(TERRAIN))
    parser.add_argument("--base", default="base", help="the floating base body's name")
    args = parser.parse_args()
    nu = mujoco.MjModel.from_xml_path(args.model).nu
    actions = np.random.default_rng(0).uniform(-1, 1, (args.control_steps, nu))
    print(f"MuJoCo {mujoco.__version__}, {Path(args.model).name}, per control step of 10 physics steps (median "
          f"of {args.repeats})")
    print(f"{'suite':58s} {'physics':>9s} {'with suite':>11s} {'cost':>9s} {'cost/physics':>12s}")
    runs = [("single", lambda s: single(s, args.model, actions, args.repeats))]
    if args.nsim:
        runs.append((f"batch {args.nsim}", lambda s: batched(s, args.model, actions, args.repeats, args.nsim)))
    for label, body in SUITES.items():
        for where, run in runs:
            bare, ours = run(_suite(body, args.base))
            print(f"{label + ' [' + where + ']':58s} {bare * 1e6:7.0f}us {ours * 1e6:9.0f}us "
                  f"{(ours - bare) * 1e6:7.0f}us {(ours - bare) / bare:11.0%}")


if __name__ == "__main__":
    main()
