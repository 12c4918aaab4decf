"""Noise for the feature bank: each sensor's noise program (`plan.noise`), applied in a few array ops.

A noise program whose steps are additive noise (gaussian, uniform, outlier, bias), a random walk (a drift
that does not depend on the signal), a per-episode gain, quantisation or clipping can run inside the bank.
Every `chunk` steps (the planned bank: with each round, for the samples it takes) the bank draws the
per-sample terms of each sensor's samples from the program alone (`plan.terms`: counter-based, the numbers
the per-sample path uses for those samples) and writes them into "noise fields" laid out like the bank's
history; what a program draws at a reset (a bias's or gain's values, a random walk's start) comes from the
sensor's episode key (`plan.noise.episode`). A read then runs a program compiled with its layout
(`read_program`): stage q of every sensor at once, in order, with the stages' array arithmetic
(`noise.arithmetic`), on views of the read's work buffer where the values are contiguous; a term is added
to every gathered value at once when the others' noise fields hold -0.0 there (adding -0.0 changes no
value). Sensors whose programs hold lowpass, dropout, misalign, custom stages, parameters drawn per episode
or a noise level stay on the per-sample path.

Bit-identity with the per-sample pipeline is the contract (the tests compare both paths).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Collection, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, Union, cast

import numpy as np

from ..noise import arithmetic as ar
from ..noise.base import block_samples
from ..noise.streams import KERNEL, Draw, Sum, add_sums, numbers
from ..plan import terms as tm
from ..plan.compile import noise_program
from ..plan.noise import episode
from ..plan.records import NoiseProgram, NoiseStep

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline
    from ..plan.drawn import Drawn
    from ..plan.schedule import Schedule

__all__ = ["BankNoise", "Layer", "ReadOp", "ops_of", "program"]

Op = Union[tm.Term, NoiseStep]  # a term's steps, or the step an elementwise op runs
Program = tuple[tuple[str, Op], ...]  # (kind, op) pairs
ReadOp = Callable[[np.ndarray], None]  # op(the gathered values' history positions): in place, on its work buffer

# What the bank does with each step of a program: a term (`plan.terms.terms`: white noise, outliers, their fused
# sums, a random walk's state) adds a per-sample row, drawn a chunk ahead into a noise field; and by stage type
# here, an episode draw adds or multiplies, quantize and clip are elementwise. Any other keeps its sensor per
# sample.
_KINDS: dict[str, str] = {  # (the steps that are terms: `plan.terms.terms`)
    "bias": "add",
    "scale": "mul",
    "quantize": "quantize",
    "clip": "clip",
}
# each pipeline's program, per (shape, schedule): built once per pipeline, which a suite's resets keep
_PROGRAMS: weakref.WeakKeyDictionary[Any, dict[Any, NoiseProgram | None]] = weakref.WeakKeyDictionary()


def program_of(noise: NoisePipeline | None, shape: tuple[int, ...],
               schedule: Schedule | Drawn) -> NoiseProgram | None:
    """A channel's noise program (`plan.compile.noise_program`), kept with its pipeline."""
    if noise is None:
        return None
    programs = _PROGRAMS.setdefault(noise, {})
    key = (shape, schedule)
    if key not in programs:
        programs[key] = noise_program(noise, shape, schedule)
    return programs[key]


def program(noise: NoiseProgram | None, size: int) -> Program | None:
    """A program as the (kind, op) pairs the bank can run, () for no noise, None when it cannot (`_KINDS`)."""
    if noise is None:
        return ()
    if noise.leveled:
        return None
    ops: list[tuple[str, Op]] = []
    for q, term in tm.terms(noise, size):
        step = noise.steps[q]
        kind = "term" if term is not None else _KINDS.get(step.stage)
        if kind is None or any(s.drawn for s in (term.steps if term is not None else (step,))):
            return None
        ops.append((kind, term if term is not None else step))
    return tuple(ops)


class _Sampled(Protocol):
    """What the bank's noise reads of a member: its value's shape, and its sample steps' stride."""

    @property
    def shape(self) -> tuple[int, ...]: ...
    @property
    def interval(self) -> int: ...


