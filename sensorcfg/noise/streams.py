"""Counter-based random numbers: each sensor's noise streams for one episode (numpy, and the compiled kernel).

Per-sample numbers are a function of (episode key, sample index, stage, lane, value index) alone:
Philox4x32-10 (Salmon et al. 2011, as in Random123), written with numpy array arithmetic so that one call
produces the numbers of any set of samples, of any keys (sensors, simulations) at once, without the
numbers before them (random access). For value v of sample j of stage s, lane l (a stage with two kinds of
numbers, as an outlier's hits and jumps, uses lanes 0 and 1), with the sensor's 128-bit episode key
(k0, k1) (`draws.sensor_key`):

    counter = (j mod 2^32, s << 24 | l << 22 | v // 4, lo32(k1), hi32(k1)),  key = (lo32(k0), hi32(k0))

gives four 32-bit words w0..w3 for values 4(v // 4) .. 4(v // 4) + 3. A uniform is w 2^-32 (in [0, 1),
32 bits); a normal comes from its own word by Marsaglia and Tsang's ziggurat, a word it rejects (about 1 in
36) going on with words of its own (`_fallback`). The few exponentials and logarithms that takes are the C
library's (Python's `math`), not numpy's, whose vectorised ones differ from it in the last bit on some CPUs.

The compiled kernel (`sensorcfg/_kernel.c`'s `add`, loaded by `sensorcfg.compiled`) computes the same numbers
bit for bit, several times faster; numpy is the reference (tests/noise/test_streams.py compares the two) and the
path without a compiler. `KERNEL` says which one runs; SENSORCFG_NUMPY_STREAMS=1 forces numpy.
`add_sums` adds sums of such numbers, scaled and shifted, into rows of a table in place (the batch's
additive noise, added to the values a read gathered or into its history).

Planned schedules draw from the same numbers, under a schedule key (`plan/drawn.py`).

Per-episode draws (bias, scale, a random walk's start, a misalign's rotation, drawn parameters, a custom
stage's seed) come from numpy's Philox generator keyed by the same key (`Streams.at`), counter (0, purpose, 0,
stage): each is a `ResetDraw` record (the suite plan holds them, `plan.records.NoiseStep.episode`), drawn by
`draw_episode` alone, for every engine and the CPU stages.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from .. import compiled

__all__ = ["Affine", "Draw", "KERNEL", "Prepared", "ResetDraw", "Rows", "Streams", "Sum", "add_rows", "add_sums",
           "draw_episode", "kernel_lanes", "numbers", "philox", "prepare", "stream_key", "uniform_runs"]

_M0, _M1 = np.uint64(0xD2511F53), np.uint64(0xCD9E8D57)  # Philox4x32 multipliers
_W0, _W1 = np.uint32(0x9E3779B9), np.uint32(0xBB67AE85)  # its key schedule's increments
_ROUNDS = 10
_LOW, _HIGH = (0, 1) if sys.byteorder == "little" else (1, 0)  # 32-bit halves of a uint64, as a view
_TWO_PI_2_32 = 2.0 * np.pi * 2.0 ** -32
_2_32 = 2.0 ** -32
_MAX_LANE_VALUES = 1 << 22  # values per (sample, stage, lane): four per counter, 2^20 counters


def philox(counter: Sequence[np.ndarray], key: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Philox4x32-10 of n counters: four uint32 arrays of the counter words, two of the key words (each
    (n,) or broadcasting to it); returns the four output words, uint32 arrays (n,)."""
    x0, x1, x2, x3 = (np.array(c, np.uint32) for c in counter)
    k0 = np.array(key[0], np.uint32)
    k1 = np.array(key[1], np.uint32)
    n = x0.size
    # two pairs of products, used in turn: a round's x1 and x3 are halves of the previous round's
    products = [(np.empty(n, np.uint64), np.empty(n, np.uint64)) for _ in range(2)]
    spare = [np.empty(n, np.uint32), np.empty(n, np.uint32)]
    for r in range(_ROUNDS):
        if r:
            k0 += _W0
            k1 += _W1
        p0, p1 = products[r % 2]
        np.multiply(x0, _M0, out=p0)
        np.multiply(x2, _M1, out=p1)
        half0, half1 = p0.view(np.uint32), p1.view(np.uint32)
        # (x0, x1, x2, x3) <- (hi1 ^ x1 ^ k0, lo1, hi0 ^ x3 ^ k1, lo0)
        new0, new2 = spare
        np.bitwise_xor(half1[_HIGH::2], x1, out=new0)
        new0 ^= k0
        np.bitwise_xor(half0[_HIGH::2], x3, out=new2)
        new2 ^= k1
        spare = [x0, x2] if r else [np.empty(n, np.uint32), np.empty(n, np.uint32)]
        x0, x1, x2, x3 = new0, half1[_LOW::2], new2, half0[_LOW::2]
    x1, x3 = x1.copy(), x3.copy()
    return [x0, x1, x2, x3]


