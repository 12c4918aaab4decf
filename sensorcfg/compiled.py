"""sensorcfg's optional compiled kernels (`_kernel.c`, built by setup.py where a C compiler is present).

Each kernel does what a few numpy calls do, bit for bit, faster: the counter-based noise numbers
(`noise/streams.py` holds the numpy reference and calls the kernel), and a batch's copies between its
recording and its history (`take`, `put`, each value's memory asked for ahead). `KERNEL` says which path runs;
SENSORCFG_NUMPY_STREAMS=1 forces numpy everywhere. Observations are the same either way.
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Any

import numpy as np

__all__ = ["KERNEL", "MODULE", "split", "take", "put"]


def _load() -> Any:
    if os.environ.get("SENSORCFG_NUMPY_STREAMS", "") not in ("", "0"):
        return None
    try:
        from . import _kernel  # type: ignore[attr-defined]
    except ImportError:
        return None
    return _kernel


MODULE: Any = _load()
KERNEL = "compiled" if MODULE is not None else "numpy"
# the noise kernel's Philox: AVX-512 or AVX2 intrinsics where the CPU has them (GCC on x86-64), else the
# portable loop; None without the kernel, or with a kernel built before there was a choice
PHILOX: str | None = getattr(MODULE, "simd", lambda name: None)("fastest") if MODULE is not None else None

_POOL: Any = None
_POOL_NAME = "sensorcfg-kernel"
_POOL_LOCK = threading.Lock()
_CPUS = os.cpu_count() or 1  # read once: each call reads /sys (7 us here), and split runs every control step
SPLIT_VALUES = 150_000  # below this much work, one thread: each call hands the GIL between the two
# threads, which costs more than the second core gives below this (the humanoid benchmark's noisy read at 128
# simulations runs faster on one thread, at 256 on two: `benchmarks/batch.py --noise`)


def split(run: Callable[[int], None], work: Sequence[int]) -> None:
    """run(i) for each index of `work` (their sizes), on two threads when it pays, each taking the next index
    until none is left, so that a slower thread (one just woken, its caches cold) takes fewer (the kernels
    release the GIL; each index's work must touch memory of its own)."""
    global _POOL
    n = len(work)
    if sum(work) < SPLIT_VALUES or _CPUS < 2 or threading.current_thread().name.startswith(_POOL_NAME):
        for i in range(n):  # (on the pool's own thread, a second job would wait for itself)
            run(i)
        return
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(1, thread_name_prefix=_POOL_NAME)
        pool = _POOL
    tickets, lock = itertools.count(), threading.Lock()

    def worker() -> None:
        while True:
            with lock:
                i = next(tickets)
            if i >= n:
                return
            run(i)

    other = pool.submit(worker)
    try:
        worker()
    except BaseException:
        wait([other])  # never raise while the other thread still writes; the caller's error is the one raised
        raise
    other.result()


def _forget_pool() -> None:
    """In a forked child: the parent's pool thread does not exist there (a job given to it would never run)."""
    global _POOL, _POOL_LOCK
    _POOL, _POOL_LOCK = None, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def take(table: np.ndarray, index: np.ndarray) -> np.ndarray:
    """`table.take(index, mode="clip")` of a float64 table and int64 positions, as a new float64 array."""
    if (MODULE is None or table.dtype != np.float64 or index.dtype != np.int64 or not table.flags.c_contiguous
            or not table.size):
        return table.take(index, mode="clip")
    index = np.ascontiguousarray(index)
    out = np.empty(index.shape)
    # One thread: the copy waits on memory, not on the core (its loads are asked for ahead), so a second
    # thread does not make it faster (`benchmarks/batch_gather.py` times both).
    MODULE.gather(table, index, out, 0, index.size)
    return out


def put(table: np.ndarray, index: np.ndarray, values: np.ndarray) -> None:
    """`table.put(index, values, mode="clip")` of a float64 table, int64 positions and as many values, in
    order (where positions repeat, the last value wins, as in numpy)."""
    if (MODULE is None or table.dtype != np.float64 or index.dtype != np.int64 or not table.flags.c_contiguous
            or values.dtype != np.float64 or values.size != index.size or not table.size):
        table.put(index, values, mode="clip")
        return
    MODULE.scatter(table, np.ascontiguousarray(index), np.ascontiguousarray(values), 0, index.size)
