"""A feature bank's read of one phase (of the planned bank: any read, whose gathered rows change), compiled
onto a work buffer of its own: a fixed number of numpy calls.

`plan.layout.read_layout` says which history positions each read gathers and how they are cut and reduced.
Compiled, a read is: one `take` from the history into the work buffer, which also stacks the windows of
reductions of one family (`observables.aggregators.family`: sums, means and medians of one or two samples;
maxima; minima) side by side, each padded to the family's longest buffer with a value that changes no
result (`PADS`, kept after the history); one reduction per family (and per reduction that runs alone);
one division for the means; one copy of the values the observations show; one `itemgetter` cutting every
observation from that copy. The copy is the read's own: each observation is a fresh array, as
dm_control's are. With noise, the take gathers the windows only, noise is applied to them, and a second
take stacks them (with the pads, then kept in the work buffer).

Where the compiled kernel is built, `runtime/read_kernel.py` runs the same steps (gather, noise, take,
reductions, divisions) as one call; these numpy steps are its reference.

Work buffer, one row: [reduced values | plain windows | windows reduced alone | (with noise: the
families' windows, pads) | family blocks]; the copy takes the first two parts.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NamedTuple, cast

import numpy as np

from ..observables.aggregators import AGGREGATORS, FAMILIES, Family, family
from .bank_noise import Layer, ReadOp, ops_of

if TYPE_CHECKING:
    from ..plan.layout import GroupMember, PlainRead, ReadLayout, ReductionGroup

__all__ = ["PADS", "CompiledRead", "KernelRead", "Reduction", "Step", "compile_read", "cut", "finish"]

PADS = [f.pad for f in FAMILIES.values()]  # what the families' blocks are padded with

class KernelRead(NamedTuple):
    """`run(index)`: the whole read, from the gather of history positions `index` to the divisions; the same
    in two calls, `noised(index)` (the gather and the noise) then `reduced(index)` (the rest), for a read
    that writes padding between them; `arrays`: what the program points to (kept alive with it)."""

    run: Callable[[np.ndarray], None]
    arrays: tuple[np.ndarray, ...]
    nbytes: int  # of the program and the index arrays it made (the others are the bank's and the read's)
    noised: Callable[[np.ndarray], None]
    reduced: Callable[[np.ndarray], None]


class Reduction(NamedTuple):
    """`reduce(window, out)`: both views of the work buffer; `family`: the family's reduction ("sum", "max",
    "min"), or None for a reduction that runs alone."""

    reduce: Callable[..., np.ndarray]
    window: np.ndarray  # (buffer, width)
    out: np.ndarray  # (width,)
    family: str | None


class Step(NamedTuple):
    """One step of a read after its gather, on the work buffer: "take" (out = source.take(positions)), a
    `Reduction`'s family or "alone" (out = reduce(source)), "divide" (out /= source)."""

    kind: str
    out: np.ndarray
    source: np.ndarray
    positions: np.ndarray | None
    run: Callable[[], object]


class CompiledRead(NamedTuple):
    """One phase's read (see the module's doc)."""

    source: np.ndarray  # the history positions gathered, in the order of `gathered`
    gathered: np.ndarray  # the windows' part of the work buffer
    steps: list[Callable[[], object]]  # on the work buffer, in order: the families' take, reductions, divisions
    records: list[Step]  # the same steps, as records (`read_kernel` compiles them)
    shown: np.ndarray  # the part of the work buffer the observations show, (n,)
    cut: Callable[[np.ndarray], tuple[np.ndarray, ...]]  # a copy of `shown` -> every member's value
    reshapes: list[tuple[int, tuple[int, ...]]]  # members whose cut needs a reshape: (member, its shape)
    noise: list[ReadOp]  # the bank noise's read program for `source` ([] without noise)
    layers: list[Layer]  # the same program, as records
    kernel: KernelRead | None = None  # the whole read as one compiled call, where a bank made one


class _Group(NamedTuple):
    """A reduction group of the read layout: its window's positions in the layout's gather, and its family."""

    positions: np.ndarray  # (buffer, width)
    members: list[GroupMember]
    reduce: Callable[..., np.ndarray]
    family: tuple[Family, int] | None  # (family, divisor); None: reduced alone


