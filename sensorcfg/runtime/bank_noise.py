"""Noise for the feature bank: the same numbers as each sensor's own pipeline, applied in a few array ops.

A noise pipeline whose stages are additive noise (gaussian, uniform, outlier, bias), a random walk (a drift
that does not depend on the signal), a per-episode gain, quantisation or clipping can run inside the bank.
Every `chunk` steps (the planned bank: with each round, for the samples it takes) the bank asks each
sensor's own stages for the per-sample terms of that sensor's samples (counter-based: the same numbers the
per-sample path uses for those samples) and writes them into "noise fields" laid out like the bank's
history. A read then runs a program compiled with its layout (`read_program`): stage q of every pipeline
at once, in order, with the stages' own array arithmetic (`noise.arithmetic`), on views of the read's work
buffer where the values are contiguous; a term is added to every gathered value at once when the others'
noise fields hold -0.0 there (adding -0.0 changes no value). Sensors whose pipelines hold lowpass,
dropout or custom stages stay on the per-sample path.

Bit-identity with the per-sample pipeline is the contract (the tests compare both paths).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, cast

import numpy as np

from ..noise import arithmetic as ar
from ..noise import stages as rt
from ..noise.streams import KERNEL, Affine, Draw, Sum, add_sums, numbers

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline

__all__ = ["BankNoise", "Layer", "ReadOp", "ops_of", "program"]

Program = tuple[tuple[str, Any], ...]  # (kind, stage) pairs
ReadOp = Callable[[np.ndarray], None]  # op(the gathered values' history positions): in place, on its work buffer

# What the bank does with each runtime stage type: "term" stages add a per-sample row (white noise,
# outliers, their sums, a random walk's state: drawn a chunk ahead into a noise field); an episode draw
# adds or multiplies; quantize and clip are elementwise. A type missing here keeps its sensor per sample.
_KINDS: dict[type, Callable[[Any], str]] = {
    rt.Gaussian: lambda stage: "term",
    rt.Uniform: lambda stage: "term",
    rt.Outlier: lambda stage: "term",
    rt.Sum: lambda stage: "term",
    rt.RandomWalk: lambda stage: "term",
    rt.EpisodeDraw: lambda stage: "add" if stage.op is np.add else "mul",
    rt.Quantize: lambda stage: "quantize",
    rt.Clip: lambda stage: "clip",
}


def program(pipeline: NoisePipeline | None) -> Program | None:
    """The pipeline as (kind, stage) pairs the bank can run, () for no noise, None when it cannot."""
    if pipeline is None:
        return ()
    if np.dtype(pipeline.dtype) != np.float64:
        return None
    ops: list[tuple[str, Any]] = []
    for stage in pipeline.stages:
        kind = _KINDS.get(type(stage))
        if kind is None:
            return None
        ops.append((kind(stage), stage))
    return tuple(ops)


class _Sampled(Protocol):
    """What the bank's noise reads of a member: its value's shape, and its sample steps' stride."""

    @property
    def shape(self) -> tuple[int, ...]: ...
    @property
    def interval(self) -> int: ...


class BankNoise:
    """Noise fields and per-group programs for the noisy members of a bank."""

    def __init__(self, channels: Sequence[_Sampled], programs: list[Program], cols: np.ndarray,
                 rows: int, chunk: int, sample_offsets: list[np.ndarray]):
        self.width = int(cols[-1])
        self.rows, self.chunk, self.cols = rows, chunk, cols
        self.shapes = [ch.shape for ch in channels]
        self.strides = [ch.interval for ch in channels]  # sample j of member i is taken at step j * stride
        self.offsets = sample_offsets  # per member: its sample steps within one chunk, relative
        self.places, self.first, self.first_places = self._layout(sample_offsets)
        groups: dict[tuple[str, ...], list[int]] = {}
        for i, ops in enumerate(programs):
            if ops:
                groups.setdefault(tuple(kind for kind, _ in ops), []).append(i)
        self.programs = programs
        self.affines: dict[tuple[int, int], tuple[Any, list[Affine] | None]] = {}  # (member, term): (stage, affine)
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
                    per_op.append((self._full(members, q, lambda s: s.step, np.nan),))
                elif kind == "clip":
                    per_op.append((self._full(members, q, lambda s: s.low, -np.inf),
                                   self._full(members, q, lambda s: s.high, np.inf)))
                else:  # add / mul: this episode's draws, filled at `start`; term: a noise field
                    per_op.append((np.zeros(self.width),) if kind in ("add", "mul") else ())
            self.params.append(per_op)

    def _full(self, members: list[int], q: int, get: Any, missing: float) -> np.ndarray:
        full = np.full(self.width, missing)
        for i in members:
            value = get(self.programs[i][q][1])
            full[self.cols[i]:self.cols[i + 1]] = missing if value is None else np.broadcast_to(
                value, self.shapes[i]).ravel()
        return full

    # -- per episode and per chunk ----------------------------------------------------------------

    def start(self, fill: bool = True) -> None:
        """After the pipelines' reset: this episode's draws, and (with `fill`) the first chunk of noise."""
        for (signature, members), per_op in zip(self.groups, self.params):
            for q, kind in enumerate(signature):
                if kind in ("add", "mul"):
                    for i in members:
                        per_op[q][0][self.cols[i]:self.cols[i + 1]] = self.programs[i][q][1].value.ravel()
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
        return any(isinstance(stage, rt.RandomWalk) for _, stage in self.programs[i])

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
        every index (`rows_at`). Where the kernel is built, a term linear in its numbers (`affine`) is written
        by it straight into its field (`add_sums`, the same roundings as the stage's `shape`)."""
        jobs: list[tuple[Any, int, np.ndarray, int, int]] = []
        draws: list[Draw] = []
        sums: list[Sum] = []
        for i, steps, starts in items:
            indices = steps // self.strides[i]
            terms = [stage for kind, stage in self.programs[i] if kind == "term"]
            places = None  # every value's flat position, where some term needs them
            for j, stage in enumerate(terms):
                affine = self._affine(i, j, stage)
                if affine is None and places is None:
                    places = (starts[:, None] + np.arange(self.cols[i + 1] - self.cols[i])).ravel()
                if isinstance(stage, rt.RandomWalk):
                    self.flat_fields[j].put(places, stage.rows_at(indices))
                    continue
                drawn = stage.draws(indices, np.repeat(stage.streams.keys, len(indices), axis=0))
                if affine is not None:  # (a sample's values are contiguous in the field)
                    sums.append(Sum(drawn, affine, self.flat_fields[j], 0, starts))
                    continue
                jobs.append((stage, j, cast(np.ndarray, places), len(draws), len(drawn)))
                draws.extend(drawn)
        if sums:
            add_sums(sums, accumulate=False)
        if not draws:
            return
        raw = numbers(draws)
        for stage, j, places, at, count in jobs:
            self.flat_fields[j].put(places, stage.shape(raw[at:at + count], len(places) // stage.size))

    def _affine(self, i: int, j: int, stage: Any) -> list[Affine] | None:
        """Term j of member i as affine terms of its numbers, when the kernel writes it (cached per stage; a
        random walk's rows are its states, not its numbers)."""
        if KERNEL != "compiled" or isinstance(stage, rt.RandomWalk):
            return None
        cached = self.affines.get((i, j))
        if cached is None or cached[0] is not stage:
            cached = self.affines[(i, j)] = (stage, stage.affine())
        return cached[1]

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
