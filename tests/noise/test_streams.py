"""The counter-based numbers (`sensorcfg.noise.streams`): Philox4x32-10 as published, random access,
normals and uniforms with the right distributions, and the compiled kernel equal to the numpy reference bit
for bit. The kernel is optional (built where a C compiler is present); where it is meant to be built (the
test sessions of noxfile.py set SENSORCFG_REQUIRE_KERNEL=1) a missing kernel fails instead of skipping."""

from __future__ import annotations

import importlib.util
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from sensorcfg import compiled
from sensorcfg.noise import streams
from sensorcfg.noise.streams import Draw, numbers, philox

from conftest import ROOT

PATHS = [pytest.param(False, id="numpy"), pytest.param(True, id="compiled")]


def _path(compiled: bool) -> bool:
    """Use the compiled kernel if asked (skip without it, or fail where it is required)."""
    if compiled and streams.KERNEL != "compiled":
        if os.environ.get("SENSORCFG_REQUIRE_KERNEL", "") not in ("", "0"):
            pytest.fail("the compiled kernel is not built (SENSORCFG_REQUIRE_KERNEL=1)", pytrace=False)
        pytest.skip("the compiled kernel is not built here")
    return compiled

# Random123's known-answer vectors for philox4x32-10: (counter, key, result)
KNOWN = [
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]


def test_philox_gives_the_published_answers_one_at_a_time_and_together():
    counters = [np.array([c[i] for c, _, _ in KNOWN], np.uint32) for i in range(4)]
    keys = [np.array([k[i] for _, k, _ in KNOWN], np.uint32) for i in range(2)]
    together = philox(counters, keys)
    for n, (counter, key, expected) in enumerate(KNOWN):
        alone = philox([np.array([w], np.uint32) for w in counter], [np.array([w], np.uint32) for w in key])
        assert [int(w[0]) for w in alone] == list(expected)
        assert [int(w[n]) for w in together] == list(expected)


KEYS = np.random.default_rng(5).integers(0, 2**63, (6, 2)).astype(np.uint64)


