"""Where a batch's values live, and which positions each copy and each read gathers. Numpy only.

One flat float64 store holds the history, then the records of the current control step, then the reset
values. The history has one row per global physics step modulo `rows`, then a row of reset samples and a
row of zeros; a row is (nsim, width), one column per observed value. Global rows make the copy of a
control step the same for every simulation whatever its episode's age; a read shifts the plan's periodic
read table (`plan.layout.read_layout`, compiled into `ReadTable`) by that age, per simulation.

A read takes the noise-free samples of its own control step straight from the records, so the history
keeps only the samples that a later read needs (and every sample of sensors whose noise is applied
there, `noisy`, and of drawn-schedule sensors). A control step is one `rollout` recording the fields the
suite reads, or with cameras one per run of substeps up to a substep at which a camera may render
(`segments`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..cache import DEFAULT_BUDGET, BoundedCache
from ..plan import Source, SuitePlan
from ..plan.layout import GroupMember, PlainRead, ReductionGroup

__all__ = ["Layout", "Segment", "Source"]  # Source: the plan's, re-exported


class Segment(NamedTuple):
    """A run of substeps `first..last` (1-based) recorded by one `rollout`, and the fields it records."""

    first: int
    last: int
    fields: tuple[str, ...]


class Layout:
    """Columns, store and gather positions for the sensors of a plan (fixed-schedule ones first) of nsim
    simulations."""

    def __init__(self, plan: SuitePlan, noisy: set[int], fields: dict[str, tuple[int, ...]],
                 stops: set[int] | frozenset[int] = frozenset()):
        """`plan`: the suite plan of the batch's features (fixed-schedule ones first); `noisy`: the sensors whose
        noise the batch applies in the history; `stops`: substeps after which a rollout must return (cameras
        render there)."""
        self.plan = plan
        self.nfixed, self.nsim, self.substeps = plan.nfixed, plan.nsim, plan.substeps
        self.sources = [sensor.source for sensor in plan.sensors]
        self.fixed = bool(plan.nfixed)  # some sensor has a fixed schedule: the read table is used
        self.cols = np.array([0, *(sensor.columns[1] for sensor in plan.sensors)], np.intp)
        self.width = plan.width
        self.rows = plan.rows  # a multiple of every period, longer than any wait
        # Reads repeat every `cycle` steps (relative to the read's own row): tables are kept per phase of it,
        # so their size does not grow with the history's length (buffer and delay).
        self.cycle = plan.reads.cycle
        self.nphase = plan.reads.nphase
        # Columns read only from the history: noisy ones (corrupted there, at their samples) and those of
        # drawn-schedule sensors, which keep every substep (when they sample is per simulation).
        self.history_only = np.zeros(self.width, bool)
        self.always = np.zeros(self.width, bool)
        for c in range(len(plan.sensors)):
            if c in noisy or c >= self.nfixed:
                self.history_only[self.cols[c]:self.cols[c + 1]] = True
            if c >= self.nfixed:
                self.always[self.cols[c]:self.cols[c + 1]] = True
        self._reads(noisy)
        self._segments(fields, stops)
        self._store(fields)
        self._sources()
        # positions kept per global step: within a budget of the history's size (at least the default)
        budget = max(DEFAULT_BUDGET, self.history.nbytes)
        self._cache = BoundedCache(budget)
        self._tables = BoundedCache(budget)
        self._uniform = BoundedCache(budget)

    def _segments(self, fields: dict[str, tuple[int, ...]], stops: set[int] | frozenset[int]) -> None:
        """Runs of substeps needing the same fields (at any phase), cut also after each stop."""
        substeps = self.substeps
        per_step = self._fields_per_substep(fields)
        # One rollout per run of substeps between stops, recording the fields any of them needs: an extra
        # call costs about as much as recording every field at every substep, so runs are cut only where a
        # camera renders.
        segments: list[tuple[int, int, set[str]]] = []  # (first, last substep, fields), 1-based
        for k in range(1, substeps + 1):
            if segments and k - 1 not in stops:
                first, _, merged = segments[-1]
                segments[-1] = (first, k, merged | per_step[k - 1])
            else:
                segments.append((k, k, set(per_step[k - 1])))
        self.segments = [Segment(a, b, tuple(f for f in fields if f in fs)) for a, b, fs in segments]
        # A field needed only at its segment's last substep is not recorded but bound (`Batch.bind`: the
        # batch copies it out once, after the call) and copied into a one-substep record slot: a fifth of
        # the bytes when five substeps would record it.
        self.bound = [tuple(f for f in fs if b > a and all(f not in per_step[k - 1] for k in range(a, b)))
                      for a, b, fs in self.segments]

    def _fields_per_substep(self, fields: dict[str, tuple[int, ...]]) -> list[set[str]]:
        """Per substep, the fields some read takes or the history keeps (at any phase)."""
        needed = np.zeros((self.substeps, self.width), bool)  # substep, column
        needed[:] = self.always
        needed |= self.later.any(axis=0)
        if self.fixed:
            for q in range(self.nphase):
                recent = self.from_record[q]
                needed[self.substep[q][recent] - 1, self.col[recent]] = True
        owner = {f: np.concatenate([np.arange(self.cols[c], self.cols[c + 1]) for c, s in enumerate(self.sources)
                                    if s.field == f]) for f in fields}
        return [{f for f in fields if needed[k, owner[f]].any()} for k in range(self.substeps)]

    def recorded(self) -> dict[str, int]:
        """Each recorded field (not bound): after how many substeps of a control step it is recorded."""
        out: dict[str, int] = {}
        for s, segment in enumerate(self.segments):
            for f in segment.fields:
                if f not in self.bound[s]:
                    out[f] = out.get(f, 0) + self._steps(s, f)
        return out

    def _steps(self, s: int, field: str) -> int:
        """Substeps of segment s whose values of `field` the store holds (1 for a bound field)."""
        a, b, _ = self.segments[s]
        return 1 if field in self.bound[s] else b - a + 1

    def _store(self, fields: dict[str, tuple[int, ...]]) -> None:
        nsim = self.nsim
        self.sizes = {f: math.prod(shape) for f, shape in fields.items()}
        hsize = (self.rows + 2) * nsim * self.width
        rsize = sum(nsim * self._steps(s, f) * self.sizes[f] for s, (_, _, fs) in enumerate(self.segments) for f in fs)
        zsize = sum(nsim * s for s in self.sizes.values())
        self.flat = np.zeros(hsize + rsize + zsize)
        self.history = self.flat[:hsize].reshape(self.rows + 2, nsim, self.width)
        self.record_offset: dict[tuple[int, str], int] = {}  # (segment, field) -> offset in `flat`
        self.reset_offset: dict[str, int] = {}
        self.record_out: list[dict[str, np.ndarray]] = []  # per segment: what its `rollout` records into
        # per segment: bound field -> (its record slot's columns that reads need, those columns of the field)
        self.bound_out: list[dict[str, tuple[np.ndarray, slice]]] = []
        self.reset_values: dict[str, np.ndarray] = {}  # what the caller fills after a physics reset
        r, z = hsize, hsize + rsize
        for s, (_, _, fs) in enumerate(self.segments):
            out, bound = {}, {}
            for f in fs:
                steps = self._steps(s, f)
                size = nsim * steps * self.sizes[f]
                self.record_offset[(s, f)] = r
                view = self.flat[r:r + size].reshape(nsim, steps, *fields[f])
                if f in self.bound[s]:  # only the span of values some channel reads is copied
                    read = np.concatenate([s.positions.ravel() for s in self.sources if s.field == f])
                    span = slice(int(read.min()), int(read.max()) + 1)
                    bound[f] = (view.reshape(nsim, -1)[:, span], span)
                else:
                    out[f] = view
                r += size
            self.record_out.append(out)
            self.bound_out.append(bound)
        for f, shape in fields.items():
            self.reset_offset[f] = z
            self.reset_values[f] = self.flat[z:z + nsim * self.sizes[f]].reshape(nsim, *shape)
            z += nsim * self.sizes[f]

    def _sources(self) -> None:
        """Column j of simulation i at substep k (1..substeps) is at `record_base[k - 1, j] + i *
        record_stride[k - 1, j]` of the store when its segment records it; its reset value at
        `reset_index[i, j]`."""
        nsim, substeps = self.nsim, self.substeps
        self.record_base = np.zeros((substeps, self.width), np.intp)
        self.record_stride = np.zeros((substeps, self.width), np.intp)
        reset = []
        for c, (field, index) in enumerate(self.sources):
            size = self.sizes[field]
            within = index.ravel().astype(np.intp)
            cols = slice(self.cols[c], self.cols[c + 1])
            for s, (a, b, fs) in enumerate(self.segments):
                if field in fs:
                    steps = self._steps(s, field)  # the store holds substeps b - steps + 1 .. b
                    for j, k in enumerate(range(b - steps + 1, b + 1)):
                        self.record_base[k - 1, cols] = self.record_offset[(s, field)] + j * size + within
                        self.record_stride[k - 1, cols] = steps * size
            reset.append(self.reset_offset[field] + np.arange(nsim)[:, None] * size + within[None, :])
        self.reset_index = np.concatenate(reset, axis=1) if reset else np.zeros((nsim, 0), np.intp)
        if self.fixed:  # where a read finds its recent samples (the reset read row: never used)
            sub = self.substep - 1
            self.record_read = np.vstack([self.record_base[sub, self.col[None, :]],
                                          np.zeros((1, self.col.size), np.intp)])
            self.record_read_stride = np.vstack([self.record_stride[sub, self.col[None, :]],
                                                 np.zeros((1, self.col.size), np.intp)])

    def _reads(self, noisy: set[int]) -> None:
        """The plan's read table as the batch uses it: row offsets per phase, outputs as index arrays, which
        read positions come from the control step's records, and what the history keeps."""
        plan, substeps, rows = self.plan, self.substeps, self.rows
        columns = np.zeros(self.width, bool)
        for c in noisy:
            columns[self.cols[c]:self.cols[c + 1]] = True
        # a noisy channel's history keeps every sample taken; a noise-free one's, those a later read shows
        self.later = np.where(columns, plan.taken, plan.read_later)
        self.plain: list[PlainRead] = []  # parts are positions in a read (index arrays)
        self.groups: list[ReductionGroup] = []
        if not self.fixed:
            return
        self.delta, self.col = plan.reads.delta, plan.reads.column
        delta = self.delta[:self.nphase]
        at = 0
        for out in plan.reads.plain:
            size = out.positions.size
            self.plain.append(PlainRead(out.sensor, slice(at, at + size),
                                        (self.nsim, *plan.sensors[out.sensor].output)))
            at += size
        self.plain_cols = (np.concatenate([out.positions for out in plan.reads.plain]) if plan.reads.plain
                           else np.zeros(0, np.intp))
        self.groups = [ReductionGroup(block.positions, (block.buffer, block.positions.size // block.buffer),
                                      [GroupMember(m.sensor, slice(*m.columns), plan.sensors[m.sensor].shape)
                                       for m in block.outputs], block.aggregator)
                       for block in plan.reads.blocks]
        # positions a read takes from its control step's records: noise-free samples of the last substeps steps
        recent = ((delta == 0) | (delta > rows - substeps)) & ~self.history_only[self.col][None, :]
        self.from_record = np.vstack([recent, np.zeros((1, self.col.size), bool)])  # never at a reset read
        # the substep of a recent sample
        self.substep = np.where(recent, np.where(delta == 0, substeps, delta - (rows - substeps)), substeps)

    def clear(self) -> None:
        """Forget cached positions (a reset changed which simulation is at which phase)."""
        self._cache.clear()

    def snapshot(self, history_row: int, age: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Store positions of the values a control step keeps: in the records, and in the history.

        `history_row`: the global step before the control step, mod rows; `age`: each simulation's steps since reset.
        Cached per `history_row` until `clear`.
        """
        key = ("snapshot", history_row)
        cached: tuple[np.ndarray, np.ndarray] | None = self._cache.get(key)
        if cached is None:
            nsim, w, substeps = self.nsim, self.width, self.substeps
            phases = np.unique((age % self.cycle) // substeps)
            sims = np.arange(nsim)[:, None]
            source, target = [], []
            for k in range(1, substeps + 1):
                cols = np.flatnonzero(self.always | self.later[phases, k - 1].any(axis=0))
                if cols.size:
                    source.append((self.record_base[k - 1, cols] + sims * self.record_stride[k - 1, cols]).ravel())
                    target.append(((history_row + k - 1) * nsim * w + sims * w + cols).ravel())
            empty = np.zeros(0, np.intp)
            cached = self._cache.put(key, (np.concatenate(source) if source else empty,
                                           np.concatenate(target) if target else empty))
        return cached

    def gathers(self, history_row: int, age: np.ndarray) -> np.ndarray:
        """Store positions of every fixed-schedule read value, for one `take`: (nsim, plain width), then
        per reduction group (buffer, nsim, group width), raveled (`read_parts` splits the result).
        `history_row`: the global step mod rows. Cached until `clear`."""
        fresh = bool((age == 0).any())  # a reset read: its phase is not the one history_row implies later on
        cached = None if fresh else self._cache.get(("read", history_row))
        if cached is None:
            phases = np.where(age == 0, self.nphase, (age % self.cycle) // self.substeps)
            if (phases == phases[0]).all():  # every simulation at one phase (as after a full reset)
                cached = self._uniform_reads(history_row, int(phases[0]))
            else:
                cached = self._positions(history_row, phases)
            if not fresh:
                self._cache.put(("read", history_row), cached)
        return cached

    def _positions(self, history_row: int, phases: np.ndarray | slice) -> np.ndarray:
        """Every read position at global step history_row, raveled for one `take`: each simulation's phase from
        `phases` (one per simulation), or the one phase `slice(q, q + 1)` of them all."""
        (plain_base, plain_stride), groups = self._read_table(history_row)
        sims = np.arange(self.nsim)
        plain = plain_base[phases] + sims[:, None] * plain_stride[phases]
        windows = [base[:, phases, :] + sims[None, :, None] * stride[:, phases, :] for base, stride in groups]
        return np.concatenate([plain.ravel(), *(w.ravel() for w in windows)])

    def read_parts(self, values: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Views of one `take` over `gathers`: plain (nsim, width), and per group (buffer, nsim, width)."""
        nsim = self.nsim
        at = nsim * self.plain_cols.size
        plain = values[:at].reshape(nsim, -1)
        groups = []
        for group in self.groups:
            size = nsim * group.part.size
            groups.append(values[at:at + size].reshape(group.block[0], nsim, group.block[1]))
            at += size
        return plain, groups

    def _uniform_reads(self, history_row: int, q: int) -> np.ndarray:
        """`gathers` when every simulation is at phase q: kept across resets (a few per history_row at most)."""
        key = (history_row, q)
        reads: np.ndarray | None = self._uniform.get(key)
        if reads is None:
            reads = self._uniform.put(key, self._positions(history_row, slice(q, q + 1)))
        return reads

    def _read_table(self, history_row: int) -> tuple[tuple[np.ndarray, np.ndarray], list[tuple[np.ndarray, ...]]]:
        """Simulation i's read positions at global step history_row and phase q are `base[q] + i * stride[q]`
        (plain: (phase, width); groups: (buffer, phase, width)). Kept per history_row: resets do not change it."""
        table: tuple[tuple[np.ndarray, np.ndarray], list[tuple[np.ndarray, ...]]] | None = self._tables.get(history_row)
        if table is None:
            nsim, w = self.nsim, self.width
            base = np.where(self.from_record, self.record_read,
                            ((history_row - 1 + self.delta) % self.rows) * (nsim * w) + self.col[None, :])
            stride = np.where(self.from_record, self.record_read_stride, w)
            table = self._tables.put(history_row, (
                (np.ascontiguousarray(base[:, self.plain_cols]), np.ascontiguousarray(stride[:, self.plain_cols])),
                [tuple(np.ascontiguousarray(a[:, g.part].reshape(-1, *g.block).transpose(1, 0, 2))
                       for a in (base, stride))
                 for g in self.groups]))
        return table

    def drawn(self, c: int, codes: np.ndarray, age: np.ndarray, global_step: int) -> np.ndarray:
        """Store positions (nsim, buffer, width) of a random-schedule channel's window, from its codes
        (0: zero fill, s + 1: the sample of step s since reset)."""
        nsim, w, rows = self.nsim, self.width, self.rows
        step = codes - 1
        if ((codes > 1) & (age[:, None] - step >= rows)).any():
            raise RuntimeError(f"a read of {self.plan.sensors[c].name!r} reaches further back than the batch's history "
                               f"of {rows} steps (an internal sizing error)")
        start = (global_step - age)[:, None]  # each simulation's reset, in global steps
        row = np.where(codes == 0, rows + 1, np.where(codes == 1, rows, (start + step - 1) % rows))
        return (row[:, :, None] * (nsim * w) + (np.arange(nsim) * w)[:, None, None]
                + np.arange(self.cols[c], self.cols[c + 1]))

