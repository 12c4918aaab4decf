"""What each fast path buys end to end: the same suite stepped with the path and without it, alternating.

Two environments on the same model and suite, A with every path and B with one turned off (the path that
remains without it runs instead; observations are the same bit for bit), are stepped in turn, repeat after
repeat (A B, then B A), with the same random actions; each repeat times whole control steps, physics
included, by CPU time (`time.process_time`: on a shared machine the wall clock also counts other work).
Prints the median of B's time over A's, minus 1 (what the path buys), its quartiles, and (one simulation) A
against a bare mj_step loop (the Environment target's ratio).

    python benchmarks/fast_paths.py PATH [--suite humanoid] [--repeats 21] [--control-steps 200] [--nsim 512]

PATH (turned off in B):
  bank       FeatureBank: plain float64 features of fixed schedules read together (else one FixedChannel each)
  drawnbank  DrawnBank: the same for drawn schedules (else one DrawnChannel each)
  read       a bank's read as one call of the compiled kernel (`_kernel.read`; else its numpy steps)
  snapshot   a bank's snapshot as one call of the compiled kernel (`_kernel.snapshot`; else numpy's take)
  noise      the compiled noise numbers (`_kernel.add`; else numpy's Philox)
  simd       the noise kernel's Philox in AVX-512 or AVX2 intrinsics (`_kernel.simd`; else the portable loop)
  copies     the batch's compiled take / put (`_kernel.gather`, `scatter`; else numpy's take / put): batch suites
  none       nothing: A against an identical B, the comparison's own noise
Suites: humanoid (benchmarks/_humanoid.py), humanoid_noise (its two noise stages per sensor, as
updater.py --noise), proprioception and sim2real (configs/, on the bundled robot); batch, batch_noise and
batch_sim2real: the same as a BatchEnvironment of --nsim simulations (as batch.py, its --noise, --sim2real).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _humanoid import humanoid_xml, sensorcfg_observables  # noqa: E402

import sensorcfg  # noqa: E402
from sensorcfg import assets, compiled  # noqa: E402
from sensorcfg.batch import BatchEnvironment  # noqa: E402
from sensorcfg.noise import streams  # noqa: E402
from sensorcfg.runtime import bank, planned, updater  # noqa: E402

N = 5
CONFIGS = Path(__file__).parent.parent / "configs"

# each path's switch: (module, attribute, the value that turns the path off)
SWITCHES: dict[str, list[tuple[Any, str, Any]]] = {
    "bank": [(updater, "qualifies", lambda ch: False)],
    "drawnbank": [(updater, "joins", lambda ch: False)],
    "read": [(bank, "kernel_read", lambda *args: None), (planned, "kernel_read", lambda *args: None)],
    "snapshot": [(bank, "kernel_snapshot", lambda *args: None), (planned, "kernel_snapshot", lambda *args: None)],
    "noise": [(streams, "_COMPILED", None)],
    "simd": [],  # (`off` switches the kernel's Philox)
    "copies": [(compiled, "MODULE", None)],  # (compiled.take / put read it at each call)
    "none": [],
}


@contextlib.contextmanager
def off(path: str | None) -> Iterator[None]:
    """The path turned off while inside (nothing for None)."""
    saved = [(module, name, getattr(module, name)) for module, name, _ in SWITCHES[path]] if path else []
    for module, name, value in SWITCHES[path] if path else []:
        setattr(module, name, value)
    if path == "simd":
        compiled.MODULE.simd("portable")
    try:
        yield
    finally:
        for module, name, value in saved:
            setattr(module, name, value)
        if path == "simd":
            compiled.MODULE.simd("fastest")


def with_noise(observables: dict[str, Any], model: mujoco.MjModel) -> dict[str, Any]:
    """updater.py --noise: a gaussian and a bias stage on every sensor (binding first tells each its shape)."""
    from updater import with_noise as add_stages

    sensorcfg.Updater(observables, N).reset(sensorcfg.Physics(model), np.random.RandomState(0))
    return add_stages(observables, model.opt.timestep)


def setting(suite: str, nsim: int) -> tuple[mujoco.MjModel, Callable[[], Any]]:
    """The model, and a maker of environments of the suite."""
    if suite.startswith("humanoid") or suite in ("batch", "batch_noise"):
        xml, files = humanoid_xml()
        model = mujoco.MjModel.from_xml_string(xml, files)
        noisy = suite.endswith("noise")
        observables: Callable[[], Any] = (lambda: with_noise(sensorcfg_observables(), model)) if noisy \
            else sensorcfg_observables
        given: Callable[[], Any] = lambda: mujoco.MjSpec.from_string(xml, files)  # noqa: E731 (as from a path)
    else:
        model = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
        name = "sim2real" if suite == "batch_sim2real" else suite
        observables = lambda: sensorcfg.load(CONFIGS / f"{name}.yaml")  # noqa: E731
        given = lambda: str(assets.path("robot.xml"))  # noqa: E731
    if suite.startswith("batch"):
        return model, lambda: BatchEnvironment(given(), observables(), nsim, physics_steps_per_control_step=N, seed=0)
    return model, lambda: sensorcfg.Environment(model, observables(), physics_steps_per_control_step=N, seed=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("path", choices=sorted(SWITCHES))
    parser.add_argument("--suite", default="humanoid", choices=["humanoid", "humanoid_noise", "proprioception",
                                                                "sim2real", "batch", "batch_noise", "batch_sim2real"])
    parser.add_argument("--repeats", type=int, default=21)
    parser.add_argument("--control-steps", type=int, default=200)
    parser.add_argument("--nsim", type=int, default=512)
    args = parser.parse_args()
    batched = args.suite.startswith("batch")
    model, make = setting(args.suite, args.nsim)
    paths = [None, args.path]
    envs = []
    for path in paths:
        with off(path):
            envs.append(make())
    spec = envs[0].action_spec()
    low, high = np.maximum(spec.minimum, -1), np.minimum(spec.maximum, 1)
    shape = (args.control_steps, args.nsim, model.nu) if batched else (args.control_steps, model.nu)
    actions = np.random.default_rng(0).uniform(low, high, shape) * (0.2 if batched else 1.0)
    data = mujoco.MjData(model)

    def run(i: int) -> float:
        with off(paths[i]):
            env = envs[i]
            env.reset()
            t0 = time.process_time()
            for action in actions:
                env.step(action)
            return time.process_time() - t0

    def bare() -> float:
        mujoco.mj_resetData(model, data)
        t0 = time.process_time()
        for action in actions:
            data.ctrl[:] = action
            mujoco.mj_step(model, data, N)
        return time.process_time() - t0

    run(0), run(1)  # warm-up: read plans are built on first use
    ratios, against_bare = [], []
    for r in range(args.repeats):
        times = {}
        for i in (0, 1) if r % 2 == 0 else (1, 0):
            times[i] = run(i)
        ratios.append(times[1] / times[0])
        if not batched:
            against_bare.append(bare() / times[0])
    q1, _, q3 = statistics.quantiles(ratios, n=4)
    bare_ratio = f"; with every path, {statistics.median(against_bare):.2f} of a bare loop" if against_bare else ""
    print(f"{args.suite:15} {args.path:10} buys {100 * (statistics.median(ratios) - 1):+6.1f}% "
          f"(quartiles {100 * (q1 - 1):+.1f}% .. {100 * (q3 - 1):+.1f}%){bare_ratio}; {args.repeats} alternating "
          f"repeats x {args.control_steps} control steps{f' x {args.nsim} simulations' if batched else ''}")


if __name__ == "__main__":
    main()
