"""The Updater's semantics for nsim simulations at once: one copy per control step, one gather per read.

This is `FeatureBank` across simulations. A control step's physics arrives as `rollout`'s records in the
store of a `Layout` (`batch.layout`); one `take`/`put` keeps in the history what later reads need, and a
read is one gather per output group over every simulation (the bank's read plan, shifted by each
episode's age), then one reduction per (aggregator, buffer) group.

A fixed-schedule sensor whose noise only adds numbers (gaussian and uniform stages) gets it as the batch
reads (`batch.read_noise`) when its reads show each sample about once (`added_as_read`): its history keeps raw
samples, as a noise-free sensor's. Other noise runs at each sample's own step on the simulations that sample
then, in place in the history (`batch.noise`); random intervals and delays are planned per simulation by the
stream rule's planner (`batch.random_schedules`). Scheduling, buffers and noise are the
single-simulation Updater's to the bit: the per-simulation state is its episode's age (`age`), random state,
noise and random plans.

Differences from the Updater: every observable must be a float64 mjData feature without a corruptor, or
a camera (rendered per simulation by `batch.camera`); generic callables, corruptors and custom
aggregators would run Python per sample and simulation and are rejected with a SuiteError naming the
sensor. `samples_taken` is not kept.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from dm_env import specs

from ..draws import episode_entropy, sensor_keys
from .. import compiled
from ..errors import ArgumentError
from ..observables.aggregators import reduce_stacked
from ..noise.streams import add_sums
from ..cache import DEFAULT_BUDGET, BoundedCache
from ..plan import FixedTiming, NoiseProgram, SuitePlan
from ..plan.bind import Bound, Entry, bind, plan_suite
from ..plan.schedule import Schedule
from ..plan.spec import observation_spec
from .layout import Layout
from .noise import BatchPipeline, prefetch
from .read_noise import ReadNoise, added_as_read
from .random_schedules import Timelines
from .relay import relayed

if TYPE_CHECKING:
    from ..noise.level import LeveledPipeline

__all__ = ["BatchUpdater"]

_NOISY_ROWS_BUDGET = DEFAULT_BUDGET  # bytes of per-row noisy samples kept, at least (the history's size when more)


def _camera_stops(schedule: Schedule, substeps: int) -> set[int]:
    """The substeps (1..substeps) after which the camera may render: a rollout returns there."""
    needed = set(schedule.needed_phases())
    period = schedule.period
    return {k for k in range(1, substeps + 1) for t in range(0, math.lcm(period, substeps), substeps)
            if (t + k) % period in needed}


class BatchUpdater:
    """Samples, delays, buffers, aggregates and corrupts observables of nsim simulations of one model.

    Per control step: `prepare(active)`, the caller's rollouts (one per `layout.segments`, into
    `layout.record_out`, cameras sampled after each), `update(active)`, then
    resets of finished simulations with `reset(ids, random_states)` (after filling `reset_values`), then
    `get_observation()`.
    """

    def __init__(self, observables: Mapping[str, Any], physics: Any, nsim: int, substeps: int, *,
                 strip_singleton_buffer_dim: bool = False, pad_with_initial_value: bool = False,
                 relays: Mapping[str, Mapping[int, int]] | None = None):
        """`physics`: a single-simulation physics of the model (its MjData tells field shapes; the
        observables are bound to it once, as the single-simulation Updater binds them, for checks and specs).
        `relays`: per field, its positions copied by the model's relay sensors (`batch.relay`), read there."""
        if not isinstance(observables, Mapping):
            raise ArgumentError("BatchEnvironment needs a dict of observables (or a Suite); got "
                             f"{type(observables).__name__}")
        self.nsim, self.substeps, self.pad = int(nsim), int(substeps), bool(pad_with_initial_value)
        bound = bind(observables, physics, self.substeps, bool(strip_singleton_buffer_dim))
        self.names = [entry.name for entry in bound.entries]
        self._spec = {e.name: observation_spec(e.name, e.observable, e.buffered_shape, e.dtype, self.pad)
                      for e in bound.entries}
        cameras, fixed, drawn = bound.cameras, bound.fixed, bound.drawn
        ordered = fixed + drawn  # history columns: fixed channels first (the read table's), then drawn ones
        self.nfixed = len(fixed)
        self.output_index = {e.name: i for i, e in enumerate(ordered + cameras)}
        self.cameras = self._cameras(cameras, physics)  # the caller sets `cameras.batch`
        sources = bound.sources()
        self.sources = relayed(sources, relays) if relays else sources
        # the suite plan of the batch's features: their noise programs, and the reads' table
        self.plan: SuitePlan = plan_suite(bound, physics, self.sources, self.nsim, self.substeps, self.pad)
        self.labels = [sensor.name for sensor in self.plan.sensors]  # (the history's columns, in order)
        read = self._noise(ordered, cameras)
        layout = self.layout = self._layout(bound)
        self.read_noise = ReadNoise(read, layout) if read else None
        self.reset_values = layout.reset_values
        self.history, self.flat, self.cols, self.rows = layout.history, layout.flat, layout.cols, layout.rows
        self.timelines = Timelines(self.plan)
        # per drawn-schedule sensor: its aggregator's name (None: none) and its read's shape
        self._drawn_outputs = [(s.aggregator, s.output) for s in self.plan.sensors[self.nfixed:]]
        self.global_step = 0  # global physics steps
        self.age = np.zeros(self.nsim, np.int64)  # physics steps since each simulation's reset
        self.control_steps = np.zeros(self.nsim, np.int64)
        self.started = np.zeros(self.nsim, bool)
        # per history row: the noisy samples of a control step starting there (`_noisy_samples`), within a budget
        self._noisy_by_row = BoundedCache(max(_NOISY_ROWS_BUDGET, layout.history.nbytes))

    # -- construction -----------------------------------------------------------------------------

    def _noise(self, ordered: list[Entry], cameras: list[Entry]) -> dict[int, BatchPipeline]:
        """Every noisy sensor's pipeline (`noise`), and those corrupted in the history (`corrupted`); returns
        the others: fixed-schedule sensors whose noise only adds numbers, added as they are read
        (`batch.read_noise`) where that draws fewer numbers."""
        programs = [sensor.noise for sensor in self.plan.sensors]  # (in the order of `ordered`)
        self.noise = {i: BatchPipeline(cast(NoiseProgram, programs[i]), self.nsim, e.name, self.plan.sensors[i].shape,
                                       dtype=e.noise.dtype)
                      for i, e in enumerate(ordered) if e.noise is not None}
        # the sensors' pipelines of a leveled program: their level for each new episode (`next_level`)
        self._leveled = {i: cast("LeveledPipeline", e.noise) for i, e in enumerate(ordered)
                         if i in self.noise and self.noise[i].program.leveled}
        self.noisy = bool(self.noise) or any(e.noise is not None for e in cameras)  # as the Updater draws
        timings = [sensor.timing for sensor in self.plan.sensors]
        read = {c: p for c, p in self.noise.items()
                if c < self.nfixed and added_as_read(p, cast(FixedTiming, timings[c]), self.substeps)}
        self.corrupted = {c: p for c, p in self.noise.items() if c not in read}
        return read

    def _layout(self, bound: Bound) -> Layout:
        """The store the rollouts record into and the history the reads gather from."""
        stops = set().union(*(_camera_stops(cast(Schedule, e.schedule), self.substeps) for e in bound.cameras))
        return Layout(self.plan, set(self.corrupted), dict(self.plan.fields), stops)

    def _cameras(self, cameras: list[Entry], physics: Any) -> Any:
        """The cameras, rendered per simulation (`batch.camera`), or None."""
        if not cameras:
            return None
        from .camera import BatchCameras

        model = physics.model if not hasattr(physics.model, "ptr") else physics.model.ptr
        return BatchCameras([(self.output_index[e.name], e) for e in cameras], model, self.nsim, self.substeps,
                            self.pad)

    # -- episodes ---------------------------------------------------------------------------------

    def reset(self, ids: np.ndarray, random_states: list[np.random.RandomState]) -> None:
        """Start new episodes of simulations `ids` (their `reset_values` filled after the physics reset).

        Per simulation, the same draws as the Updater's reset, in the same order: the episode entropy of
        the noise streams (if any sensor is noisy), then the reset draws of random-schedule channels.
        """
        ids = np.asarray(ids, np.intp)
        if not ids.size:
            return
        keys = self._start_episodes(ids, random_states)
        for c, channel_keys in zip(self.noise, keys):
            leveled = self._leveled.get(c)
            self.noise[c].start(ids, channel_keys, 1.0 if leveled is None else leveled.next_level)
        if self.read_noise is not None:
            self.read_noise.restart()
        self.started[ids] = True
        values = self.flat.take(self.layout.reset_index[ids])  # (m, width): the reset sample
        zeros = np.zeros(ids.size, np.int64)
        for c, pipeline in self.corrupted.items():
            lo, hi = self.cols[c], self.cols[c + 1]
            shape = self.plan.sensors[c].shape
            values[:, lo:hi] = pipeline(values[:, lo:hi].reshape(ids.size, *shape), ids, zeros).reshape(ids.size, -1)
        h = self.history
        h[:self.rows, ids] = values[None] if self.pad else 0.0
        h[(self.global_step - 1) % self.rows, ids] = values
        h[self.rows, ids] = values
        h[self.rows + 1, ids] = 0.0
        self.age[ids] = 0
        self.control_steps[ids] = 0
        if self.cameras is not None:
            self.cameras.reset(ids)
        self.layout.clear()
        self._noisy_by_row.clear()

    def _start_episodes(self, ids: np.ndarray, random_states: list[np.random.RandomState]) -> np.ndarray:
        """Each simulation's draws at reset, in the Updater's order; returns the noisy channels' keys
        (channel, simulation, 2), in the order of `self.noise`."""
        labels = [self.labels[c] for c in self.noise]
        planned = self.timelines.labels
        keys = np.zeros((len(labels) + len(planned), ids.size, 2), np.uint64)  # noise's, then schedules'
        for m, i in enumerate(ids.tolist()):
            entropy = episode_entropy(random_states[i]) if self.noisy or planned else None
            if labels or planned:
                keys[:, m] = sensor_keys(entropy or [], labels + planned)
            if self.cameras is not None:
                self.cameras.reset_noise(i, entropy or [])
        if planned:
            self.timelines.start(ids, keys[len(labels):])
        return keys[:len(labels)]

    # -- the physics loop -------------------------------------------------------------------------

    def prepare(self, active: np.ndarray) -> None:
        """Before a control step: plan random schedules ahead for the simulations about to step."""
        if self.timelines.labels:
            self.timelines.ensure(np.flatnonzero(active), self.control_steps)

    def update(self, active: np.ndarray) -> None:
        """After a control step's rollout (into `record_out`): store, sample and corrupt its substeps steps."""
        substeps, history_row = self.substeps, self.global_step % self.rows
        source, target = self.layout.snapshot(history_row, self.age)
        compiled.put(self.flat, target, compiled.take(self.flat, source))
        everyone = bool(active.all())
        if self.corrupted:
            sums, calls = [], []
            for call in self._noise_calls(history_row, active, everyone):  # additive-only pipelines: in place, at once
                k, c, sims, steps = call
                if self.corrupted[c].fused is not None:
                    sums.append(self.corrupted[c].sum(self.history[history_row + k - 1], int(self.cols[c]),
                                                      sims, steps))
                else:
                    calls.append(call)
            add_sums(sums)
            prefetch([(self.corrupted[c], sims, steps) for _, c, sims, steps in calls])
            for k, c, sims, steps in calls:
                self._corrupt(self.history[history_row + k - 1], c, sims, steps)
        self.global_step += substeps
        if everyone:
            self.age += substeps
            self.control_steps += 1
        else:
            self.age[active] += substeps
            self.control_steps[active] += 1
        if self.timelines.labels:
            self.timelines.advance(np.flatnonzero(active))

    def _noise_calls(self, history_row: int, active: np.ndarray,
                     everyone: bool) -> list[tuple[int, int, np.ndarray, np.ndarray]]:
        """(substep k, channel, sims, steps) of this control step's noisy samples, in order."""
        noisy = self._noisy_samples(history_row)
        taken = self.timelines.taken_now() if self.timelines.labels else None
        calls = []
        for k in range(1, self.substeps + 1):
            for c, sims in noisy[k - 1]:
                if not everyone:
                    sims = sims[active[sims]]
                if sims.size:
                    calls.append((k, c, sims, self.age[sims] + k))
            for r in range(len(self.timelines.labels)):
                c = self.nfixed + r
                if c in self.corrupted:
                    sims = np.flatnonzero(cast(np.ndarray, taken)[:, r, k - 1] & active)
                    if sims.size:
                        calls.append((k, c, sims, self.age[sims] + k))
        return calls

    def _corrupt(self, row: np.ndarray, c: int, sims: np.ndarray, steps: np.ndarray) -> None:
        """Noise on channel c's samples of `sims` in history row `row` (nsim, width), in place."""
        if not sims.size:
            return
        lo, hi = self.cols[c], self.cols[c + 1]
        shape = self.plan.sensors[c].shape
        if sims.size == self.nsim:
            samples = row[:, lo:hi].reshape(self.nsim, *shape)  # a view: columns are contiguous in a row
            noisy = self.corrupted[c](samples, sims, steps, out=samples)
            if not np.shares_memory(samples, row):
                row[:, lo:hi] = noisy.reshape(self.nsim, -1)
        else:
            raw = row[sims, lo:hi]
            row[sims, lo:hi] = self.corrupted[c](raw.reshape(sims.size, *shape), sims, steps).reshape(sims.size, -1)

    def _noisy_samples(self, history_row: int) -> list[list[tuple[int, np.ndarray]]]:
        """Per substep, the noisy fixed channels and the simulations that sample them (cached per phase)."""
        noisy: list[list[tuple[int, np.ndarray]]] | None = self._noisy_by_row.get(history_row)
        if noisy is None:
            local = self.age % self.rows
            noisy = [[] for _ in range(self.substeps)]
            for c in range(self.nfixed):
                if c not in self.corrupted:
                    continue
                needed = cast(FixedTiming, self.plan.sensors[c].timing).taken  # the first nfixed are fixed
                for k in range(1, self.substeps + 1):
                    sims = np.flatnonzero(needed[(local + k) % needed.size])
                    if sims.size:
                        noisy[k - 1].append((c, sims))
            self._noisy_by_row.put(history_row, noisy)
        return noisy

    # -- reads ------------------------------------------------------------------------------------

    def get_observation(self) -> dict[str, np.ndarray]:
        """Every observation of every simulation, (nsim, ...) arrays in the observables' order."""
        out: list[Any] = [None] * len(self.output_index)
        if self.cameras is not None:
            self.cameras.read(self.age, out)
        if self.nfixed:
            layout = self.layout
            # one take of every value read (positions are valid by construction), then views
            values = compiled.take(self.flat, layout.gathers(self.global_step % self.rows, self.age))
            if self.read_noise is not None:
                self.read_noise.apply(values, self.age)
            gathered, windows = layout.read_parts(values)
            for i, part, shape in layout.plain:
                out[i] = gathered[:, part].reshape(shape)
            for group, window in zip(layout.groups, windows):
                reduced = reduce_stacked(group.aggregator, window)
                for i, sub, shape in group.members:
                    out[i] = reduced[:, sub].reshape(self.nsim, *shape)
        if self.timelines.labels:
            self._read_drawn(out)
        return {name: out[self.output_index[name]] for name in self.names}

    def _read_drawn(self, out: list[Any]) -> None:
        for r, (codes, (aggregator, output)) in enumerate(zip(self.timelines.last, self._drawn_outputs)):
            c = self.nfixed + r
            values = self.flat.take(self.layout.drawn(c, codes, self.age, self.global_step))  # (nsim, buffer, width)
            if aggregator is not None:
                values = reduce_stacked(aggregator, values.transpose(1, 0, 2))
            out[c] = values.reshape(self.nsim, *output)

    # -- specs ------------------------------------------------------------------------------------

    def observation_spec(self) -> dict[str, specs.Array]:
        """The single-simulation specs with a leading nsim axis (bounds broadcast over it)."""
        out = {}
        for name, spec in self._spec.items():
            shape = (self.nsim, *spec.shape)
            if isinstance(spec, specs.BoundedArray):
                out[name] = specs.BoundedArray(shape, spec.dtype, np.broadcast_to(spec.minimum, spec.shape),
                                               np.broadcast_to(spec.maximum, spec.shape), name=name)
            else:
                out[name] = specs.Array(shape, spec.dtype, name=name)
        return out
