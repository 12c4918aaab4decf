"""The Warp engine's cost: world-steps/s of MuJoCo Warp physics alone and of `WarpEnvironment` with a suite.

Setting: Unitree Go2 (tests/models/go2_like.xml, or Menagerie's unitree_go2/scene_mjx.xml through
--model-go2) with benchmarks/suites/go2_sim2real.yaml, and dm_control's humanoid (benchmarks/_humanoid.py,
or --model-humanoid) with benchmarks/suites/humanoid_sim2real.yaml: 20 sensors each, delays (the IMU's
drawn per sample), buffers, aggregators, two noise stages per sensor (misalign and parameters drawn per
episode among them), clean twins. A control step is 4 physics steps.

- physics alone: per control step the actions copied into `ctrl`, then `Worlds.step(4)` (4 `mjw.step` of
  every world, each with the worlds' step counts and divergence check);
- with suite: `WarpEnvironment.step(actions)`: the same physics, the sensors' record after each physics
  step, the episode bookkeeping (the masked restart and one `mjw.forward` of every world per control
  step), the reads and the key table's top-up on the host.

Both run on the same worlds in this process, in pairs (alternating which goes first); the table gives
the medians of the pairs, in physics world-steps per second (worlds x physics steps / s), and the
overhead: (physics rate / suite rate - 1) x 100 %. The device is synchronised before each timer is read.
On CUDA both loops replay each control step as one CUDA graph (WarpEnvironment records its own; the physics
loop is recorded here the same way); on Warp's CPU device both run plain launches.

Two settings, each a pair of loops:
- steady: no world's episode ends (the timed loops have no restarts);
- restarting: every world's episode ends every `PERIOD` control steps, staggered across worlds, so that
  1/PERIOD of the worlds restart in every control step, as in training with many worlds. Physics alone then
  restarts them as mjlab's step does (`ManagerBasedRlEnv.step`: a masked reset, then `sim.forward()` of
  every world); with the suite, `termination_fn` ends the same episodes and `WarpEnvironment.step` restarts
  them (masked reset, one `mjw.forward` of every world, the reset samples).
Each row also prints one `Worlds.forward()` per control step as % of the steady physics' time.

    python benchmarks/warp.py --device cuda:0 --worlds 1024,4096,16384 --model-go2 .../scene_mjx.xml
    python benchmarks/warp.py --quick        # CPU device, 2 worlds, a few steps: checks, not speed

`--quick` (CI) also checks every observation against the observation spec (shape, float32) and that all
values are finite, and that the restarting setting restarts every world once per PERIOD control steps. On
Warp's CPU device the figures say nothing about GPU speed.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
# run as a script, this folder comes first on sys.path, and this file would shadow the `warp` package
sys.path[:] = [p for p in sys.path if Path(p or os.curdir).resolve() != HERE]
ROOT = HERE.parent
SUITES = HERE / "suites"
GO2_LIKE = ROOT / "tests" / "models" / "go2_like.xml"
SUBSTEPS = 4
PERIOD = 50  # control steps per episode in the restarting setting (2% of the worlds restart per step)


@dataclass(frozen=True)
class Row:
    model: str
    worlds: int
    physics: float  # world-steps/s, median of the pairs
    suite: float
    overhead: float  # %
    restarting_physics: float  # world-steps/s with 1/PERIOD of the worlds restarting per control step
    restarting_suite: float
    restarting_overhead: float  # %
    observations: int  # arrays per read (twins included)
    values: int  # float32 values per world and read
    setup: float  # seconds to build the environment (host-side seeds and key table included)
    forward: float  # one mjw.forward of every world per control step, in % of the physics' time


def _ending_kernels() -> tuple[Any, Any]:
    """The restarting setting's episode ends: world w's after its control steps c with (c + w) % period ==
    period - 1 (while `restarting[0]` is 1), so 1/period of the worlds end theirs in every control step; and
    whether any flag is set."""
    import warp as wp

    @wp.kernel
    def ending(steps: wp.array[wp.int64], restarting: wp.array[wp.int32], substeps: wp.int64, period: wp.int64,
               out: wp.array[bool]):
        w = wp.tid()
        out[w] = restarting[0] == 1 and (steps[w] // substeps + wp.int64(w)) % period == period - wp.int64(1)

    @wp.kernel
    def any_set(flags: wp.array[bool], out: wp.array[wp.int32]):
        if flags[wp.tid()]:
            out[0] = 1

    return ending, any_set


def humanoid_model(path: str | None) -> Any:
    """The humanoid as a path (given) or an MjSpec of dm_control's suite/humanoid.xml (the suite adds its
    MuJoCo sensor kinds through the spec)."""
    if path:
        return path
    import importlib.util

    import mujoco

    spec = importlib.util.spec_from_file_location("_humanoid", HERE / "_humanoid.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    xml, assets = module.humanoid_xml()
    return mujoco.MjSpec.from_string(xml, assets)


def actions_for(env: Any, count: int, seed: int = 0) -> list[Any]:
    """`count` (nworld, nu) float32 device arrays of uniform controls over each actuator's ctrlrange
    ([-1, 1] where it has none), cycled through by both loops."""
    import numpy as np
    import warp as wp

    spec = env.action_spec()
    low = np.where(np.isfinite(spec.minimum), spec.minimum, -1.0)
    high = np.where(np.isfinite(spec.maximum), spec.maximum, 1.0)
    rng = np.random.default_rng(seed)
    return [wp.array(rng.uniform(low, high, spec.shape).astype(np.float32), dtype=wp.float32, device=env.device)
            for _ in range(count)]


def timed(run: Callable[[], None], device: Any) -> float:
    import warp as wp

    wp.synchronize_device(device)
    t0 = time.perf_counter()
    run()
    wp.synchronize_device(device)
    return time.perf_counter() - t0


def check(env: Any, observation: dict[str, Any], label: str) -> None:
    """Every observation the spec's shape, float32, finite; the physics state finite."""
    import numpy as np
    import warp as wp

    spec = env.observation_spec()
    if set(observation) != set(spec):
        raise SystemExit(f"{label}: observations {sorted(observation)} are not the spec's {sorted(spec)}")
    for name, array in observation.items():
        if tuple(array.shape) != spec[name].shape or array.dtype != wp.float32:
            raise SystemExit(f"{label}: {name} is {tuple(array.shape)} {wp.types.type_repr(array.dtype)}, the spec "
                             f"says {spec[name].shape} float32")
        values = array.numpy()
        if not np.isfinite(values).all():
            raise SystemExit(f"{label}: {name} has non-finite values")
    for field in ("qpos", "qvel"):
        if not np.isfinite(env.worlds.state(field)).all():
            raise SystemExit(f"{label}: the physics' {field} is not finite")


