"""Where a batch should add additive noise: as it reads, or in its history. The rule's measurement.

`batch/read_noise.py` adds a fixed-schedule sensor's gaussian and uniform noise as the batch reads when reads
show each sample at most `_MAX_READS_PER_SAMPLE` times on average; otherwise the sample is corrupted once in
the history. This script times both paths side by side in one process: two BatchEnvironments of the same
suite, one forced onto each path, their updater's `update` and `get_observation` alternating over the same
recorded control steps (physics is not timed: it is the same for both). Suites: the humanoid's
20-observable suite of benchmarks/_humanoid.py (mixed intervals: each sample read once), and the same
sensors all at the control rate (interval 5 = the substeps) with buffer k, whose reads show each sample k
times; two gaussian stages per sensor. Prints medians per control step and history / read (above 1: reading
is cheaper).

    MUJOCO_GL=egl python benchmarks/batch_noise_paths.py [--nsim 512] [--buffers 1 2 3] [--control-steps 40]

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
from batch import noisy  # noqa: E402

from sensorcfg.batch import BatchEnvironment  # noqa: E402
from sensorcfg.batch import read_noise  # noqa: E402


def measure(model: mujoco.MjModel, suite: dict, nsim: int, steps: int) -> dict[str, float]:
    envs = {}
    for path, limit in (("read", float("inf")), ("history", -1.0)):
        read_noise._MAX_READS_PER_SAMPLE = limit  # force the path for this environment's sensors
        envs[path] = BatchEnvironment(model, noisy(sensorcfg_observables(suite), model), nsim,
                                      physics_steps_per_control_step=5, seed=0)
        envs[path].reset()
    spec = envs["read"].action_spec()
    actions = np.random.default_rng(0).uniform(np.maximum(spec.minimum, -1), np.minimum(spec.maximum, 1),
                                               (steps, nsim, model.nu))
    times: dict[str, list[float]] = {path: [] for path in envs}
    everyone = np.ones(nsim, bool)
    for action in actions:
        envs["read"].step(action)  # one recording both updaters read (the same fields)
        for path, env in envs.items():
            updater = env.updater
            start = time.perf_counter()
            updater.update(everyone)
            updater.get_observation()
            times[path].append(time.perf_counter() - start)
    return {path: statistics.median(t[5:]) for path, t in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nsim", type=int, default=512)
    parser.add_argument("--buffers", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--control-steps", type=int, default=40)
    args = parser.parse_args()
    xml, assets = humanoid_xml()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    suites = {"humanoid suite (each sample read once)": SUITE}
    for k in args.buffers:
        suites[f"control rate, buffer {k} (read {k} times)"] = {
            name: (kind, etype, names, 5, 0, k, None) for name, (kind, etype, names, *_) in SUITE.items()}
    print(f"{args.nsim} simulations, two gaussian stages per sensor, update + read per control step (medians)")
    print(f"{'suite':<42} {'read':>9} {'history':>9} {'history / read':>15}")
    for label, suite in suites.items():
        t = measure(model, suite, args.nsim, args.control_steps)
        print(f"{label:<42} {t['read'] * 1e3:>7.2f}ms {t['history'] * 1e3:>7.2f}ms {t['history'] / t['read']:>15.2f}")


if __name__ == "__main__":
    main()