class Draw(NamedTuple):
    """The per-sample numbers of one stage and lane for m samples: `size` values each."""

    keys: npt.NDArray[np.uint64]  # (m, 2): each sample's episode key (its sensor's, its simulation's)
    samples: npt.NDArray[np.int64]  # (m,) sample indices
    stage: int
    lane: int
    size: int
    normal: bool  # standard normals, else uniforms in [0, 1)


def _counters(draws: Sequence[Draw]) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray]:
    """The counter and key words of every draw, concatenated (q = ceil(size / 4) counters per sample,
    draw after draw), and each draw's q."""
    q = np.array([-(-d.size // 4) for d in draws], np.int64)
    m = np.array([np.size(d.samples) for d in draws], np.int64)
    per_row = np.repeat(q, m)  # counters per sample row
    samples = np.concatenate([np.asarray(d.samples, np.int64).ravel() for d in draws])
    keys = np.concatenate([np.asarray(d.keys, np.uint64).reshape(-1, 2) for d in draws])
    # k0 lo, hi, k1 lo, hi
    halves = np.ascontiguousarray(keys).view(np.uint32).reshape(-1, 4)[:, [_LOW, _HIGH, 2 + _LOW, 2 + _HIGH]]
    tags = np.repeat(np.array([d.stage << 24 | d.lane << 22 for d in draws], np.uint32), m)
    start = np.cumsum(per_row) - per_row
    index = np.arange(int(per_row.sum()), dtype=np.int64) - np.repeat(start, per_row)  # v // 4 within a row
    counter = [np.repeat((samples & 0xFFFFFFFF).astype(np.uint32), per_row),
               np.repeat(tags, per_row) | index.astype(np.uint32)]
    words = np.repeat(halves, per_row, axis=0)
    return [*counter, words[:, 2], words[:, 3]], [words[:, 0], words[:, 1]], q


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Marsaglia and Tsang's (2000) 128-layer tables for 32-bit words: kn (uint32), wn, fn."""
    m1, dn, vn = 2147483648.0, 3.442619855899, 9.91256303526217e-3
    tn = dn
    kn, wn, fn = [0.0] * 128, [0.0] * 128, [0.0] * 128
    q = vn / math.exp(-0.5 * dn * dn)
    kn[0], kn[1] = (dn / q) * m1, 0.0
    wn[0], wn[127] = q / m1, dn / m1
    fn[0], fn[127] = 1.0, math.exp(-0.5 * dn * dn)
    for i in range(126, 0, -1):
        dn = math.sqrt(-2.0 * math.log(vn / dn + math.exp(-0.5 * dn * dn)))
        kn[i + 1] = (dn / tn) * m1
        tn = dn
        fn[i] = math.exp(-0.5 * dn * dn)
        wn[i] = dn / m1
    return np.array(kn, np.uint32), np.array(wn), np.array(fn)


_KN, _WN, _FN = _ziggurat_tables()
_R = 3.442620  # the start of the tail


def _kernel() -> Any:
    """The compiled kernel, given the ziggurat's tables; None where it was not built or is switched off."""
    if compiled.MODULE is not None:
        compiled.MODULE.tables(_KN, _WN, _FN)
    return compiled.MODULE


_COMPILED = _kernel()
KERNEL = compiled.KERNEL


def _libm(fn: Any, x: np.ndarray) -> np.ndarray:
    """fn (math.exp or math.log: the C library's) of each element of float64 array x."""
    return np.fromiter(map(fn, x.tolist()), np.float64, x.size)


def _normals(words: list[np.ndarray], counter: list[np.ndarray], key: list[np.ndarray]) -> np.ndarray:
    """Standard normals (n, 4) from the words by the ziggurat (one 32-bit word each). The few words it
    rejects (about 1 in 36) go on with words of their own (`_fallback`), so every value stays a function of
    its counter."""
    both = np.stack(words, axis=1)  # (n, 4): value 4q + k from word k of counter q
    hz = both.view(np.int32)
    iz = both & np.uint32(127)
    out = hz * _WN.take(iz)
    rejected = np.flatnonzero(np.abs(hz).view(np.uint32) >= _KN.take(iz))
    if rejected.size:
        row, col = rejected >> 2, rejected & 3
        out.ravel()[rejected] = _fallback(hz.ravel()[rejected].astype(np.int64), [c[row] for c in counter],
                                          [c[row] for c in key], col)
    return out


_ATTEMPTS = 2  # fallback attempts drawn per Philox call


def _fallback(hz: np.ndarray, counter: list[np.ndarray], key: list[np.ndarray], word: np.ndarray) -> np.ndarray:
    """Marsaglia and Tsang's `nfix` for rejected words `hz` (word `word` of their counter), vectorised.
    Attempt a of a value draws four words (wedge test, next word, two for the tail): Philox at its counter
    with lane 3 and the key's second word xor (1 + word + 16 a)."""
    out = np.empty(hz.size)
    todo = np.arange(hz.size)
    counter = [counter[0], counter[1] | np.uint32(3 << 22), counter[2], counter[3]]
    attempt = 0
    while todo.size:
        tries = np.arange(attempt, attempt + _ATTEMPTS, dtype=np.uint32)
        tweak = (1 + word[todo, None].astype(np.uint32) + 16 * tries).ravel()
        drawn = philox([np.repeat(c[todo], _ATTEMPTS) for c in counter],
                       [np.repeat(key[0][todo], _ATTEMPTS), np.repeat(key[1][todo], _ATTEMPTS) ^ tweak])
        drawn = [w.reshape(todo.size, _ATTEMPTS) for w in drawn]
        pending = np.arange(todo.size)  # rows of `todo` still rejected
        for a in range(_ATTEMPTS):
            rows = todo[pending]
            accepted, value, hz[rows] = _attempt(hz[rows], [w[pending, a] for w in drawn])
            out[rows[accepted]] = value[accepted]
            pending = pending[~accepted]
            if not pending.size:
                break
        todo, attempt = todo[pending], attempt + _ATTEMPTS
    return out


def _attempt(hz: np.ndarray, w: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One `nfix` step for words `hz` with four fresh words each: (accepted, value, the word to go on with)."""
    u = [(x + 0.5) * _2_32 for x in w]
    iz = hz & 127
    value = hz * _WN[iz]
    tail = iz == 0
    accepted = np.zeros(hz.size, bool)
    if tail.any():  # beyond the base layer: x from the exponential tail
        t = -_libm(math.log, u[2][tail]) / _R
        value[tail] = np.where(hz[tail] > 0, _R + t, -_R - t)
        accepted[tail] = -2.0 * _libm(math.log, u[3][tail]) >= t * t
    wedge = ~tail
    inside = np.zeros(hz.size, bool)
    w_iz, w_value = iz[wedge], value[wedge]
    inside[wedge] = _FN[w_iz] + u[0][wedge] * (_FN[w_iz - 1] - _FN[w_iz]) < _libm(math.exp, -0.5 * w_value * w_value)
    accepted |= inside
    # the others take the next word; accepted at once when it falls inside its layer
    again = wedge & ~inside
    nh = w[1][again].view(np.int32).astype(np.int64)
    niz = nh & 127
    fast = np.abs(nh) < _KN[niz]
    value[again] = nh * _WN[niz]
    accepted[again] = fast
    following = hz.copy()
    following[again] = nh
    return accepted, value, following


def numbers(draws: Sequence[Draw], compiled: bool = True) -> list[np.ndarray]:
    """Each draw's numbers, (m, size) float64: by the compiled kernel where it is built (and `compiled`),
    else from one numpy Philox call over all of them."""
    if not draws:
        return []
    if any(d.size > _MAX_LANE_VALUES or d.stage >= 256 or d.lane >= 3 for d in draws):
        raise ValueError(f"a noise stage draws at most {_MAX_LANE_VALUES} values per sample, from stages < 256")
    if compiled and _COMPILED is not None:
        out = [np.empty((np.size(d.samples), d.size)) for d in draws]
        _run([_Job([d], [None], out[i], 0, None) for i, d in enumerate(draws)], accumulate=False)
        return out
    counter, key, q = _counters(draws)
    words = philox(counter, key)
    normal = [d.normal for d in draws]
    values: dict[bool, np.ndarray] = {}
    if any(normal):
        values[True] = _normals(words, counter, key)
    if not all(normal):
        values[False] = np.stack(words, axis=1) * _2_32
    out, at = [], 0
    for d, per in zip(draws, q.tolist()):
        m = int(np.size(d.samples))
        out.append(values[d.normal][at:at + m * per].reshape(m, -1)[:, :d.size])
        at += m * per
    return out


def uniform_runs(keys: np.ndarray, first: np.ndarray, counts: np.ndarray, lane: int, compiled: bool = True
                 ) -> np.ndarray:
    """The uniform (value 0, stage 0, lane `lane`) of samples first[s] .. first[s] + counts[s] - 1 of key s
    (keys (m, 2)), run after run: `numbers` of one size-1 uniform draw, with a key per run instead of per
    sample (the planned schedules' draws)."""
    counts = np.ascontiguousarray(counts, np.int64)
    total = int(counts.sum())
    if not total:
        return np.zeros(0)
    starts = np.cumsum(counts) - counts
    samples = np.repeat(np.asarray(first, np.int64) - starts, counts) + np.arange(total)
    draw = Draw(np.repeat(np.asarray(keys, np.uint64).reshape(-1, 2), counts, axis=0), samples, 0, lane, 1, False)
    return numbers([draw], compiled=compiled)[0][:, 0]


MAX_TERMS = 8  # terms of one sum the kernel adds in one pass (`add_sums`); a longer sum is not fused


class Affine(NamedTuple):
    """A per-sample term linear in its draw's numbers x: x scale (+ offset), each (size,) float64."""

    scale: npt.NDArray[np.float64]
    offset: npt.NDArray[np.float64] | None


class Sum(NamedTuple):
    """Numbers of draws of the same samples (their keys, samples and size), each scaled and shifted, summed
    in order and added to table[rows[r], lo:lo + size] for sample r: `table` (n, width) float64, C-contiguous;
    or, `table` flat (n,), to table[rows[r] + lo:rows[r] + lo + size] (rows: where each sample's values start)."""

    draws: Sequence[Draw]
    terms: Sequence[Affine]
    table: np.ndarray
    lo: int
    rows: np.ndarray


def add_sums(jobs: Sequence[Sum], compiled: bool = True, accumulate: bool = True) -> None:
    """Each job's total added to its rows in place (written there, without `accumulate`), with numpy's
    roundings: per term x *= scale; x += offset, total = first term; total += each other; then row = row +
    total (the regions must not overlap). The compiled kernel does it in one pass per job, splitting many jobs
    between two threads."""
    if any(len(job.terms) > MAX_TERMS for job in jobs):
        raise ValueError(f"a sum adds at most {MAX_TERMS} terms in one pass")
    if not (compiled and _COMPILED is not None):
        raw = iter(numbers([d for job in jobs for d in job.draws], compiled=False))
        for job in jobs:
            total: np.ndarray | None = None
            for term in job.terms:
                x = next(raw)
                x *= term.scale
                if term.offset is not None:
                    x += term.offset
                if total is None:
                    total = x
                else:
                    total += x
            assert total is not None
            hi = job.lo + job.draws[0].size
            if job.table.ndim == 1:
                at = np.asarray(job.rows)[:, None] + np.arange(job.lo, hi)
                job.table[at] = job.table[at] + total if accumulate else total
            else:
                job.table[job.rows, job.lo:hi] = job.table[job.rows, job.lo:hi] + total if accumulate else total
        return
    _run([_Job(job.draws, job.terms, job.table, job.lo, np.ascontiguousarray(job.rows, np.int64)) for job in jobs],
         accumulate=accumulate)


class _Job(NamedTuple):
    draws: Sequence[Draw]
    terms: Sequence[Affine | None]
    out: np.ndarray
    lo: int
    rows: np.ndarray | None


def kernel_lanes(draws: Sequence[Draw], terms: Sequence[Affine | None]) -> list[tuple[Any, ...]]:
    """A sum's lanes as the kernel's `add` takes them: (counter tag, normal, scale, offset) per term."""
    return [(d.stage << 24 | d.lane << 22, d.normal, *(t if t is not None else (None, None)))
            for d, t in zip(draws, terms)]


def _run(jobs: list[_Job], accumulate: bool) -> None:
    """The kernel's `add` over the jobs, on two threads when there are many numbers (`compiled.split`)."""
    assert _COMPILED is not None
    kernel = _COMPILED.add
    calls: list[tuple[Any, ...]] = []
    work: list[int] = []
    total = sum(np.size(job.draws[0].samples) * job.draws[0].size * len(job.draws) for job in jobs)
    for draws, terms, out, lo, rows in jobs:
        first = draws[0]
        m = np.size(first.samples)
        if not first.size or not m:
            continue
        samples = np.ascontiguousarray(first.samples, np.int64).ravel()
        keys = first.keys
        if not (isinstance(keys, np.ndarray) and keys.shape == (m, 2) and keys.dtype == np.uint64
                and keys.flags.c_contiguous):
            keys = np.ascontiguousarray(np.broadcast_to(np.asarray(keys, np.uint64).reshape(-1, 2), (m, 2)))
        width = out.shape[-1] if out.ndim == 2 else 0
        _pieces(calls, work, total, keys, samples, first.size, kernel_lanes(draws, terms), out, width, lo, rows,
                accumulate)
    _split(kernel, calls, work)


_PIECES = 16  # a job larger than 1/_PIECES of a call's numbers is cut into runs of samples of about that size,
# so that the two threads (each taking the next piece) finish together


def _pieces(calls: list[tuple[Any, ...]], work: list[int], total: int, keys: np.ndarray, samples: np.ndarray,
            size: int, lanes: list[tuple[Any, ...]], out: np.ndarray, width: int, lo: int, rows: np.ndarray | None,
            accumulate: bool) -> None:
    """One job's calls of the kernel's `add`, cut into runs of samples when the whole call is split between
    two threads (`total` numbers); each call's numbers in `work`."""
    m = samples.size
    per_sample = size * len(lanes)
    pieces = min(m, max(1, -(-m * per_sample * _PIECES // total))) if total >= compiled.SPLIT_VALUES else 1
    for a, b in ((m * p // pieces, m * (p + 1) // pieces) for p in range(pieces)):
        if rows is None:  # the samples' own rows of `out`
            calls.append((keys[a:b], samples[a:b], size, lanes, out[a:b], width, lo, None, accumulate))
        else:
            calls.append((keys[a:b], samples[a:b], size, lanes, out, width, lo, rows[a:b], accumulate))
        work.append(int(b - a) * per_sample)


def _split(kernel: Any, calls: list[tuple[Any, ...]], work: list[int]) -> None:
    compiled.split(lambda i: kernel(*calls[i]), work)


class Prepared(NamedTuple):
    """A sum's fixed parts, made once (`prepare`): its draws (stage, lane, size, kind; their keys and samples
    unused), its terms, and both as the kernel's lanes."""

    draws: list[Draw]
    terms: list[Affine]
    lanes: list[tuple[Any, ...]]


def prepare(draws: Sequence[Draw], terms: Sequence[Affine]) -> Prepared:
    return Prepared(list(draws), list(terms), kernel_lanes(draws, terms))


class Rows(NamedTuple):
    """A prepared sum for samples `samples` (m,) int64 of keys `keys` ((m, 2) uint64, C-contiguous), added to a
    flat table from `starts` (m,) int64."""

    sum: Prepared
    keys: np.ndarray
    samples: np.ndarray
    starts: np.ndarray


def add_rows(rows: Sequence[Rows], out: np.ndarray, compiled: bool = True) -> None:
    """`add_sums` of prepared sums into the flat float64 table `out` (what a batch's read runs every control
    step): the kernel's calls straight from the prepared lanes, without building draws; numpy's `add_sums`
    where the kernel is not built (or not `compiled`)."""
    rows = [r for r in rows if r.samples.size and r.sum.draws[0].size]
    if not (compiled and _COMPILED is not None):
        add_sums([Sum([d._replace(keys=r.keys, samples=r.samples) for d in r.sum.draws], r.sum.terms, out, 0, r.starts)
                  for r in rows], compiled=False)
        return
    calls: list[tuple[Any, ...]] = []
    work: list[int] = []
    total = sum(r.samples.size * r.sum.draws[0].size * len(r.sum.lanes) for r in rows)
    for r in rows:
        _pieces(calls, work, total, r.keys, r.samples, r.sum.draws[0].size, r.sum.lanes, out, 0, 0, r.starts, True)
    _split(_COMPILED.add, calls, work)


class Streams:
    """A sensor's episode key and its per-episode generator: numpy's Philox keyed by that key, positioned
    at (stage, purpose) by `at` (one generator object, repositioned)."""

    __slots__ = ("key", "keys", "bitgen", "generator", "_state", "_counter")

    def __init__(self, key: np.ndarray):
        self.key = np.asarray(key, np.uint64)
        self.keys = self.key.reshape(1, 2)
        self.bitgen = np.random.Philox(key=self.key)
        self.generator = np.random.Generator(self.bitgen)
        self._counter = np.zeros(4, np.uint64)
        # a whole state, set at once (faster than reading the state back and editing it)
        self._state: Any = {"bit_generator": "Philox", "state": {"counter": self._counter, "key": self.key},
                            "buffer": np.zeros(4, np.uint64), "buffer_pos": 4, "has_uint32": 0, "uinteger": 0}

    def rekey(self, key: np.ndarray) -> None:
        """A new episode's key (the generator is kept)."""
        self.key = np.asarray(key, np.uint64)
        self.keys = self.key.reshape(1, 2)
        self._state["state"]["key"] = self.key

    def at(self, stage: int, block: int, purpose: int = 0, key: np.ndarray | None = None) -> np.random.Generator:
        """The generator positioned at the start of (stage, block, purpose) (of another key when given);
        `buffer_pos` 4: no buffered output, the next comes from the counter."""
        counter = self._counter
        counter[0], counter[1], counter[2], counter[3] = 0, purpose, block, stage
        self._state["state"]["key"] = self.key if key is None else key
        self.bitgen.state = self._state
        return self.generator


class ResetDraw(NamedTuple):
    """Numbers a stage draws at each reset: `scale.size` values of numpy's Philox generator keyed by the
    sensor's episode key at counter (0, `purpose`, 0, `stream`) (`Streams.at`): standard normals
    (`Generator.standard_normal`) when `normal`, else uniforms in [0, 1) (`Generator.random`, 53 bits), value
    i mapped to `offset[i] + scale[i] x` (`scale[i] x` when `offset` is None). Purpose 1: a stage's own
    values (a bias's or scale's, a random walk's start, a misalign's rotation vector); purpose 2: its
    parameters drawn per episode, in field order."""

    stream: int
    purpose: int
    normal: bool
    scale: npt.NDArray[np.float64]  # (values,)
    offset: npt.NDArray[np.float64] | None


def draw_episode(draw: ResetDraw, streams: Streams) -> npt.NDArray[np.float64]:
    """The values (scale.size,) float64 of `draw` for the episode key of `streams`: the one home of every
    number drawn at a reset (the CPU stages and every engine call it)."""
    rng = streams.at(draw.stream, 0, purpose=draw.purpose)
    x = rng.standard_normal(draw.scale.size) if draw.normal else rng.random(draw.scale.size)
    x *= draw.scale
    if draw.offset is not None:
        x += draw.offset
    return x


def stream_key(rng: np.random.Generator | np.random.RandomState) -> np.ndarray:
    """A sensor's 128-bit episode key: four 32-bit words from its stream."""
    if isinstance(rng, np.random.RandomState):
        words = rng.randint(0, 2**32, size=4, dtype=np.uint64)
    else:
        words = rng.integers(0, 2**32, size=4, dtype=np.uint64)
    return np.array([(words[0] << np.uint64(32)) | words[1], (words[2] << np.uint64(32)) | words[3]], np.uint64)
