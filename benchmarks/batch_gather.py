"""A batched read's gather: every value a control step's reads need, taken from the batch's store.

Setting: dm_control's suite/humanoid.xml, the 20-observable suite of benchmarks/_humanoid.py, 5 physics
steps per control step, nsim simulations (`BatchEnvironment`). After each control step, each variant takes
the positions of that step's read (`Layout.gathers`), in rotating order, twice: right after a rollout of
every simulation (recording nothing: the caches then hold MuJoCo's memory, as when a read follows its
control step's physics), and again at once (warm caches):

  numpy      `flat.take(index, mode="clip")`, the reference
  kernel     `compiled.take`: the compiled gather, one thread, each value's line asked for ahead
  kernel x2  the compiled gather in two halves on two threads

Prints medians in ms and each against numpy (all three give the same bits; checked).

    MUJOCO_GL=egl python benchmarks/batch_gather.py [--nsim 512] [--repeats 4] [--control-steps 30]

Needs MuJoCo 4 (mujoco.batch) and the compiled kernel.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _humanoid import humanoid_xml, sensorcfg_observables  # noqa: E402

from sensorcfg import compiled  # noqa: E402
from sensorcfg.batch import BatchEnvironment  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nsim", type=int, default=512)
    parser.add_argument("--repeats", type=int, default=4)
    parser.add_argument("--control-steps", type=int, default=30)
    args = parser.parse_args()
    if compiled.MODULE is None:
        sys.exit("batch_gather.py compares the compiled gather with numpy's: the kernel is not built")
    xml, assets = humanoid_xml()
    source = mujoco.MjSpec.from_string(xml, assets)
    model = source.copy().compile()
    nsim = args.nsim
    env = BatchEnvironment(source, sensorcfg_observables(), nsim, physics_steps_per_control_step=5, seed=0)
    lo, hi = model.actuator_ctrlrange.T
    actions = np.random.default_rng(0).uniform(lo, hi, (args.control_steps, nsim, model.nu)) * 0.2
    updater, layout = env.updater, env.updater.layout
    pool = ThreadPoolExecutor(1)

    def halves(table: np.ndarray, index: np.ndarray) -> np.ndarray:
        out, n = np.empty(index.size), index.size
        other = pool.submit(compiled.MODULE.gather, table, index, out, n // 2, n)
        compiled.MODULE.gather(table, index, out, 0, n // 2)
        other.result()
        return out

    variants: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
        "numpy": lambda table, index: table.take(index, mode="clip"), "kernel": compiled.take, "kernel x2": halves}
    times: dict[tuple[str, str], list[float]] = {(v, c): [] for v in variants for c in ("after rollout", "warm")}
    names = list(variants)
    for _ in range(args.repeats):
        env.reset()
        for i, a in enumerate(actions):
            env.step(a)
            index = layout.gathers(updater.global_step % updater.rows, updater.age)
            reference = updater.flat.take(index, mode="clip")
            for name in names[i % 3:] + names[:i % 3]:
                env.batch.rollout(5, control=a[:, None, :], record=())  # not recorded: the store is unchanged
                for caches in ("after rollout", "warm"):
                    t0 = time.perf_counter()
                    got = variants[name](updater.flat, index)
                    times[(name, caches)].append(time.perf_counter() - t0)
                    assert np.array_equal(got.view(np.int64), reference.view(np.int64))
    print(f"humanoid suite, {nsim} simulations: {index.size:,} values a read from a store of "
          f"{updater.flat.nbytes / 1e6:.0f} MB; medians of {args.repeats} x {args.control_steps} reads, ms")
    print(f"{'':>10} {'after rollout':>14} {'vs numpy':>9} {'warm':>8} {'vs numpy':>9}")
    for name in names:
        cells = []
        for caches in ("after rollout", "warm"):
            ms = 1e3 * statistics.median(times[(name, caches)])
            cells.append(f"{ms:>{14 if caches != 'warm' else 8}.3f} "
                         f"{statistics.median(times[('numpy', caches)]) / statistics.median(times[(name, caches)]):>8.2f}x")
        print(f"{name:>10} {' '.join(cells)}")


if __name__ == "__main__":
    main()
