"""Environment steps per second on mujoco.batch: physics alone, with the suite, and a loop of Environments.

Setting: dm_control's suite/humanoid.xml, 5 physics steps per control step, the 20-observable suite of
benchmarks/_humanoid.py, random controls. The environment gets the robot as an MjSpec (as from a path), so
that it may add relay sensors (`sensorcfg.batch.relay`; `--mjmodel` gives it the compiled MjModel
instead: no relays). For each nsim (64 and 512 by default), each repeat times K control steps of:

  batched    `BatchEnvironment.step`: one rollout recording the suite's fields, plus the vectorised updater
  physics    `Batch.rollout(5, control=...)` recording nothing, on a Batch of the robot as written (no
             relay sensors) from the same state: the floor for any batched suite
  null       the same on a second such Batch: the noise floor of the comparison (ideally 0%), instances
             included (identical instances differ by up to 2% here)
  recording  the environment's rollout recording what it records, without the updater: MuJoCo's share
             of the suite cost (the rest is the vectorised updater in Python)
  floor      recording, plus the environment's copies of bound fields and one `take` of every value its
             reads need: the least a suite that records with `rollout` and reads the records can add
  loop       nsim single-simulation `Environment.step`s with the same suite (one MjData each)

Paired measurement: every variant runs every control step from the same simulation state (copied into
its Batch; their order rotates), so that the state (contacts make steps dearer) does not tilt the ratio.
Physics and null also copy out the fields the environment binds (`Batch.bind`: those read only after a
control step's last substep), which MuJoCo does after every call; measured against unbound Batches from
the same state, that is within their own spread (+-0.5%). The suite cost includes everything else, the
relay sensors' computation too.

Prints medians over repeats of environment steps per second (control steps times simulations, per second
of wall time) and the ratios. Targets: the suite adds at most 5% to batched physics at 512 simulations;
batched at least 1.8x the loop on 2 cores.

    MUJOCO_GL=egl python benchmarks/batch.py [--nsim 64 512] [--repeats 7] [--control-steps 20] [--nthread 0]
    MUJOCO_GL=egl python benchmarks/batch.py --sim2real [--nsim 64 512]   # the bundled robot + configs/sim2real.yaml

With --sim2real the model is the bundled robot and the suite configs/sim2real.yaml (random latency and noise
on every sensor), 5 physics steps per control step; "physics / batched" is the ratio the issue asks >= 0.8.

Needs MuJoCo 4 (mujoco.batch).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from typing import Any

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
from mujoco.batch import Batch  # noqa: E402
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
    parser.add_argument("--sim2real", action="store_true", help="the bundled robot with configs/sim2real.yaml")
    parser.add_argument("--mjmodel", action="store_true",
                        help="give the environment the compiled MjModel (no relays) instead of the MjSpec")
    args = parser.parse_args()

    if args.sim2real:
        from pathlib import Path

        from sensorcfg import assets as bundled

        source: Any = mujoco.MjSpec.from_file(str(bundled.path("robot.xml")))
        sim2real = sensorcfg.load(Path(__file__).parent.parent / "configs" / "sim2real.yaml")
    else:
        xml, assets = humanoid_xml()
        source = mujoco.MjSpec.from_string(xml, assets)
    model = source.copy().compile()  # the robot as written: what "physics" steps
    given = model if args.mjmodel else source  # a spec (as a path): the environment may add relays
    k = args.control_steps
    what = "bundled robot + configs/sim2real.yaml" if args.sim2real else f"humanoid, {len(SUITE)} observables"
    print(f"{what}, {N} physics steps per control step"
          f"{' (+2 gaussian noise stages each)' if args.noise else ''}; mujoco {mujoco.__version__}, "
          f"{os.cpu_count()} CPUs, nthread={args.nthread or 'all'}; medians of {args.repeats} repeats x {k} "
          "control steps")
    print(f"{'nsim':>6} {'physics':>12} {'batched':>12} {'loop':>12} {'suite cost':>11} {'recording':>11} "
          f"{'floor':>7} {'null':>8} {'batched/loop':>13} {'reset':>9} {'batched/physics':>16}")
    for nsim in args.nsim:
        rng = np.random.default_rng(0)
        lo, hi = model.actuator_ctrlrange.T
        actions = rng.uniform(lo, hi, (k, nsim, model.nu)) * 0.2

        def suite() -> Any:
            if args.sim2real:
                return sim2real
            observables = sensorcfg_observables()
            return noisy(observables, model) if args.noise else observables

        env = BatchEnvironment(given, suite(), nsim, nthread=args.nthread, physics_steps_per_control_step=N, seed=0)
        loop = [] if args.no_loop else [
            sensorcfg.Environment(model, suite(), physics_steps_per_control_step=N, seed=i) for i in range(nsim)]
        state = env.batch.state  # (nsim, nstate): every simulation's mjSTATE_INTEGRATION row, writable
        layout = env.updater.layout
        # physics and null: the robot as written (no relay sensors), binding what the environment binds
        bare = {name: Batch(model, nsim, args.nthread) for name in ("physics", "null")}
        for batch in bare.values():
            for f in {f for bound in layout.bound for f in bound}:
                batch.bind(f)

        def physics_of(batch: Any) -> Callable[[np.ndarray], None]:
            return lambda a: batch.rollout(N, control=a[:, None, :], record=())

        def record_step(a: np.ndarray, env: BatchEnvironment = env, layout: Any = layout) -> None:
            for (first, last, _), out in zip(layout.segments, layout.record_out):
                env.batch.rollout(last - first + 1, control=a[:, None, :], record=list(out), out=out)

        def floor_step(a: np.ndarray, env: BatchEnvironment = env, layout: Any = layout) -> None:
            updater = env.updater
            env._rollout(a, np.ones(env.nsim, bool), np.zeros(env.nsim, bool), {})
            if layout.fixed:
                updater.flat.take(layout.gathers(updater.global_step % updater.rows, updater.age), mode="clip")

        def loop_step(a: np.ndarray, loop: list = loop) -> None:
            for e, ai in zip(loop, a):
                e.step(ai)

        def repeat(env: BatchEnvironment = env, loop: list = loop, state: np.ndarray = state,
                   actions: np.ndarray = actions, nsim: int = nsim) -> dict[str, float]:
            """K control steps of each variant; returns env steps per second of each (and the reset's seconds)."""
            t0 = time.perf_counter()
            env.reset()  # a full reset: every simulation starts an episode
            reset = time.perf_counter() - t0
            for e in loop:
                e.reset()
            paired = [("physics", physics_of(bare["physics"])), ("null", physics_of(bare["null"])),
                      ("recording", record_step), ("floor", floor_step), ("batched", env.step)]
            states = {name: bare[name].state if name in bare else state for name, _ in paired}
            wall = dict.fromkeys([name for name, _ in paired] + (["loop"] if loop else []), 0.0)
            for i, a in enumerate(actions):
                start = state.copy()
                after = None
                for name, fn in paired[i % len(paired):] + paired[:i % len(paired)]:
                    states[name][:] = start
                    t0 = time.perf_counter()
                    fn(a)
                    wall[name] += time.perf_counter() - t0
                    if name == "batched":
                        after = state.copy()
                state[:] = after  # the environment goes on from its own step
                if loop:
                    t0 = time.perf_counter()
                    loop_step(a)
                    wall["loop"] += time.perf_counter() - t0
            return {**{name: k * nsim / t for name, t in wall.items()}, "reset": reset}

        repeat()  # warm-up
        rows: dict[str, list[float]] = {}
        for _ in range(args.repeats):
            for name, value in repeat().items():
                rows.setdefault(name, []).append(value)
        med = {name: statistics.median(v) for name, v in rows.items()}
        nan = float("nan")
        cost = med["physics"] / med["batched"] - 1
        null = med["physics"] / med["null"] - 1
        recording = med["physics"] / med["recording"] - 1
        floor = med["physics"] / med["floor"] - 1
        print(f"{nsim:>6} {med['physics']:>12,.0f} {med['batched']:>12,.0f} {med.get('loop', nan):>12,.0f} "
              f"{100 * cost:>10.1f}% {100 * recording:>10.1f}% {100 * floor:>6.1f}% {100 * null:>+7.1f}% "
              f"{med['batched'] / med.get('loop', nan):>12.2f}x {1000 * med['reset']:>7.1f}ms "
              f"{med['batched'] / med['physics']:>16.2f}")
    print("env steps/s: control steps x simulations per wall-clock second. suite cost = physics/batched - 1 "
          "(target <= 5% at 512), of which recording = physics/recording - 1 is MuJoCo's; floor = recording "
          "plus one gather of what the reads need; null = physics against itself (the comparison's noise); "
          "batched/loop target >= 1.8x on 2 cores; reset: a full reset of every simulation (median)")


if __name__ == "__main__":
    main()
