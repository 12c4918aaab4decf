"""Compiling a suite plan (`SuitePlan`) from bound observables (`plan.bound.Entry`): schedules, read tables,
masks, noise programs.

One function per part; each reuses the rule's one home (`plan/schedule.Schedule` for windows and taken
samples and the history's rows, `plan/layout.read_layout` for what a read gathers and how it is reduced,
`plan/drawn.Drawn` for drawn schedules' spans).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..draws import ChoiceSteps, UniformSteps
from .bound import Entry
from .drawn import Drawn
from .layout import Member, read_layout
from .noise import program
from .records import (BoolArray, DrawnSteps, DrawnTiming, FixedTiming, IntArray, NoiseProgram, PlainOutput,
                      ReadTable, ReducedOutput, ReductionBlock, SensorRecord, Source, SuitePlan, frozen)
from .schedule import Schedule, history_rows

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline

__all__ = ["compile_plan", "noise_program", "timing_of"]


_NO_WEIGHTS = frozen(np.zeros(0))


def _steps(setting: UniformSteps | ChoiceSteps | int | None, default: int) -> DrawnSteps:
    if isinstance(setting, UniformSteps):
        return DrawnSteps("uniform", frozen([setting.low, setting.high], np.intp), _NO_WEIGHTS)
    if isinstance(setting, ChoiceSteps):
        weights = _NO_WEIGHTS if setting.p is None else frozen(setting.p, np.float64)
        return DrawnSteps("choice", frozen(setting.values, np.intp), weights)
    return DrawnSteps("fixed", frozen([int(setting) if setting else default], np.intp), _NO_WEIGHTS)


def _fixed(sensor: Entry) -> Schedule:
    """A fixed-schedule sensor's schedule (`compile_plan`'s callers sorted them so)."""
    if not isinstance(sensor.schedule, Schedule):
        raise TypeError(f"sensor {sensor.name!r} has no fixed schedule (an internal error)")
    return sensor.schedule


def _drawn(sensor: Entry) -> Drawn:
    """A drawn-schedule sensor's planned schedule (`compile_plan`'s callers sorted them so)."""
    if not isinstance(sensor.schedule, Drawn):
        raise TypeError(f"sensor {sensor.name!r} has no planned drawn schedule (an internal error)")
    return sensor.schedule


def timing_of(schedule: Schedule | Drawn) -> FixedTiming | DrawnTiming:
    """A bound schedule's record in the plan."""
    if isinstance(schedule, Schedule):
        return FixedTiming(schedule.interval, schedule.delay, schedule.buffer, schedule.period,
                           frozen(schedule.needed_mask()), schedule.every_sample)
    return DrawnTiming(_steps(schedule.interval, 1), _steps(schedule.delay, 0), schedule.buffer, schedule.span,
                       schedule.every_sample)


def noise_program(noise: NoisePipeline | None, shape: tuple[int, ...],
                  schedule: Schedule | Drawn) -> NoiseProgram | None:
    """A bound sensor's noise program (`plan.noise.program`): sample j is taken at step j x its schedule's stride
    (a fixed schedule's interval, a drawn one's `Drawn.stride`)."""
    stride = schedule.interval if isinstance(schedule, Schedule) else schedule.stride
    return program(noise, tuple(shape), stride, timing_of(schedule))


def _record(sensor: Entry, source: Source, first: int) -> SensorRecord:
    size = math.prod(sensor.shape)
    schedule = sensor.schedule if isinstance(sensor.schedule, Schedule) else _drawn(sensor)
    aggregator = sensor.aggregator_name
    output = sensor.shape if aggregator is not None else sensor.buffered_shape
    return SensorRecord(sensor.name, tuple(sensor.shape), (first, first + size), tuple(output), aggregator,
                        timing_of(schedule), noise_program(sensor.noise, tuple(sensor.shape), schedule),
                        Source(source.field, frozen(source.positions, np.intp)))


def _read_table(fixed: Sequence[Entry], cols: IntArray, rows: int, substeps: int,
                cycle: int) -> ReadTable:
    """Per phase of a read, each read position's row offset (mod `rows`) and column, and the outputs."""
    nphase = cycle // substeps
    if not fixed:
        empty = frozen(np.zeros((nphase + 1, 0), np.intp))
        return ReadTable(cycle, nphase, empty, frozen(np.zeros(0, np.intp)), (), ())
    width = int(cols[len(fixed)])
    offsets = []
    members = [Member(_fixed(e), e.aggregator_name, e.shape, e.buffered_shape) for e in fixed]
    for q in range(nphase):
        layout = read_layout(members, cols[:len(fixed) + 1], rows, q * substeps)
        row, column = np.divmod(layout.gather, width)
        offsets.append((row - q * substeps) % rows)
    offset = np.stack(offsets)
    plain = tuple(PlainOutput(p.member, frozen(np.arange(p.part.start, p.part.stop), np.intp))
                  for p in layout.plain)
    blocks = tuple(ReductionBlock(g.aggregator, g.block[0], frozen(g.part, np.intp),
                                  tuple(ReducedOutput(m.member, (m.columns.start, m.columns.stop))
                                        for m in g.members))
                   for g in layout.groups)
    return ReadTable(cycle, nphase, frozen(np.vstack([offset, offset[:1]]), np.intp), frozen(column, np.intp),
                     plain, blocks)


def _masks(fixed: Sequence[Entry], cols: IntArray, width: int, nphase: int,
           substeps: int) -> tuple[BoolArray, BoolArray]:
    """(phase, substep, column): a sample is taken; it is shown by a later control step's read."""
    taken = np.zeros((nphase, substeps, width), bool)
    later = np.zeros((nphase, substeps, width), bool)
    for c, sensor in enumerate(fixed):
        schedule, columns = _fixed(sensor), slice(int(cols[c]), int(cols[c + 1]))
        needed = schedule.needed_mask()
        for q in range(nphase):
            for k in range(1, substeps + 1):
                step = q * substeps + k
                taken[q, k - 1, columns] = needed[step % schedule.period]
                later[q, k - 1, columns] = (step % schedule.interval == 0 and schedule.last_read(
                    step // schedule.interval) >= q * substeps + 2 * substeps)
    return frozen(taken), frozen(later)


def compile_plan(fixed: Sequence[Entry], drawn: Sequence[Entry], sources: Sequence[Source],
                 fields: Mapping[str, tuple[int, ...]], nsim: int, substeps: int, timestep: float,
                 pad: bool) -> SuitePlan:
    """The plan of bound observables (fixed-schedule ones, then drawn ones; `sources` in that order) for `nsim`
    simulations reading after every `substeps` physics steps of `timestep` seconds."""
    sensors: list[Entry] = [*fixed, *drawn]
    widths = [math.prod(e.shape) for e in sensors]
    cols = np.cumsum([0, *widths]).astype(np.intp)
    schedules = [_fixed(e) for e in fixed]
    period = math.lcm(substeps, *(s.interval for s in schedules))
    rows = history_rows(schedules, substeps, reach=max([0, *(_drawn(e).span for e in drawn)]))
    records = tuple(_record(e, source, int(cols[c])) for c, (e, source) in enumerate(zip(sensors, sources)))
    reads = _read_table(fixed, cols, rows, substeps, period)
    taken, later = _masks(fixed, cols, int(cols[-1]), reads.nphase, substeps)
    return SuitePlan(int(nsim), int(substeps), float(timestep), bool(pad), records, len(fixed), int(cols[-1]), rows,
                     reads, taken, later, tuple((f, tuple(shape)) for f, shape in fields.items()))