@pytest.mark.parametrize("normal", [True, False], ids=["normals", "uniforms"])
def test_a_samples_numbers_do_not_depend_on_what_else_is_drawn(normal):
    samples = np.arange(40)
    keys = np.repeat(KEYS, 40 // len(KEYS) + 1, axis=0)[:40]
    many = numbers([Draw(keys, samples, 2, 0, 7, normal), Draw(keys[:3], samples[:3], 5, 1, 3, not normal)])
    for j in (0, 13, 39):
        alone = numbers([Draw(keys[j:j + 1], samples[j:j + 1], 2, 0, 7, normal)])[0]
        assert np.array_equal(alone[0], many[0][j])
    # the first values of a sample are the same whatever its size (four values per counter)
    assert np.array_equal(numbers([Draw(keys, samples, 2, 0, 5, normal)])[0], many[0][:, :5])


def test_keys_stages_lanes_and_samples_give_different_numbers():
    base = Draw(KEYS[:1], np.array([3]), 1, 0, 8, True)
    first = numbers([base])[0]
    for other in (base._replace(keys=KEYS[1:2]), base._replace(stage=2), base._replace(lane=1),
                  base._replace(samples=np.array([4]))):
        assert not np.any(numbers([other])[0] == first)


@pytest.mark.parametrize("compiled", PATHS)
def test_normals_are_standard_normal_and_uniforms_uniform(compiled):
    n = 200_000
    keys = np.repeat(KEYS[:1], n // 20, axis=0)
    z, u = numbers([Draw(keys, np.arange(n // 20), 0, 0, 20, True), Draw(keys, np.arange(n // 20), 1, 0, 20, False)],
                   compiled=_path(compiled))
    z, u = z.ravel(), u.ravel()
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1) < 0.01
    for t in (1.0, 2.0, 3.0):  # tail frequencies, against 5 standard errors
        p = math.erfc(t / math.sqrt(2))
        assert abs(np.mean(np.abs(z) > t) - p) < 5 * math.sqrt(p * (1 - p) / n)
    zs = np.sort(z)[::50]
    cdf = 0.5 * np.array([math.erfc(-x / math.sqrt(2)) for x in zs])
    assert np.max(np.abs(cdf - (np.arange(zs.size) * 50 + 1) / n)) < 1.63 / math.sqrt(n)  # KS at 1%
    assert u.min() >= 0 and u.max() < 1 and abs(u.mean() - 0.5) < 0.005
    assert np.all(np.abs(np.histogram(u, 10, (0, 1))[0] - n / 10) < 5 * math.sqrt(n / 10))


def _philox_variants() -> list[str]:
    """The kernel's Philox implementations this CPU runs (intrinsics where it has AVX-512 or AVX2; the portable
    loop everywhere)."""
    found = []
    for name in ("avx512f", "avx2", "portable"):
        try:
            found.append(compiled.MODULE.simd(name))
        except ValueError:
            continue
    assert compiled.MODULE.simd("fastest") == compiled.PHILOX == found[0] and found[-1] == "portable"
    return found


def test_the_compiled_kernel_gives_the_numpy_numbers_bit_for_bit():
    """With each Philox the CPU runs (the intrinsics and the portable loop), as planned draws' runs too."""
    _path(True)
    rng = np.random.default_rng(11)
    draws = []
    for size, m in [(1, 3000), (3, 2000), (4, 1000), (5, 999), (21, 800), (63, 300), (64, 250), (257, 70),
                    (5000, 12)]:  # one counter to several blocks of counters per sample
        keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
        samples = rng.integers(0, 2**40, m)  # the counter takes the low 32 bits
        for normal in (True, False):
            draws.append(Draw(keys, samples, int(rng.integers(0, 256)), int(rng.integers(0, 3)), size, normal))
    reference = numbers(draws, compiled=False)
    first = np.arange(70) * 977
    counts = np.arange(70) % 9 * 11  # runs of 0 to 88 samples: partial vectors and several blocks
    runs = streams.uniform_runs(draws[0].keys[:70], first, counts, 1, compiled=False)
    variants = _philox_variants()
    try:
        for variant in variants:
            compiled.MODULE.simd(variant)
            for d, a, b in zip(draws, reference, numbers(draws, compiled=True)):
                assert a.shape == b.shape == (np.size(d.samples), d.size)
                assert np.array_equal(a.view(np.uint64), b.view(np.uint64)), (variant, d.size, d.normal)
            assert np.array_equal(streams.uniform_runs(draws[0].keys[:70], first, counts, 1, compiled=True), runs)
    finally:
        compiled.MODULE.simd("fastest")
    z = np.concatenate([a.ravel() for d, a in zip(draws, reference) if d.normal])
    # the fallback ran both ways: values beyond the ziggurat's base strip come only from its tail
    assert np.count_nonzero(np.abs(z) > 3.442620) > 0


def test_numpy_streams_can_be_forced_and_give_the_same_observations(tmp_path):
    """SENSORCFG_NUMPY_STREAMS=1 runs the reference in a fresh process; a noisy suite observes the same."""
    script = tmp_path / "run.py"
    script.write_text(
        "import sys, numpy as np, sensorcfg\n"
        "from sensorcfg import assets\n"
        "from sensorcfg.noise import streams\n"
        "suite = sensorcfg.load(sys.argv[1])\n"
        "env = sensorcfg.Environment(sensorcfg.assets.path('robot.xml'), suite, seed=3)\n"
        "out = [env.reset().observation]\n"
        "out += [env.step(np.zeros(env.action_spec().shape)).observation for _ in range(40)]\n"
        "np.savez(sys.argv[2], kernel=streams.KERNEL, **{f'{i}/{k}': v for i, o in enumerate(out) for k, v in o.items()})\n")
    suite = str(ROOT / "configs" / "sim2real.yaml")
    runs = {}
    for force in ("1", "0"):
        out = tmp_path / f"obs{force}.npz"
        subprocess.run([sys.executable, str(script), suite, str(out)], check=True,
                       env={**os.environ, "SENSORCFG_NUMPY_STREAMS": force})
        runs[force] = dict(np.load(out))
    assert str(runs["1"].pop("kernel")) == "numpy"
    # "0": the kernel wherever it is built, even when this process was itself forced onto numpy
    built = importlib.util.find_spec("sensorcfg._kernel") is not None
    assert str(runs["0"].pop("kernel")) == ("compiled" if built else "numpy")
    assert runs["1"].keys() == runs["0"].keys() and len(runs["1"]) > 40
    for key, value in runs["1"].items():
        assert np.array_equal(value, runs["0"][key]), key


def test_sums_added_in_place_equal_the_numpy_arithmetic_on_both_paths():
    """`add_sums` (the batch's gaussian and uniform stages, fused and added in place in its history): numbers
    x scale (+ offset), summed in order, added to table rows, with numpy's roundings; enough numbers that the
    compiled path splits the jobs between two threads."""
    rng = np.random.default_rng(3)
    shapes = [(1, 9000), (6, 5000), (21, 3000), (48, 700)]
    width = sum(size for size, _ in shapes) + 5
    table = rng.normal(size=(9000, width))
    jobs, lo = [], 2
    for size, m in shapes:
        keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
        samples = rng.integers(0, 2**32, m)
        rows = np.sort(rng.choice(9000, m, replace=False))
        draws = [Draw(keys, samples, 1, 0, size, True), Draw(keys, samples, 2, 0, size, False),
                 Draw(keys, samples, 3, 0, size, True)]
        terms = [streams.Affine(rng.normal(size=size), None), streams.Affine(rng.normal(size=size), rng.normal(size=size)),
                 streams.Affine(np.full(size, 0.5), np.zeros(size))]
        jobs.append((draws, terms, lo, rows))
        lo += size
    assert sum(m * size * 3 for size, m in shapes) > compiled.SPLIT_VALUES
    expected = table.copy()
    for draws, terms, lo, rows in jobs:
        raw = numbers(draws, compiled=False)
        total = raw[0] * terms[0].scale
        for x, term in zip(raw[1:], terms[1:]):
            total = total + (x * term.scale + term.offset)
        expected[rows, lo:lo + draws[0].size] = expected[rows, lo:lo + draws[0].size] + total
    for kernel in (False, _path(True)):
        got = table.copy()
        streams.add_sums([streams.Sum(draws, terms, got, lo, rows) for draws, terms, lo, rows in jobs], compiled=kernel)
        assert np.array_equal(expected.view(np.uint64), got.view(np.uint64))
        # a flat table (the batch's read values): rows are where each sample's values start
        flat = table.copy().ravel()
        streams.add_sums([streams.Sum(draws, terms, flat, lo, rows * width) for draws, terms, lo, rows in jobs],
                         compiled=kernel)
        assert np.array_equal(expected.ravel().view(np.uint64), flat.view(np.uint64))
    every = [d for draws, *_ in jobs for d in draws]  # numbers split between threads too
    for a, b in zip(numbers(every, compiled=False), numbers(every, compiled=True)):
        assert np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.mark.parametrize("kernel", PATHS)
def test_uniform_runs_are_the_numbers_of_size_one_uniform_draws(kernel):
    """`uniform_runs` (the planned schedules' draws: a key per run of samples) gives `numbers` of one size-1
    uniform draw with a key per sample, bit for bit, on both paths; empty runs give nothing."""
    rng = np.random.default_rng(21)
    m = 9
    keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
    first = rng.integers(0, 2**33, m)  # (the counter takes the low 32 bits)
    counts = rng.integers(0, 300, m)
    counts[[2, 5]] = 0
    for lane in (0, 1, 2):
        got = streams.uniform_runs(keys, first, counts, lane, compiled=_path(kernel))
        samples = np.concatenate([np.arange(f, f + c) for f, c in zip(first.tolist(), counts.tolist())])
        draw = Draw(np.repeat(keys, counts, axis=0), samples, 0, lane, 1, False)
        expected = numbers([draw], compiled=False)[0][:, 0]
        assert got.shape == expected.shape and np.array_equal(got.view(np.uint64), expected.view(np.uint64))
    assert streams.uniform_runs(keys, first, np.zeros(m, np.int64), 1, compiled=kernel).shape == (0,)


@pytest.mark.parametrize("kernel", PATHS)
def test_sums_written_replace_the_rows(kernel):
    """`add_sums(..., accumulate=False)` (the bank's noise fields): the total written over the rows' values,
    the same bits as the sum added to zeros would be, on both paths; other values are left alone."""
    rng = np.random.default_rng(8)
    m, size, width = 400, 3, 7
    keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
    samples = rng.integers(0, 2**32, m)
    draws = [Draw(keys, samples, 4, 0, size, True), Draw(keys, samples, 5, 1, size, False)]
    terms = [streams.Affine(rng.normal(size=size), None), streams.Affine(rng.normal(size=size), rng.normal(size=size))]
    starts = np.sort(rng.choice(1000, m, replace=False)) * width + 2
    flat = rng.normal(size=1000 * width)
    zeros = np.zeros_like(flat)
    streams.add_sums([streams.Sum(draws, terms, zeros, 0, starts)], compiled=False)
    written = flat.copy()
    streams.add_sums([streams.Sum(draws, terms, written, 0, starts)], compiled=_path(kernel), accumulate=False)
    at = (starts[:, None] + np.arange(size)).ravel()
    assert np.array_equal(written[at].view(np.uint64), zeros[at].view(np.uint64))
    rest = np.ones(flat.size, bool)
    rest[at] = False
    assert np.array_equal(written[rest], flat[rest])

def test_the_kernel_refuses_rows_outside_its_table():
    """A flat table's rows are where samples start: one whose values would run past the end is refused
    (as a row past a 2-D table's last), never written."""
    _path(True)
    keys, samples = np.zeros((2, 2), np.uint64), np.arange(2, dtype=np.int64)
    lanes = [(1 << 24, True, None, None)]
    table = np.zeros(10)
    compiled.MODULE.add(keys, samples, 3, lanes, table, 0, 0, np.array([0, 7]), True)  # values 7..9: the last
    assert np.count_nonzero(table) == 6
    big = 2**63 - 2  # a start or offset whose sum with the size overflows 64 bits must not wrap past the check
    for rows, width, lo in ((np.array([0, 8]), 0, 0), (np.array([-1, 0]), 0, 0), (np.array([0, 5]), 2, 0),
                            (np.array([0, big]), 0, 0), (np.array([0, 1]), 0, big), (np.array([0, 1]), 2, big)):
        before = table.copy()
        with pytest.raises(ValueError):
            compiled.MODULE.add(keys, samples, 2 if width else 3, lanes, table, width, lo, rows, True)
        assert np.array_equal(before, table)


def test_the_read_kernel_refuses_an_index_of_another_length():
    """A compiled read's gather fills its work buffer from the index: an index of another length is refused
    before anything runs (`runtime/read_kernel.py` records the buffer's length)."""
    _path(True)
    history, work = np.arange(5.0), np.zeros(3)
    program = np.array([[1, work.__array_interface__["data"][0], history.__array_interface__["data"][0], 5, 0, 3]],
                       np.int64).tobytes()
    for index in (np.array([0, 1], np.int64), np.array([0, 1, 2, 3], np.int64)):
        with pytest.raises(ValueError, match="not as long as"):
            compiled.MODULE.read(program, index)
        assert not work.any()
    compiled.MODULE.read(program, np.array([4, 0, 9], np.int64))  # positions past the end clip, as numpy's take
    assert work.tolist() == [4.0, 0.0, 4.0]


def test_prepared_rows_add_what_add_sums_adds():
    """`add_rows` (a batch read's sums, prepared once: keys, lanes and starts) adds into a flat table what
    `add_sums` adds from draws and terms, on numpy's path too, with enough numbers to split between threads."""
    _path(True)
    rng = np.random.default_rng(8)
    shapes = [(21, 4000), (3, 9000), (48, 600), (10, 500)]
    n = sum(size * m for size, m in shapes)
    table = rng.normal(size=n + 7)
    rows, sums, at = [], [], 3
    for size, m in shapes:
        keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
        samples = rng.integers(0, 2**32, m)
        starts = at + np.arange(m) * size
        draws = [Draw(keys, samples, 4, 0, size, True), Draw(keys, samples, 5, 1, size, False)]
        terms = [streams.Affine(rng.normal(size=size), None), streams.Affine(rng.normal(size=size), rng.normal(size=size))]
        rows.append(streams.Rows(streams.prepare(draws, terms), keys, samples, starts))
        sums.append(streams.Sum(draws, terms, None, 0, starts))
        at += m * size
    assert 2 * n > compiled.SPLIT_VALUES
    expected = table.copy()
    streams.add_sums([s._replace(table=expected) for s in sums], compiled=False)
    got = table.copy()
    streams.add_rows(rows, got)
    assert np.array_equal(expected.view(np.uint64), got.view(np.uint64)) and not np.array_equal(got, table)


def test_prepared_rows_without_the_kernel_are_add_sums_on_numpy():
    """`add_rows` where the kernel is not built (or not asked for): numpy's `add_sums` of the same draws."""
    rng = np.random.default_rng(9)
    table = rng.normal(size=400)
    keys = rng.integers(0, 2**64, (30, 2), dtype=np.uint64)
    samples = rng.integers(0, 2**32, 30)
    starts = np.arange(30) * 13
    draws = [Draw(keys, samples, 2, 0, 13, True), Draw(keys, samples, 3, 1, 13, False)]
    terms = [streams.Affine(rng.normal(size=13), None), streams.Affine(rng.normal(size=13), rng.normal(size=13))]
    expected, got = table.copy(), table.copy()
    streams.add_sums([streams.Sum(draws, terms, expected, 0, starts)], compiled=False)
    template = [d._replace(keys=np.zeros((0, 2), np.uint64), samples=np.zeros(0, np.int64)) for d in draws]
    streams.add_rows([streams.Rows(streams.prepare(template, terms), keys, samples, starts)], got, compiled=False)
    assert np.array_equal(expected.view(np.uint64), got.view(np.uint64)) and not np.array_equal(got, table)
