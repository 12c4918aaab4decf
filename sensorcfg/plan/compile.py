"""Compiling a suite plan (`SuitePlan`) from bound channels: schedules, read tables, masks, noise programs.

One function per part; each reuses the rule's one home (`runtime/schedule.Schedule` for windows and taken
samples and the history's rows, `runtime/bank.read_layout` for what a read gathers and how it is reduced,
`runtime/drawn.Drawn` for drawn schedules' spans).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..draws import ChoiceSteps, UniformSteps
from ..runtime.bank import read_layout
from ..runtime.channels import DrawnChannel, FixedChannel
from ..runtime.drawn import Drawn
from ..runtime.schedule import history_rows
from .noise import program
from .records import (BoolArray, DrawnSteps, DrawnTiming, FixedTiming, IntArray, PlainOutput, ReadTable,
                      ReducedOutput, ReductionBlock, SensorRecord, Source, SuitePlan, frozen)

__all__ = ["compile_plan"]


_NO_WEIGHTS = frozen(np.zeros(0))


def _steps(setting: UniformSteps | ChoiceSteps | int | None, default: int) -> DrawnSteps:
    if isinstance(setting, UniformSteps):
        return DrawnSteps("uniform", frozen([setting.low, setting.high], np.intp), _NO_WEIGHTS)
    if isinstance(setting, ChoiceSteps):
        weights = _NO_WEIGHTS if setting.p is None else frozen(setting.p, np.float64)
        return DrawnSteps("choice", frozen(setting.values, np.intp), weights)
    return DrawnSteps("fixed", frozen([int(setting) if setting else default], np.intp), _NO_WEIGHTS)


def _timing(channel: FixedChannel | DrawnChannel) -> FixedTiming | DrawnTiming:
    if isinstance(channel, FixedChannel):
        schedule = channel.schedule
        return FixedTiming(channel.interval, channel.delay, schedule.buffer, schedule.period,
                           frozen(schedule.needed_mask()), schedule.every_sample)
    drawn: Drawn = channel.drawn
    return DrawnTiming(_steps(drawn.interval, 1), _steps(drawn.delay, 0), drawn.buffer, drawn.span)


def _record(channel: FixedChannel | DrawnChannel, source: Source, first: int) -> SensorRecord:
    size = math.prod(channel.shape)
    stride = channel.interval if isinstance(channel, FixedChannel) else channel.drawn.stride
    aggregator = None if channel.aggregator is None else str(getattr(channel.aggregator, "name"))
    output = channel.shape if aggregator is not None else channel.buffered_shape
    timing = _timing(channel)
    return SensorRecord(channel.name, tuple(channel.shape), (first, first + size), tuple(output), aggregator,
                        timing, program(channel.noise, tuple(channel.shape), stride, timing),
                        Source(source.field, frozen(source.positions, np.intp)))


def _read_table(fixed: Sequence[FixedChannel], cols: IntArray, rows: int, substeps: int,
                cycle: int) -> ReadTable:
    """Per phase of a read, each read position's row offset (mod `rows`) and column, and the outputs."""
    nphase = cycle // substeps
    if not fixed:
        empty = frozen(np.zeros((nphase + 1, 0), np.intp))
        return ReadTable(cycle, nphase, empty, frozen(np.zeros(0, np.intp)), (), ())
    width = int(cols[len(fixed)])
    offsets = []
    for q in range(nphase):
        layout = read_layout(list(fixed), cols[:len(fixed) + 1], rows, q * substeps)
        row, column = np.divmod(layout.gather, width)
        offsets.append((row - q * substeps) % rows)
    offset = np.stack(offsets)
    plain = tuple(PlainOutput(p.member, frozen(np.arange(p.part.start, p.part.stop), np.intp))
                  for p in layout.plain)
    blocks = tuple(ReductionBlock(g.aggregator, g.block[0], frozen(np.arange(g.part.start, g.part.stop), np.intp),
                                  tuple(ReducedOutput(m.member, (m.columns.start, m.columns.stop))
                                        for m in g.members))
                   for g in layout.groups)
    return ReadTable(cycle, nphase, frozen(np.vstack([offset, offset[:1]]), np.intp), frozen(column, np.intp),
                     plain, blocks)


def _masks(fixed: Sequence[FixedChannel], cols: IntArray, width: int, nphase: int,
           substeps: int) -> tuple[BoolArray, BoolArray]:
    """(phase, substep, column): a sample is taken; it is shown by a later control step's read."""
    taken = np.zeros((nphase, substeps, width), bool)
    later = np.zeros((nphase, substeps, width), bool)
    for c, channel in enumerate(fixed):
        schedule, columns = channel.schedule, slice(int(cols[c]), int(cols[c + 1]))
        needed = schedule.needed_mask()
        for q in range(nphase):
            for k in range(1, substeps + 1):
                step = q * substeps + k
                taken[q, k - 1, columns] = needed[step % schedule.period]
                later[q, k - 1, columns] = (step % channel.interval == 0 and
                                            schedule.last_read(step // channel.interval) >= q * substeps + 2 * substeps)
    return frozen(taken), frozen(later)


def compile_plan(fixed: Sequence[FixedChannel], drawn: Sequence[DrawnChannel], sources: Sequence[Source],
                 fields: Mapping[str, tuple[int, ...]], nsim: int, substeps: int, timestep: float,
                 pad: bool) -> SuitePlan:
    """The plan of bound channels (fixed-schedule ones, then drawn ones; `sources` in that order) for `nsim`
    simulations reading after every `substeps` physics steps of `timestep` seconds."""
    channels: list[FixedChannel | DrawnChannel] = [*fixed, *drawn]
    widths = [math.prod(ch.shape) for ch in channels]
    cols = np.cumsum([0, *widths]).astype(np.intp)
    period = math.lcm(substeps, *(ch.interval for ch in fixed))
    rows = history_rows([ch.schedule for ch in fixed], substeps, reach=max([0, *(ch.drawn.span for ch in drawn)]))
    sensors = tuple(_record(ch, source, int(cols[c])) for c, (ch, source) in enumerate(zip(channels, sources)))
    reads = _read_table(fixed, cols, rows, substeps, period)
    taken, later = _masks(fixed, cols, int(cols[-1]), reads.nphase, substeps)
    return SuitePlan(int(nsim), int(substeps), float(timestep), bool(pad), sensors, len(fixed), int(cols[-1]), rows,
                     reads, taken, later, tuple((f, tuple(shape)) for f, shape in fields.items()))