class _Cuts:
    """Per member, the index into an (n,) copy that gives its value in one step where its shape allows
    ((1, k) and (k,) arrays, numpy scalars), else its (k,) span, reshaped (`reshapes`): views of the copy."""

    def __init__(self, members: int, plain: list[PlainRead], ordered: list[_Group], starts: np.ndarray):
        """Plain members' windows start at `starts`; reduced values lie first, in the groups' `ordered` order."""
        self.keys: list[int | slice | tuple[None, slice] | None] = [None] * members
        self.reshapes: list[tuple[int, tuple[int, ...]]] = []
        for p, start in zip(plain, starts):
            self.place(p.member, int(start), p.shape, scalar=False)
        at = 0
        for g in ordered:
            for m in g.members:
                self.place(m.member, at + m.columns.start, m.shape, scalar=True)
            at += g.positions.shape[1]

    def place(self, i: int, start: int, shape: tuple[int, ...], scalar: bool) -> None:
        span = slice(start, start + math.prod(shape))
        if not shape and scalar:  # numpy reductions of scalar samples give numpy scalars (dm_control's type)
            self.keys[i] = start
        elif len(shape) == 2 and shape[0] == 1:
            self.keys[i] = (None, span)
        else:
            self.keys[i] = span
            if len(shape) != 1:
                self.reshapes.append((i, shape))

    def getter(self) -> Callable[[np.ndarray], tuple[np.ndarray, ...]]:
        if len(self.keys) == 1:
            key = self.keys[0]
            return lambda values: (values[key],)
        return operator.itemgetter(*self.keys)


def compile_read(channels: Sequence[object], layout: ReadLayout,
                 noise_layers: Callable[[np.ndarray], list[Layer]] | None, pads_at: int | None) -> CompiledRead:
    """`channels`: the members, one output each; `layout`: `read_layout(...)` of one phase; `noise_layers(source)`:
    the bank noise's read layers for the values gathered from `source` (None without noise);
    `pads_at`: where the history's source holds the families' pads (`PADS`): the gather fills the families'
    blocks too; or None: noise applies to the gathered windows first, and a second take stacks them."""
    index, groups, plain = layout
    families, alone = _families(groups)
    stacked_groups = [g for members in families.values() for g in members]
    ordered = stacked_groups + alone  # as their reduced values lie
    nreduced = sum(g.positions.shape[1] for g in ordered)
    # the windows gathered: plain, reduced alone, and the families' unless the gather stacks them itself
    windows = _windows(plain, alone + (stacked_groups if pads_at is None else []))
    order = np.concatenate([*windows, np.zeros(0, np.intp)]).astype(np.intp)
    starts = nreduced + np.cumsum([0] + [len(w) for w in windows])  # each window's start in the work row
    work = np.empty((1, int(starts[-1]) + (0 if pads_at is not None else len(PADS)) + _block_values(families)))
    stacked = _stacker(work[0], index, order, int(starts[-1]), pads_at)
    for gs in families.values():
        stacked.add(gs)
    for g, start in zip(alone, starts[len(plain):]):
        stacked.alone(g, int(start))
    source = index[order]
    if pads_at is not None:  # the gather fills the blocks too
        source = np.concatenate([source, *stacked.index])
    records = _steps(work[0], nreduced, stacked, pads_at is None)
    cuts = _Cuts(len(channels), plain, ordered, starts)
    gathered = work[0, nreduced:nreduced + len(source)]
    layers = noise_layers(source) if noise_layers else []
    shown = work[0, :int(starts[len(plain)])]
    return CompiledRead(source, gathered, [step.run for step in records], records, shown, cuts.getter(),
                        cuts.reshapes, ops_of(layers, gathered), layers)


def finish(read: CompiledRead) -> Sequence[np.ndarray]:
    """After the windows are gathered (and their noise applied): stack, reduce, copy and cut every member's
    observation (fresh arrays: views of this read's own copy)."""
    for step in read.steps:
        step()
    return cut(read)


def cut(read: CompiledRead) -> Sequence[np.ndarray]:
    """Every member's observation from the work buffer's reduced values and plain windows: fresh arrays
    (views of this read's own copy, reshaped where the cut does not give a member's shape)."""
    values = read.cut(read.shown.copy())
    if not read.reshapes:
        return values
    cut = list(values)
    for i, shape in read.reshapes:
        cut[i] = cut[i].reshape(shape)  # a contiguous span of the copy: a view of it
    return cut