def measure(label: str, model: Any, suite: Path, nworld: int, device: str, steps: int, pairs: int,
            verify: bool) -> Row:
    import numpy as np
    import warp as wp
    from mujoco_warp._src.types import OverflowType  # (exported as mjw.OverflowType from MuJoCo Warp 4 on)

    from sensorcfg.warp.environment import WarpEnvironment

    # the solver's budgets reached (MuJoCo Warp 4's bits; 3.11 flags none)
    budgets = sum(int(getattr(OverflowType, name, 0)) for name in ("ITERATIONS", "LS_ITERATIONS"))
    built = time.perf_counter()
    ending_kernel, any_kernel = _ending_kernels()
    restarting = wp.zeros(1, dtype=wp.int32, device=device)  # 1: the restarting setting's episodes end
    ending = wp.zeros(nworld, dtype=bool, device=device)

    def termination_fn(env: Any) -> Any:  # device work only: recorded in the step's graph
        wp.launch(ending_kernel, dim=nworld, inputs=[env.worlds.steps, restarting, SUBSTEPS, PERIOD],
                  outputs=[ending], device=env.device)
        return ending

    env = WarpEnvironment(model, str(suite), nworld, device=device, physics_steps_per_control_step=SUBSTEPS,
                          seed=0, termination_fn=termination_fn)
    wp.synchronize_device(env.device)
    built = time.perf_counter() - built
    worlds, ctrl = env.worlds, env.worlds.data.ctrl
    # a solver budget reached is by design in MJX-tuned models (Menagerie's *_mjx.xml: iterations="1"), and
    # MuJoCo Warp prints it from the device per world and step: those two are not printed (the other
    # overflows are, and are counted below)
    worlds.model.opt.warn_overflow = int(worlds.model.opt.warn_overflow) & ~int(budgets)
    actions = actions_for(env, 8)
    last: dict[str, Any] = {}

    buffer = wp.empty_like(actions[0])

    def control_step() -> None:  # the physics of a control step, as WarpEnvironment.step runs it
        wp.copy(ctrl, buffer)
        worlds.step(SUBSTEPS)

    any_ending = wp.zeros(1, dtype=wp.int32, device=device)

    def restart() -> None:
        worlds.reset(ending)
        worlds.forward()

    def restarting_step() -> None:  # and, when some episode ended, the restarts, as mjlab's step does
        control_step()
        termination_fn(env)
        any_ending.zero_()
        wp.launch(any_kernel, dim=nworld, inputs=[ending], outputs=[any_ending], device=env.device)
        wp.capture_if(any_ending, on_true=restart)

    graphs: dict[Callable[[], None], Any] = {}
    if env.device.is_cuda:  # captured as WarpEnvironment captures its step (after a first, eager one)
        for step in (control_step, restarting_step):
            step()
            with wp.ScopedCapture(device=env.device) as capture:
                step()
            graphs[step] = capture.graph

    def physics_loop(step: Callable[[], None]) -> Callable[[], None]:
        def run() -> None:
            for k in range(steps):
                wp.copy(buffer, actions[k % len(actions)])
                if step in graphs:
                    wp.capture_launch(graphs[step])
                else:
                    step()
        return run

    def forward() -> None:  # what WarpEnvironment.step's restart path adds in a control step with a restart
        for _ in range(steps):
            worlds.forward()

    def with_suite() -> None:
        for k in range(steps):
            last.update(env.step(actions[k % len(actions)]).observation)

    env.reset()
    for k in range(2):  # warm-up: kernels loaded (compiled on a cold cache), memory pools grown
        wp.copy(ctrl, actions[k])
        worlds.step(SUBSTEPS)
        env.step(actions[k])
    wp.synchronize_device(env.device)
    rates: dict[str, list[float]] = {}
    settings = {0: {"physics": physics_loop(control_step), "suite": with_suite},
                1: {"restarting physics": physics_loop(restarting_step), "restarting suite": with_suite}}
    for p in range(pairs):
        for setting, loops in settings.items():
            restarting.fill_(setting)
            names = list(loops) if p % 2 == 0 else list(loops)[::-1]
            for name in names:
                rates.setdefault(name, []).append(nworld * steps * SUBSTEPS / timed(loops[name], env.device))
        restarting.zero_()
        rates.setdefault("forward", []).append(nworld * steps * SUBSTEPS / timed(forward, env.device))
    if verify:
        check(env, last, f"{label} x {nworld}")
        restarting.fill_(1)  # over PERIOD control steps every world's episode ends once, and restarts
        firsts = sum(int((env.step(actions[0]).step_type.numpy() == 0).sum()) for _ in range(PERIOD + 1))
        restarting.zero_()
        if firsts < nworld:
            raise SystemExit(f"{label} x {nworld}: {firsts} restarts in {PERIOD + 1} control steps of the restarting "
                             f"setting; every world restarts once in {PERIOD}")
    overflowed = int(((worlds.overflow.numpy().astype(np.int64) & ~int(budgets)) != 0).sum())
    if overflowed:
        print(f"  {label} x {nworld}: {overflowed} world(s) overflowed MuJoCo Warp's contact or constraint sizes "
              "(their physics is wrong; the timing is still of the work done)")
    median = {name: statistics.median(r) for name, r in rates.items()}
    spec = env.observation_spec()
    values = sum(int(_size(s.shape[1:])) for s in spec.values())
    return Row(label, nworld, median["physics"], median["suite"], (median["physics"] / median["suite"] - 1) * 100,
               median["restarting physics"], median["restarting suite"],
               (median["restarting physics"] / median["restarting suite"] - 1) * 100, len(spec), values,
               built, median["physics"] / median["forward"] * 100)


