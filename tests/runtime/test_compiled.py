"""The compiled kernels' copies (`sensorcfg.compiled.take` / `put`, a batch's recording <-> history) equal
numpy's `take` / `put` with mode="clip" bit for bit: positions past either end, repeated positions (the last
write wins), and arrays longer than the kernel's prefetch distance. Without the kernel they are numpy's
own calls; where it is meant to be built (SENSORCFG_REQUIRE_KERNEL=1) a missing kernel fails. `split`, which
shares the kernels' calls between two threads, runs each once and returns only when both threads are done."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest

from sensorcfg import compiled


@pytest.fixture(autouse=True)
def _kernel_present():
    if compiled.KERNEL != "compiled" and os.environ.get("SENSORCFG_REQUIRE_KERNEL", "") not in ("", "0"):
        pytest.fail("the compiled kernel is not built (SENSORCFG_REQUIRE_KERNEL=1)", pytrace=False)


@pytest.mark.parametrize("n", [7, 3 * compiled.SPLIT_VALUES])
def test_take_and_put_are_numpys_with_clip(n):
    rng = np.random.default_rng(n)
    table = rng.normal(size=max(n // 3, 5))
    table[0] = -0.0
    index = rng.integers(-3, table.size + 3, n)  # some past either end, many repeated
    assert np.array_equal(table.take(index, mode="clip").view(np.int64), compiled.take(table, index).view(np.int64))
    values = rng.normal(size=n)
    expected, got = table.copy(), table.copy()
    expected.put(index, values, mode="clip")
    compiled.put(got, index, values)
    assert np.array_equal(expected.view(np.int64), got.view(np.int64))


def test_other_dtypes_and_layouts_take_numpys_path():
    table = np.arange(12, dtype=np.int32)
    index = np.array([0, 11, 20])
    assert compiled.take(table, index).tolist() == [0, 11, 11]
    strided = np.arange(20.0)[::2]
    assert compiled.take(strided, np.array([1, 3])).tolist() == [2.0, 6.0]


def test_split_runs_every_index_once_and_waits_for_both_threads(monkeypatch):
    monkeypatch.setattr(compiled, "_CPUS", 2)
    seen, threads = [], set()

    both = threading.Barrier(2, timeout=10)

    def run(i):
        if i < 2:
            both.wait()  # the first two calls run at once: one on each thread
        time.sleep(0.001)  # the GIL is let go, as the kernels do
        seen.append(i)
        threads.add(threading.get_ident())

    compiled.split(run, [compiled.SPLIT_VALUES // 10] * 40)
    assert sorted(seen) == list(range(40)) and len(threads) == 2

    finished = []

    def failing(i):
        time.sleep(0.002)
        if i == 0:
            raise ValueError("index 0")
        finished.append(i)

    with pytest.raises(ValueError, match="index 0"):
        compiled.split(failing, [compiled.SPLIT_VALUES] * 6)
    assert sorted(finished) == [1, 2, 3, 4, 5]  # the other thread's indices ran to the end before the raise


def test_split_stays_on_one_thread_below_its_threshold(monkeypatch):
    monkeypatch.setattr(compiled, "_CPUS", 2)
    threads = set()
    compiled.split(lambda i: threads.add(threading.get_ident()), [10] * 8)
    assert threads == {threading.get_ident()}


def test_split_raises_the_callers_error_when_both_threads_fail(monkeypatch):
    monkeypatch.setattr(compiled, "_CPUS", 2)
    both = threading.Barrier(2, timeout=10)

    def failing(i):
        both.wait()
        raise ValueError(f"call {threading.current_thread().name}")

    with pytest.raises(ValueError, match="MainThread"):
        compiled.split(failing, [compiled.SPLIT_VALUES] * 2)


def test_split_from_the_pools_own_thread_does_not_wait_for_itself(monkeypatch):
    monkeypatch.setattr(compiled, "_CPUS", 2)
    inner = []

    def run(i):
        if threading.current_thread() is not threading.main_thread():
            compiled.split(inner.append, [compiled.SPLIT_VALUES] * 3)
        time.sleep(0.002)

    done = threading.Event()
    worker = threading.Thread(target=lambda: (compiled.split(run, [compiled.SPLIT_VALUES] * 4), done.set()), daemon=True)
    worker.start()
    assert done.wait(20), "split deadlocked"
    assert inner and sorted(inner) == sorted([0, 1, 2] * (len(inner) // 3))  # every nested split ran whole


@pytest.mark.skipif(not hasattr(os, "fork"), reason="os.fork is POSIX only")
def test_split_works_in_a_forked_child(monkeypatch):
    monkeypatch.setattr(compiled, "_CPUS", 2)
    compiled.split(lambda i: None, [compiled.SPLIT_VALUES] * 2)  # the parent's pool thread exists
    pid = os.fork()
    if pid == 0:  # the child: exits 0 only if split returns
        threading.Timer(10, lambda: os._exit(3)).start()
        seen = []
        compiled.split(seen.append, [compiled.SPLIT_VALUES] * 4)
        os._exit(0 if sorted(seen) == [0, 1, 2, 3] else 2)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