class _Walk:
    """A random walk term of one member in one episode: b_j = a b_(j-1) + c z_j over every sample index j, a
    block of indices at a time and in order (`noise.base.block_samples`), from the episode's start (the step's
    draw at reset; 0 for a Brownian walk, whose a is None)."""

    def __init__(self, term: tm.Term, key: np.ndarray, start: np.ndarray | None):
        step = term.steps[0]
        self.term, self.key = term, key[None]
        self.a = None if step.param("correlation_time") is None else step.number("a")
        self.c = step.number("c")
        self.block = block_samples(term.size)
        self.carry = np.zeros(term.size) if start is None else np.array(start, np.float64)
        self.last = -1  # the newest block walked
        self.block_id = -1
        self.rows = np.zeros((0, term.size))

    def _block_rows(self, block: int) -> np.ndarray:
        states = self.rows
        while self.last < block:  # every index is walked, whether or not its samples are taken
            self.last += 1
            samples = np.arange(self.last * self.block, (self.last + 1) * self.block)
            z = tm.values(self.term, numbers(tm.draws(self.term, samples, np.repeat(self.key, len(samples), 0))),
                          len(samples))
            states = ar.walk(self.carry, z, self.a, self.c, self.last == 0)
        return states

    def rows_at(self, indices: np.ndarray) -> np.ndarray:
        """The walk's states at sample indices `indices` (increasing), (len, size)."""
        first, last = int(indices[0]) // self.block, int(indices[-1]) // self.block
        blocks = []
        for block in range(first, last + 1):
            if block != self.block_id:
                if block <= self.last:
                    raise ValueError(f"the bank's random walk was asked for block {block} after {self.last}")
                self.rows = self._block_rows(block)
                self.block_id = block
            blocks.append(self.rows)
        stacked = blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
        rows: np.ndarray = stacked[indices - first * self.block]
        return rows