def _steps(row: np.ndarray, nreduced: int, stacked: _Stacked, stack: bool) -> list[Step]:
    """A read's work after its gather, on the work buffer `row`, each with its zero-argument call: (with
    `stack`) a take stacking the gathered windows and pads into the families' blocks, the reductions, the
    means' divisions."""
    steps: list[Step] = []
    if stack and stacked.index:
        source, index, out = row[nreduced:stacked.first_block], np.concatenate(stacked.index), row[
            stacked.first_block:stacked.block_at]
        steps.append(Step("take", out, source, index, functools.partial(source.take, index, None, out, "clip")))
    steps += [Step(r.family or "alone", r.out, r.window, None, functools.partial(r.reduce, r.window, r.out))
              for r in stacked.reductions]
    steps += [Step("divide", out, counts, None, functools.partial(np.true_divide, out, counts, out))
              for out, counts in stacked.divisions]
    return steps


def _windows(plain: list[PlainRead], groups: list[_Group]) -> list[np.ndarray]:
    """Read-layout positions of each window, in the order the work row holds them."""
    return [np.arange(p.part.start, p.part.stop) for p in plain] + [g.positions.ravel() for g in groups]


def _block_values(families: dict[str, list[_Group]]) -> int:
    """Values in the families' blocks: per family, its longest buffer times its width."""
    return sum(max(g.positions.shape[0] for g in gs) * sum(g.positions.shape[1] for g in gs)
               for gs in families.values())


def _stacker(row: np.ndarray, index: np.ndarray, order: np.ndarray, end: int, pads_at: int | None) -> _Stacked:
    """Blocks after the windows (which end at `end`) that a take fills from the history (`pads_at` given)
    or from the gathered windows followed by the pads (stored there)."""
    if pads_at is not None:
        return _Stacked(row, end, index, pads_at)
    where = np.empty(len(index), np.intp)  # a read-layout position -> its place among the gathered values
    where[order] = np.arange(len(order))
    row[end:end + len(PADS)] = PADS
    return _Stacked(row, end + len(PADS), where, len(order))


def _families(groups: list[ReductionGroup]) -> tuple[dict[str, list[_Group]], list[_Group]]:
    """The read layout's reduction groups by family (`observables.aggregators.family`), and those reduced alone."""
    families: dict[str, list[_Group]] = {}
    alone = []
    for g in groups:
        found = family(g.aggregator, *g.block)
        group = _Group(g.part.reshape(g.block), g.members, g.reduce, found)
        if found is None:
            alone.append(group)
        else:
            families.setdefault(found[0].reduce, []).append(group)
    return families, alone


class _Stacked:
    """The families' blocks in the work buffer, from `first_block` on: where each block value comes from in
    the source of the take that fills them (`lookup`: a read-layout position -> its place there; the pads
    from `pad_at`), and each family's reduction into its reduced values."""

    def __init__(self, row: np.ndarray, first_block: int, lookup: np.ndarray, pad_at: int):
        self.row, self.lookup, self.pad_at = row, lookup, pad_at
        self.first_block = self.block_at = first_block
        self.at = 0  # the next reduced value
        self.index: list[np.ndarray] = []
        self.reductions: list[Reduction] = []
        self.divisions: list[tuple[np.ndarray, np.ndarray]] = []

    def add(self, groups: list[_Group]) -> None:
        """One family: its groups' windows side by side, each padded to the longest."""
        fam = cast("tuple[Family, int]", groups[0].family)[0]
        buffer = max(g.positions.shape[0] for g in groups)
        width = sum(g.positions.shape[1] for g in groups)
        source = np.full((buffer, width), self.pad_at + PADS.index(fam.pad), np.intp)
        counts = np.empty(width)
        col = 0
        for g in groups:
            b, w = g.positions.shape
            source[:b, col:col + w] = self.lookup[g.positions]
            counts[col:col + w] = cast("tuple[Family, int]", g.family)[1]
            col += w
        block = self.row[self.block_at:self.block_at + source.size].reshape(source.shape)
        out = self.row[self.at:self.at + width]
        self.reductions.append(Reduction(AGGREGATORS[fam.reduce].reduce, block, out, fam.reduce))
        if (counts != 1).any():
            self.divisions.append((out, counts))
        self.index.append(source.ravel())
        self.block_at += source.size
        self.at += width

    def alone(self, group: _Group, start: int) -> None:
        """A group reduced on its own, from its window at `start` in the work row."""
        buffer, width = group.positions.shape
        window = self.row[start:start + buffer * width].reshape(buffer, width)
        self.reductions.append(Reduction(group.reduce, window, self.row[self.at:self.at + width], None))
        self.at += width
