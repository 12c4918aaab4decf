"""Additive noise added as a batch reads, not where its history keeps samples.

A fixed-schedule sensor whose noise only adds numbers (gaussian and uniform stages, fused into one sum:
`BatchPipeline.additive`) gets sample j's noise from its simulation's episode key and j alone
(`noise.streams`). So where its reads show each sample about once (`added_as_read`; a frame stack keeps the
history path, which draws a sample's numbers once), the batch keeps that sensor's raw samples, as it keeps a
noise-free sensor's (only those a later read needs, the rest read straight from the control step's
records), and a read adds each sample's noise to the values it gathered, one sum per sensor, before any
reduction (`streams.add_rows`: each sensor's sum prepared once per batch, its keys, samples and positions per
read). A sample in the windows of several reads gets the same numbers each time. Padding before the reset sample
is the reset sample's noisy value (`pad_with_initial_value`) or zeros, which no noise touches, as in the
single-simulation Updater.

A simulation whose episode has a noise level other than 1 blends the result with the raw value
(`noise.level.blend`, as the pipeline's last stage does).
"""

from __future__ import annotations

from typing import NamedTuple, cast

import numpy as np

from ..noise.level import blend
from ..noise.streams import Prepared, Rows, add_rows, prepare
from ..plan.records import FixedTiming
from ..plan.schedule import Schedule, newest_sample
from .layout import Layout
from .noise import BatchPipeline, Fused, Levels

__all__ = ["ReadNoise", "added_as_read"]

# Reads that show each sample once cost less than the history path (which also copies every sample and runs a
# call per substep); reads that show each sample twice cost about as much. The read's cost grows by about one
# single read's per extra read while the history path draws each sample's numbers once, so the break-even lies
# near 1.8 reads per sample; 1.5 keeps a margin. `benchmarks/batch_noise_paths.py` times both paths
# (docs/performance.md).
_MAX_READS_PER_SAMPLE = 1.5


def added_as_read(pipeline: BatchPipeline, timing: FixedTiming, substeps: int) -> bool:
    """Whether the batch adds a fixed-schedule sensor's noise as it reads (every `substeps` steps): the pipeline
    only adds numbers, and reads show each sample taken at most `_MAX_READS_PER_SAMPLE` times on average (per
    period of the plan's `timing`: slots read over samples taken)."""
    if pipeline.additive is None:
        return False
    shown = timing.period // substeps * timing.buffer
    return shown <= _MAX_READS_PER_SAMPLE * int(np.count_nonzero(timing.taken))


class _Sensor(NamedTuple):
    stage: Fused  # the pipeline's fused sum: its keys and terms
    size: int  # values per sample
    span: slice  # its (simulation, slot) pairs in the concatenated arrays of `ReadNoise`
    levels: Levels | None  # the pipeline's per-simulation noise levels (None without a level)
    sum: Prepared  # its draws and terms, made once (`streams.prepare`)


def _starts(layout: Layout, c: int, size: int, buffer: int) -> np.ndarray:
    """Where simulation i's slot s of fixed channel c starts in the values of one read (`Layout.read_parts`)."""
    nsim, plain_width = layout.nsim, layout.plain_cols.size
    sims, slots = np.arange(nsim)[:, None], np.arange(buffer)[None, :]
    for i, part, _ in layout.plain:
        if i == c:
            return cast(np.ndarray, sims * plain_width + part.start + slots * size)
    at = nsim * plain_width
    for group in layout.groups:
        for i, sub, _ in group.members:
            if i == c:
                return cast(np.ndarray, at + (slots * nsim + sims) * group.block[1] + sub.start)
        at += nsim * group.part.size
    raise ValueError(f"channel {c} is not read")