class BankNoise:
    """Noise fields and per-group programs for the noisy members of a bank."""

    def __init__(self, channels: Sequence[_Sampled], noises: Sequence[NoiseProgram | None], cols: np.ndarray,
                 rows: int, chunk: int, sample_offsets: list[np.ndarray]):
        """`noises`: each member's noise program (None: none); each one the bank can run (`program`)."""
        self.width = int(cols[-1])
        self.rows, self.chunk, self.cols = rows, chunk, cols
        self.shapes = [ch.shape for ch in channels]
        self.strides = [ch.interval for ch in channels]  # sample j of member i is taken at step j * stride
        self.offsets = sample_offsets  # per member: its sample steps within one chunk, relative
        self.places, self.first, self.first_places = self._layout(sample_offsets)
        self.noises = list(noises)
        programs = [program(noise, int(cols[i + 1] - cols[i])) for i, noise in enumerate(noises)]
        if any(ops is None for ops in programs):
            raise ValueError("a bank member's noise the bank cannot run (an internal error: `program` decides)")
        self.programs = cast(list[Program], programs)
        groups: dict[tuple[str, ...], list[int]] = {}
        for i, ops in enumerate(self.programs):
            if ops:
                groups.setdefault(tuple(kind for kind, _ in ops), []).append(i)
        self.affines = {(i, j): tm.affine(term) if KERNEL == "compiled" and term.steps[0].stage != "random_walk"
                        else None for i, ops in enumerate(self.programs)
                        for j, term in enumerate(op for kind, op in ops if kind == "term")
                        if isinstance(term, tm.Term)}
        self.groups = [(signature, members) for signature, members in groups.items()]
        self.nfields = max((sig.count("term") for sig, _ in self.groups), default=0)
        # -0.0 where nothing is drawn: adding it changes no value, so a read may add a whole field row
        self.fields = np.full((self.nfields, rows, self.width), -0.0)
        self.flat_fields = self.fields.reshape(self.nfields, rows * self.width)
        # per group and op position: full-width parameter vectors (constants now, episode draws at reset)
        self.params: list[list[Any]] = []
        for signature, members in self.groups:
            per_op: list[Any] = []
            for q, kind in enumerate(signature):
                if kind == "quantize":
                    per_op.append((self._full(members, q, "step"),))
                elif kind == "clip":
                    per_op.append((self._full(members, q, "low"), self._full(members, q, "high")))
                else:  # add / mul: this episode's draws, filled at `start`; term: a noise field
                    per_op.append((np.zeros(self.width),) if kind in ("add", "mul") else ())
            self.params.append(per_op)
        # this episode's: each member's key, its terms' bias values and random walks
        self.keys = [np.zeros((1, 2), np.uint64) for _ in self.programs]
        self.biases: dict[tuple[int, int], list[np.ndarray]] = {}
        self.walkers: dict[tuple[int, int], _Walk] = {}

    def _full(self, members: list[int], q: int, name: str) -> np.ndarray:
        """Kernel number `name` of op q of every member, at the members' columns (NaN elsewhere)."""
        full = np.full(self.width, np.nan)
        for i in members:
            full[self.cols[i]:self.cols[i + 1]] = cast(NoiseStep, self.programs[i][q][1]).number(name)
        return full

    # -- per episode and per chunk ----------------------------------------------------------------

    def start(self, keys: Sequence[np.ndarray], fill: bool = True) -> None:
        """Start an episode with each member's sensor key (`keys`): its draws at the reset (`plan.noise.episode`),
        and (with `fill`) the first chunk of noise."""
        self.biases.clear()
        self.walkers.clear()
        drawn = {}
        for i, (noise, ops) in enumerate(zip(self.noises, self.programs)):
            if not ops or noise is None:
                continue
            self.keys[i] = np.asarray(keys[i], np.uint64).reshape(1, 2)
            drawn[i] = episode(noise, self.keys[i][0])
            for j, term in enumerate(op for kind, op in ops if kind == "term"):
                term = cast(tm.Term, term)
                if term.steps[0].stage == "random_walk":
                    self.walkers[(i, j)] = _Walk(term, self.keys[i][0], drawn[i][term.first].values)
                else:
                    self.biases[(i, j)] = [cast(np.ndarray, drawn[i][s.stream].values) for s in term.steps
                                           if s.stage == "bias"]
        for (signature, members), per_op in zip(self.groups, self.params):
            for q, kind in enumerate(signature):
                if kind in ("add", "mul"):
                    for i in members:
                        step = cast(NoiseStep, self.programs[i][q][1])
                        per_op[q][0][self.cols[i]:self.cols[i + 1]] = drawn[i][step.stream].values
        if fill:
            self.fill(0)

    def _layout(self, sample_offsets: list[np.ndarray]) -> tuple[list[np.ndarray], ...]:
        """Per member: the flat positions (in a noise field, from a chunk's first row) of its values at its
        sample steps; the steps of an episode's first chunk (the reset sample first, when it is not among
        them) and their positions."""
        def places(i: int, offsets: np.ndarray) -> np.ndarray:
            at: np.ndarray = offsets * self.width + self.cols[i]
            return at

        first = [offsets if len(offsets) and offsets[0] == 0 else np.concatenate(([0], offsets)).astype(np.intp)
                 for offsets in sample_offsets]
        return ([places(i, o) for i, o in enumerate(sample_offsets)], first,
                [places(i, o) for i, o in enumerate(first)])

    def walks(self, i: int) -> bool:
        """Whether member i's noise has a random walk (its states are computed over every index, in order)."""
        return any(kind == "term" and cast(tm.Term, op).steps[0].stage == "random_walk"
                   for kind, op in self.programs[i])

    def fill(self, step: int, members: Collection[int] | None = None) -> None:
        """Write the per-sample terms of every noisy member's (of `members`) samples in steps [step, step +
        chunk). `step` is a multiple of the chunk, which divides the rows, so a chunk's rows do not wrap."""
        start = (step % self.rows) * self.width
        items = []
        for i, ops in enumerate(self.programs):
            if ops and (members is None or i in members):
                offsets, places = ((self.first[i], self.first_places[i]) if step == 0
                                   else (self.offsets[i], self.places[i]))
                items.append((i, step + offsets, places + start))
        self._write(items)

    def fill_samples(self, samples: list[tuple[int, np.ndarray]]) -> None:
        """Write the per-sample terms of the given samples: (member, its sample steps), wherever they lie in
        the rows (a member without a random walk: its walk needs its indices in order, a chunk at a time)."""
        self._write([(i, steps, (steps % self.rows) * self.width + self.cols[i]) for i, steps in samples])

    def _write(self, items: list[tuple[int, np.ndarray, np.ndarray]]) -> None:
        """(member, sample steps, where each sample's values start in a noise field (flat)): the numbers of
        those samples only, of every member, from one Philox call (`streams.numbers`); a random walk walks
        every index (`_Walk.rows_at`). Where the kernel is built, a term linear in its numbers (`plan.terms.affine`)
        is written by it straight into its field (`add_sums`, the same roundings as `plan.terms.values`)."""
        jobs: list[tuple[tm.Term, list[np.ndarray], int, np.ndarray, int, int]] = []
        draws: list[Draw] = []
        sums: list[Sum] = []
        for i, steps, starts in items:
            indices = steps // self.strides[i]
            terms = [cast(tm.Term, op) for kind, op in self.programs[i] if kind == "term"]
            places = None  # every value's flat position, where some term needs them
            for j, term in enumerate(terms):
                affine = self.affines[(i, j)]
                if affine is None and places is None:
                    places = (starts[:, None] + np.arange(self.cols[i + 1] - self.cols[i])).ravel()
                walk = self.walkers.get((i, j))
                if walk is not None:
                    self.flat_fields[j].put(places, walk.rows_at(indices))
                    continue
                drawn = tm.draws(term, indices, np.repeat(self.keys[i], len(indices), axis=0))
                if affine is not None:  # (a sample's values are contiguous in the field)
                    sums.append(Sum(drawn, affine, self.flat_fields[j], 0, starts))
                    continue
                jobs.append((term, self.biases.get((i, j), []), j, cast(np.ndarray, places), len(draws), len(drawn)))
                draws.extend(drawn)
        if sums:
            add_sums(sums, accumulate=False)
        if not jobs:  # (a term of biases alone draws nothing per sample, and is still written)
            return
        raw = numbers(draws)
        for term, biases, j, places, at, count in jobs:
            self.flat_fields[j].put(places, tm.values(term, raw[at:at + count], len(places) // term.size, biases))

    # -- reads ------------------------------------------------------------------------------------

    def read_layers(self, columns: np.ndarray) -> list[Layer]:
        """The noise of a read of bank columns `columns` (one per gathered value): stage q of every group at
        once, layer by layer (the groups' values are disjoint, and each value still goes through its own
        stages in order, so the bits are those of the per-sample pipeline)."""
        member = np.searchsorted(self.cols, columns, side="right") - 1
        layers: dict[tuple[int, str, int], list[tuple[np.ndarray, Any]]] = {}
        has_term = np.zeros((self.nfields, len(self.shapes)), bool)  # [j, member]: it has a j-th term
        for g, ((signature, members), per_op) in enumerate(zip(self.groups, self.params)):
            pos = np.flatnonzero(np.isin(member, members))
            j = 0
            for q, (kind, params) in enumerate(zip(signature, per_op)):
                key = j if kind == "term" else g if kind in ("add", "mul") else -1  # episode draws: per group
                layers.setdefault((q, kind, key), []).append((pos, params))
                if kind == "term":
                    has_term[j, members] = True
                    j += 1
        out = []
        for (_, kind, key), entries in sorted(layers.items(), key=lambda item: item[0][0]):
            pos = np.concatenate([p for p, _ in entries])
            order = np.argsort(pos)
            pos = pos[order]
            if not len(pos):
                continue
            if kind == "term":  # the other values' noise fields hold -0.0, which changes no value: add them too
                rest = np.ones(len(columns), bool)
                rest[pos] = False
                everywhere = not has_term[key, member[rest]].any()
                out.append(Layer(kind, np.arange(len(columns)) if everywhere else pos, self.flat_fields[key], ()))
                continue
            out.append(_elementwise_layer(kind, pos, order, entries, columns))
        return out

    def read_program(self, columns: np.ndarray, gathered: np.ndarray) -> list[ReadOp]:
        """`read_layers(columns)` as ops on a read's own work buffer `gathered`. Each op is `op(index)`,
        `index` being the read's history positions (a term is looked up there in its noise field)."""
        return ops_of(self.read_layers(columns), gathered)

    @staticmethod
    def apply(index: np.ndarray, program: list[ReadOp]) -> None:
        """Apply a read program to its work buffer's values, gathered from history positions `index`."""
        for op in program:
            op(index)


class Layer(NamedTuple):
    """One noise op of a read: `kind` ("term", "add", "mul", "quantize", "clip") at the gathered values'
    positions `pos` (sorted); `table`: a term's noise field (flat, looked up at the history positions) or an
    episode draw's full-width values; `args`: an episode draw's columns at `pos`, or the constants of
    quantize (step) and clip (low, high) at `pos`."""

    kind: str
    pos: np.ndarray
    table: np.ndarray | None
    args: tuple[np.ndarray, ...]


def _elementwise_layer(kind: str, pos: np.ndarray, order: np.ndarray, entries: list[tuple[np.ndarray, Any]],
                      columns: np.ndarray) -> Layer:
    """An episode draw's layer (its group's values, read at its columns) or quantize's and clip's (their
    constants at `pos`, gathered from each entry's (positions, parameters) in the order `order`)."""
    if kind in ("add", "mul"):
        return Layer(kind, pos, entries[0][1][0], (columns[pos],))
    args = tuple(np.concatenate([params[a].take(columns[p]) for p, params in entries])[order]
                 for a in range(len(entries[0][1])))
    return Layer(kind, pos, None, args)


def ops_of(layers: list[Layer], gathered: np.ndarray) -> list[ReadOp]:
    """The layers as numpy ops on `gathered`, the reference the compiled read (`read_kernel`) is held to."""
    ops = []
    for layer in layers:
        where = _where(layer.pos, len(gathered))
        if layer.kind == "term":
            ops.append(_term_op(cast(np.ndarray, layer.table), gathered, where))
            continue
        ops.append(_on(_elementwise(layer), gathered, where))
    return ops


def _where(pos: np.ndarray, n: int) -> slice | np.ndarray | None:
    """Positions as None (all n), a slice (contiguous: ops work on a view) or the index array."""
    if len(pos) == n:
        return None
    if pos[-1] - pos[0] + 1 == len(pos):
        return slice(int(pos[0]), int(pos[-1]) + 1)
    return pos


def _term_op(field: np.ndarray, g: np.ndarray, where: slice | np.ndarray | None) -> ReadOp:
    """Add the noise field's values at the read's history positions (at `where` of `g`)."""
    add = ar.add
    if where is None:
        return lambda index: add(g, field.take(index), g)
    if isinstance(where, slice):
        view, part = g[where], where
        return lambda index: add(view, field.take(index[part]), view)
    positions = where

    def scattered(index: np.ndarray) -> None:
        v = g.take(positions)
        add(v, field.take(index.take(positions)), v)
        g.put(positions, v)
    return scattered


def _elementwise(layer: Layer) -> Callable[[np.ndarray], None]:
    """An elementwise stage, in place: quantize and clip with their constants, an episode draw with this
    episode's values (filled at `start`) at its columns."""
    kind, args = layer.kind, layer.args
    if kind in ("add", "mul"):
        values, cols, arithmetic = cast(np.ndarray, layer.table), args[0], ar.add if kind == "add" else ar.multiply
        return lambda v: arithmetic(v, values.take(cols), v)
    if kind == "quantize":
        step, quantize = args[0], ar.quantize
        return lambda v: quantize(v, step, v)
    low, high, clip = args[0], args[1], ar.clip
    return lambda v: clip(v, low, high, v)


def _on(fn: Callable[[np.ndarray], None], g: np.ndarray, where: slice | np.ndarray | None) -> ReadOp:
    """`fn` on the values at `where` of `g` (a view when they are contiguous)."""
    if where is not None and not isinstance(where, slice):
        positions = where

        def scattered(index: np.ndarray) -> None:
            v = g.take(positions)
            fn(v)
            g.put(positions, v)
        return scattered
    view = g if where is None else g[where]
    return lambda index: fn(view)
