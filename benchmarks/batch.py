"""Environment steps per second on mujoco.batch: physics alone, with the suite, and a loop of Environments.

Setting: dm_control's suite/humanoid.xml, 5 physics steps per control step, the 20-observable suite of
benchmarks/_humanoid.py, random controls. For each nsim (64 and 512 by default), each repeat times K
control steps of:

  physics    `Batch.rollout(5, control=...)` recording nothing: the floor for any batched suite
  batched    `BatchEnvironment.step`: one rollout recording the suite's fields, plus the vectorised updater
  loop       nsim single-simulation `Environment.step`s with the same suite (one MjData each)

Within a repeat the three variants alternate every control step, so that load from other processes hits
them alike. Prints medians over repeats of environment steps per second (control steps times
simulations, per second of wall time) and the ratios. Targets: the suite adds at most 5% to batched
physics at 512 simulations; batched at least 1.8x the loop on 2 cores.

    MUJOCO_GL=egl python benchmarks/batch.py [--nsim 64 512] [--repeats 7] [--control-steps 20] [--nthread 0]

Needs MuJoCo 4 (mujoco.batch).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _humanoid import SUITE, humanoid_xml, sensorcfg_observables  # noqa: E402

import sensorcfg  # noqa: E402
from sensorcfg.batch import BatchEnvironment  # noqa: E402

N = 5


def noisy(observables: dict, model: mujoco.MjModel) -> dict:
    """Two gaussian stages on every observable (bound once to learn its shape)."""
    from sensorcfg.noise import build_noise

    physics = sensorcfg.Physics(model)
    for obs in observables.values():
        spec = obs.reader(physics).index
        obs.noise = build_noise([{"type": "gaussian", "std": 0.01}, {"type": "gaussian", "mean": 0.001, "std": 0.002}],
                                spec.shape, np.float64, model.opt.timestep)
    return observables


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nsim", type=int, nargs="+", default=[64, 512])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--control-steps", type=int, default=20)
    parser.add_argument("--nthread", type=int, default=0, help="batch threads (0: every CPU)")
    parser.add_argument("--no-loop", action="store_true", help="skip the single-simulation loop")
    parser.add_argument("--noise", action="store_true", help="two gaussian noise stages on every sensor")
    args = parser.parse_args()
    from mujoco import batch as mjbatch

    xml, assets = humanoid_xml()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    k = args.control_steps
    print(f"humanoid, {N} physics steps per control step, {len(SUITE)} observables"
          f"{' (+2 gaussian noise stages each)' if args.noise else ''}; mujoco {mujoco.__version__}, "
          f"{os.cpu_count()} CPUs, nthread={args.nthread or 'all'}; medians of {args.repeats} repeats x {k} "
          "control steps")
    print(f"{'nsim':>6} {'physics':>12} {'batched':>12} {'loop':>12} {'suite cost':>11} {'batched/loop':>13} "
          f"{'suite cost CPU':>14}")
    for nsim in args.nsim:
        rng = np.random.default_rng(0)
        lo, hi = model.actuator_ctrlrange.T
        actions = rng.uniform(lo, hi, (k, nsim, model.nu)) * 0.2
        physics = mjbatch.Batch(model, nsim, args.nthread)

        def suite() -> dict:
            observables = sensorcfg_observables()
            return noisy(observables, model) if args.noise else observables

        env = BatchEnvironment(model, suite(), nsim, nthread=args.nthread, physics_steps_per_control_step=N, seed=0)
        loop = [] if args.no_loop else [
            sensorcfg.Environment(model, suite(), physics_steps_per_control_step=N, seed=i) for i in range(nsim)]

        def physics_step(a: np.ndarray) -> None:
            physics.rollout(N, control=a[:, None, :], record=())

        def loop_step(a: np.ndarray) -> None:
            for e, ai in zip(loop, a):
                e.step(ai)

        def repeat() -> dict[str, float]:
            """One run of K control steps of each variant, interleaved per control step (so that load from
            other processes hits all three alike); returns env steps per second of each."""
            physics.reset()
            env.reset()
            for e in loop:
                e.reset()
            names = ["physics", "batched"] + (["loop"] if loop else [])
            wall = dict.fromkeys(names, 0.0)
            cpu = dict.fromkeys(names, 0.0)
            variants = list(zip(names, [physics_step, env.step, loop_step]))
            for a in actions:
                for name, fn in variants:
                    c0, t0 = time.process_time(), time.perf_counter()
                    fn(a)
                    wall[name] += time.perf_counter() - t0
                    cpu[name] += time.process_time() - c0
            return {**{name: k * nsim / t for name, t in wall.items()},
                    **{"cpu " + name: t / (k * nsim) for name, t in cpu.items()}}

        repeat()  # warm-up
        rows: dict[str, list[float]] = {}
        for _ in range(args.repeats):
            for name, value in repeat().items():
                rows.setdefault(name, []).append(value)
        med = {name: statistics.median(v) for name, v in rows.items()}
        nan = float("nan")
        cost = med["physics"] / med["batched"] - 1
        cpu_cost = med["cpu batched"] / med["cpu physics"] - 1
        print(f"{nsim:>6} {med['physics']:>12,.0f} {med['batched']:>12,.0f} {med.get('loop', nan):>12,.0f} "
              f"{100 * cost:>10.1f}% {med['batched'] / med.get('loop', nan):>12.2f}x {100 * cpu_cost:>13.1f}%")
    print("env steps/s: control steps x simulations per wall-clock second. suite cost = physics/batched - 1 "
          "(target <= 5% at 512), also in CPU seconds (all threads of this process, less sensitive to other "
          "processes); batched/loop target >= 1.8x on 2 cores")


if __name__ == "__main__":
    main()
