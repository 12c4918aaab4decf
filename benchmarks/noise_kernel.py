"""The counter-based noise numbers (`sensorcfg.noise.streams`): nanoseconds per number, numpy's reference
against the compiled kernel with each Philox the CPU runs (AVX-512 or AVX2 intrinsics, the compiler's
portable loop), all in this process, on one thread, interleaved per round; medians.

Rows: normals and uniforms of one draw per sample size (`streams.numbers`), and the batch's read noise of the
humanoid benchmark at 512 simulations (`benchmarks/batch.py --noise`: two gaussian stages summed and added
into the gathered values, `streams.add_sums`, its 19,456 (simulation, slot) samples of 3-48 values), on one
thread and, last column, on two (the kernel splits work of 150,000 numbers and more).

    python benchmarks/noise_kernel.py [--repeats 9]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from sensorcfg import compiled
from sensorcfg.noise import streams
from sensorcfg.noise.streams import Affine, Draw, Sum

# the humanoid suite's read noise per control step at 512 simulations: (values per sample, samples)
READ = [(21, 5120), (48, 512), (4, 1536), (9, 1024), (3, 5120), (6, 3072), (12, 2560), (10, 512)]


def _draws(size: int, m: int, normal: bool, rng: np.random.Generator) -> list[Draw]:
    keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
    return [Draw(keys, rng.integers(0, 2**31, m), 1, 0, size, normal)]


def _read_jobs(rng: np.random.Generator) -> tuple[list[Sum], int]:
    total = sum(size * m for size, m in READ)
    values = rng.normal(size=total)
    jobs, at = [], 0
    for size, m in READ:
        keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
        samples = rng.integers(0, 2**31, m)
        draws = [Draw(keys, samples, s, 0, size, True) for s in (1, 2)]
        terms = [Affine(np.full(size, 0.01), None), Affine(np.full(size, 0.002), np.full(size, 0.001))]
        jobs.append(Sum(draws, terms, values, 0, at + np.arange(m) * size))
        at += m * size
    return jobs, 2 * total


def _time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    if compiled.MODULE is None:
        raise SystemExit("the compiled kernel is not built here (or SENSORCFG_NUMPY_STREAMS is set)")
    choose = getattr(compiled.MODULE, "simd", lambda name: name)  # a kernel before the intrinsics: "kernel"
    variants = []
    for name in ("avx512f", "avx2", "portable") if hasattr(compiled.MODULE, "simd") else ("kernel",):
        try:
            variants.append(choose(name))
        except ValueError:
            continue
    rng = np.random.default_rng(0)
    cases: list[tuple[str, Callable[[bool], object], int]] = []
    for size in (1, 3, 6, 21, 48):
        for normal in (True, False):
            m = 200_000 // size
            draws = _draws(size, m, normal, rng)
            cases.append((f"{'normals' if normal else 'uniforms'}, {size} per sample",
                          lambda kernel, d=draws: streams.numbers(d, compiled=kernel), m * size))
    jobs, count = _read_jobs(rng)
    cases.append(("read noise, 2 gaussian stages (humanoid, 512 sims)",
                  lambda kernel: streams.add_sums(jobs, compiled=kernel), count))
    split = compiled.SPLIT_VALUES
    print(f"ns per number, one thread (medians of 5 rounds of {args.repeats} runs, numpy {max(1, args.repeats // 3)}); "
          f"kernel Philox variants this CPU runs: {', '.join(variants)}")
    header = f"{'':52} {'numpy':>8} " + " ".join(f"{v:>9}" for v in variants) + f" {'numpy/' + variants[0]:>15} {'2 threads':>10}"
    print(header)
    for label, fn, n in cases:
        rows: dict[str, list[float]] = {}
        for _ in range(5):
            compiled.SPLIT_VALUES = 1 << 62
            rows.setdefault("numpy", []).append(_time(lambda: fn(False), max(1, args.repeats // 3)))
            for v in variants:
                choose(v)
                rows.setdefault(v, []).append(_time(lambda: fn(True), args.repeats))
            choose("fastest")
            compiled.SPLIT_VALUES = split
            rows.setdefault("two", []).append(_time(lambda: fn(True), args.repeats))
        ns = {k: 1e9 * statistics.median(v) / n for k, v in rows.items()}
        print(f"{label:52} {ns['numpy']:8.1f} " + " ".join(f"{ns[v]:9.2f}" for v in variants)
              + f" {ns['numpy'] / ns[variants[0]]:14.1f}x {ns['two']:10.2f}")
    choose("fastest")


if __name__ == "__main__":
    main()
