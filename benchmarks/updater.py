"""Per-control-step cost of dm_control's Updater and sensorcfg's, side by side in one process.

Setting: dm_control's suite/humanoid.xml, 5 physics steps per control step, the 20-observable
proprioceptive suite of benchmarks/_humanoid.py (mixed intervals, delays, buffers, aggregators). Both
updaters read the same dm_control Physics. Each repeat runs K control steps of: physics alone, physics +
sensorcfg, physics + dm_control (interleaved, so drift hits all three alike); an updater's cost is its loop
minus the physics loop of the same repeat. Prints medians over the repeats and the ratios.

    python benchmarks/updater.py [--repeats 15] [--control-steps 200] [--noise] [--no-dm-control]

Needs dm_control (the MuJoCo 3.17.0 environment: `nox -s oracle-mujoco3` installs it), except with
--no-dm-control: sensorcfg's Updater alone, on sensorcfg's own Physics (any MuJoCo).
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

N = 5


def _dm_corruptor(bias: float):
    """What a dm_control user writes by hand for the same two stages (bias fixed when the suite is built)."""
    return lambda value, random_state: value + random_state.normal(0.0, 0.01, np.shape(value)) + bias


def dm_control_setup(noise: bool = False):
    from dm_control import mjcf
    from dm_control.composer.observation import updater as dm_updater
    from dm_control.composer.observation.observable import mjcf as dm_mjcf

    xml, assets = humanoid_xml()
    root = mjcf.from_xml_string(xml, assets=assets)
    physics = mjcf.Physics.from_mjcf_model(root)
    observables = {}
    for name, (kind, etype, names, interval, delay, buffer, agg) in SUITE.items():
        element = root.find(etype, names) if isinstance(names, str) else [root.find(etype, n) for n in names]
        obs = dm_mjcf.MJCFFeature(kind, element, update_interval=interval, delay=delay, buffer_size=buffer,
                                  aggregator=agg, corruptor=_dm_corruptor(0.001) if noise else None)
        obs.enabled = True
        observables[name] = obs
    return physics, dm_updater.Updater(observables, N)


def with_noise(observables: dict, timestep: float) -> dict:
    from sensorcfg.config.noise import NoiseStage
    from sensorcfg.noise import build_noise
    from pydantic import TypeAdapter

    # the usual sensor model: white noise and a per-episode calibration bias
    stages = TypeAdapter(list[NoiseStage]).validate_python(
        [{"type": "gaussian", "std": 0.01}, {"type": "bias", "std": 0.002}])
    for obs in observables.values():
        obs.noise = build_noise(stages, obs.array_spec.shape, obs.array_spec.dtype, timestep) if obs.array_spec else None
    return observables


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--control-steps", type=int, default=200)
    parser.add_argument("--noise", action="store_true",
                        help="two noise stages (gaussian, bias) on every sensor, in both updaters (dm_control: "
                             "the same stages as its corruptor)")
    parser.add_argument("--no-dm-control", action="store_true",
                        help="time sensorcfg's Updater alone, on sensorcfg.Physics (no dm_control needed)")
    args = parser.parse_args()
    if args.no_dm_control:
        xml, assets = humanoid_xml()
        physics, dm = sensorcfg.Physics(mujoco.MjModel.from_xml_string(xml, assets)), None
        model, data = physics.model, physics.data
    else:
        physics, dm = dm_control_setup(args.noise)
        model, data = physics.model.ptr, physics.data.ptr
    ours_obs = sensorcfg_observables()
    ours = sensorcfg.Updater(ours_obs, N)
    if args.noise:  # binding first tells each feature its shape
        ours.reset(physics, np.random.RandomState(0))
        with_noise(ours_obs, model.opt.timestep)
    k = args.control_steps

    def physics_only() -> None:
        for _ in range(k):
            for _ in range(N):
                mujoco.mj_step(model, data)

    def with_updater(updater) -> None:
        prepare, update, observe = updater.prepare_for_next_control_step, updater.update, updater.get_observation
        for _ in range(k):
            prepare()
            for _ in range(N):
                mujoco.mj_step(model, data)
                update()
            observe()

    def timed(fn, *a) -> float:
        mujoco.mj_resetData(model, data)
        mujoco.mj_forward(model, data)
        for u in (ours, dm) if dm is not None else (ours,):
            u.reset(physics, np.random.RandomState(1))
        t0 = time.perf_counter()
        fn(*a)
        return (time.perf_counter() - t0) / k

    updaters = {"sensorcfg": ours, **({"dm_control": dm} if dm is not None else {})}
    for u in updaters.values():  # warm-up
        timed(with_updater, u)
    timed(physics_only)
    rows: dict[str, list[float]] = {"physics": [], **{name: [] for name in updaters}}
    for _ in range(args.repeats):
        p = timed(physics_only)
        rows["physics"].append(p)
        for name, u in updaters.items():
            rows[name].append(timed(with_updater, u) - p)
    med = {name: statistics.median(v) for name, v in rows.items()}
    print(f"humanoid, {N} physics steps per control step, {len(SUITE)} observables"
          f"{' (+2 noise stages each: gaussian, bias)' if args.noise else ''}; "
          f"medians of {args.repeats} repeats x {k} control steps; mujoco {mujoco.__version__}")
    print(f"{'per control step':<28}{'median (us)':>12}")
    for name, label in (("physics", "physics (5 x mj_step)"), ("dm_control", "dm_control Updater"),
                        ("sensorcfg", "sensorcfg Updater")):
        if name in med:
            print(f"{label:<28}{med[name] * 1e6:>12.1f}")
    print(f"sensorcfg / physics: {100 * med['sensorcfg'] / med['physics']:.1f}%  (goal: close to 10%)")
    if dm is not None:
        print(f"dm_control / sensorcfg cost ratio: {med['dm_control'] / med['sensorcfg']:.1f}x  (target >= 10x)")
        print(f"dm_control / physics: {100 * med['dm_control'] / med['physics']:.1f}%")


if __name__ == "__main__":
    main()