class ReadNoise:
    """The read-time noise of fixed channels `pipelines` (channel -> its batch pipeline) of a batch.

    Every sensor's (simulation, slot) pairs are laid end to end, so that a read computes all their sample
    indices in one pass; the keys, which change only at resets (`restart`), are kept in that order too."""

    def __init__(self, pipelines: dict[int, BatchPipeline], layout: Layout):
        """`pipelines`: fixed channel -> its batch pipeline, read by `layout` (its plan's sensors, their timing
        and shape, and `pad_with_initial_value`)."""
        plan = layout.plan
        self.pad = plan.pad_with_initial_value
        self.nsim = nsim = layout.nsim
        self.sensors: list[_Sensor] = []
        columns: list[tuple[np.ndarray, ...]] = []
        at = 0
        for c, pipeline in pipelines.items():
            stage = pipeline.additive
            if stage is None or stage.terms is None:  # `added_as_read` chose pipelines with one
                raise RuntimeError(f"read noise of channel {c}: its pipeline is not a sum added as read "
                                   "(an internal error)")
            record = plan.sensors[c]
            schedule = Schedule.of(cast(FixedTiming, record.timing), plan.substeps)  # (its windows)
            size = int(np.prod(record.shape, dtype=np.int64))
            if pipeline.stride != schedule.interval:  # a fixed schedule's is: sample j's numbers are the j-th
                raise RuntimeError(f"read noise of channel {c}: its noise stride is not its interval "
                                   "(an internal error)")
            count = nsim * schedule.buffer
            templates = stage.draws(np.zeros(0, np.intp), np.zeros(0, np.int64))  # (their keys and samples unused)
            prepared = prepare(templates, stage.terms)
            self.sensors.append(_Sensor(stage, size, slice(at, at + count), pipeline.levels, prepared))
            at += count
            # the read at t sees sample `schedule.newest(t) + schedule.offsets()[slot]` in slot `slot`
            columns.append((np.repeat(np.arange(nsim), schedule.buffer),
                            _starts(layout, c, size, schedule.buffer).ravel(), np.tile(schedule.offsets(), nsim),
                            *(np.full(count, v) for v in (schedule.delay, schedule.interval))))
        self.sims, self.starts, self.first, delay, interval = (
            np.concatenate(column).astype(np.int64) for column in zip(*columns))
        self.keys = np.zeros((at, 2), np.uint64)
        # a read divides each simulation's step once per (delay, interval) pair, not once per (sensor, slot)
        pairs, pair = np.unique(np.stack([delay, interval], axis=1), axis=0, return_inverse=True)
        self.pair_delay, self.pair_interval = pairs[:, :1], pairs[:, 1:]
        self.pair_at = pair.ravel() * nsim + self.sims  # each entry's (pair, simulation) in their raveled steps

    def restart(self) -> None:
        """Take the sensors' episode keys (after a reset of some simulations)."""
        for sensor in self.sensors:
            self.keys[sensor.span] = sensor.stage.keys[self.sims[sensor.span]]

    def apply(self, values: np.ndarray, age: np.ndarray) -> None:
        """Add each read sample's noise to `values`, one read of every simulation (`age`: each one's steps since
        reset)."""
        steps = newest_sample(age[None, :], self.pair_delay, self.pair_interval)  # (pair, simulation)
        sample = steps.ravel().take(self.pair_at)
        sample += self.first  # < 0: padding
        padding = bool((sample < 0).any())
        if self.pad:
            np.maximum(sample, 0, out=sample)  # the reset sample's value
        rows, blends = [], []
        for sensor in self.sensors:
            span = sensor.span
            sims, starts, j, keys = self.sims[span], self.starts[span], sample[span], self.keys[span]
            if padding and not self.pad:  # zeros: no noise
                kept = np.flatnonzero(j >= 0)
                sims, starts, j, keys = sims[kept], starts[kept], j[kept], keys[kept]
            if not j.size:
                continue
            rows.append(Rows(sensor.sum, keys, j, starts))
            if sensor.levels is not None and sensor.levels.active:
                blends.append(self._blended(values, sensor, sims, starts))  # their raw values, before the noise
        add_rows(rows, values)
        for at, raw, level in blends:  # no bounds: a sum of additive terms keeps none (`noise.bounds`)
            out = np.empty_like(raw)
            blend(raw, values[at], level, out)
            values[at] = out

    @staticmethod
    def _blended(values: np.ndarray, sensor: _Sensor, sims: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, ...]:
        """The positions of the samples of simulations at a level other than 1, their raw values and levels."""
        levels = cast(Levels, sensor.levels).levels[sims]
        rows = np.flatnonzero(levels != 1.0)
        at = starts[rows, None] + np.arange(sensor.size)
        return at, values[at], levels[rows, None]