def _size(shape: tuple[int, ...]) -> int:
    n = 1
    for d in shape:
        n *= d
    return n


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cpu", help="a Warp device: cpu, cuda:0 (default: cpu)")
    parser.add_argument("--worlds", help="world counts, comma-separated (default: 8,32 on cpu, 1024,4096,16384 "
                        "on cuda)")
    parser.add_argument("--steps", type=int, help="control steps per timed run (default: 10 on cpu, 200 on cuda)")
    parser.add_argument("--pairs", type=int, default=3, help="timed pairs per setting; medians (default: 3)")
    parser.add_argument("--models", default="go2,humanoid", help="which models: go2, humanoid (default: both)")
    parser.add_argument("--model-go2", help="Go2's scene (default: tests/models/go2_like.xml; on the GPU give "
                        "Menagerie's unitree_go2/scene_mjx.xml)")
    parser.add_argument("--model-humanoid", help="the humanoid's MJCF (default: dm_control's suite/humanoid.xml, "
                        "as benchmarks/_humanoid.py finds it)")
    parser.add_argument("--quick", action="store_true", help="CI: CPU device, 2 worlds, 3 control steps, 1 pair; "
                        "checks the observations against the spec and that they are finite")
    parser.add_argument("--json", help="also write the rows to this file")
    args = parser.parse_args(argv)
    if args.quick:
        args.device, args.worlds, args.steps, args.pairs = "cpu", args.worlds or "2", args.steps or 3, 1
    cuda = args.device.startswith("cuda")
    worlds = [int(w) for w in (args.worlds or ("1024,4096,16384" if cuda else "8,32")).split(",")]
    steps = args.steps or (200 if cuda else 10)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    unknown = sorted(set(models) - {"go2", "humanoid"})
    if unknown or args.pairs < 1 or steps < 1 or min(worlds) < 1:
        parser.error(f"--models takes go2 and humanoid (got {unknown})" if unknown else
                     "--pairs, --steps and --worlds must be positive")

    import mujoco
    import warp as wp

    wp.config.log_level = logging.WARNING  # no line per module loaded
    wp.init()
    device = wp.get_device(args.device)
    go2 = args.model_go2 or str(GO2_LIKE)
    settings = {"go2": (go2, SUITES / "go2_sim2real.yaml"),
                "humanoid": (humanoid_model(args.model_humanoid) if "humanoid" in models else None,
                             SUITES / "humanoid_sim2real.yaml")}
    print(f"device {device.alias} ({device.name}); mujoco {mujoco.__version__}, warp {wp.__version__}; "
          f"{SUBSTEPS} physics steps per control step, {steps} control steps per run, medians of {args.pairs} "
          f"pair(s)")
    print("CUDA graphs: " + ("each control step, physics alone and with the suite, is replayed as one graph" if cuda
                             else "none on the CPU device (plain launches, physics alone and with the suite)"))
    print("MuJoCo Warp's solver-budget warnings (iterations, ls_iterations reached) are not printed; other "
          "overflows are counted per row")
    if not args.model_go2 and "go2" in models:
        print(f"go2: {GO2_LIKE.relative_to(ROOT)} (a stand-in; --model-go2 for Menagerie's scene_mjx.xml)")
    if not cuda:
        print("Warp's CPU device: correctness runs, not GPU speed")
    rows = []
    for name in models:
        model, suite = settings[name]
        for nworld in worlds:
            rows.append(measure(name, model, suite, nworld, args.device, steps, args.pairs, verify=args.quick))
            r = rows[-1]
            print(f"  {r.model} x {r.worlds}: {r.observations} observations, {r.values} values per world; built in "
                  f"{r.setup:.1f} s; one mjw.forward per control step costs {r.forward:.0f}% of the physics",
                  flush=True)
    print(f"M world-steps/s; restarting: {100 // PERIOD}% of the worlds restart in every control step (physics alone "
          "restarts them as mjlab does: masked reset, then a forward of every world)")
    print(f"{'model':<10}{'worlds':>8}{'physics':>10}{'with suite':>12}{'overhead %':>12}"
          f"{'restarting physics':>20}{'with suite':>12}{'overhead %':>12}")
    for r in rows:
        print(f"{r.model:<10}{r.worlds:>8}{r.physics / 1e6:>10.4g}{r.suite / 1e6:>12.4g}{r.overhead:>12.1f}"
              f"{r.restarting_physics / 1e6:>20.4g}{r.restarting_suite / 1e6:>12.4g}{r.restarting_overhead:>12.1f}")
    if args.quick:
        print("quick: every observation matched its spec (shape, float32) and was finite")
    if args.json:
        Path(args.json).write_text(json.dumps({"device": args.device, "substeps": SUBSTEPS, "steps": steps,
                                               "pairs": args.pairs, "graphs": cuda,
                                               "rows": [asdict(r) for r in rows]}, indent=1))


if __name__ == "__main__":
    main()
