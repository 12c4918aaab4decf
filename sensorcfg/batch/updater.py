"""The Updater's semantics for nsim simulations at once: one history, one gather per read.

This is `FeatureBank` across simulations. The physics of a control step arrives as `rollout`'s records,
(nsim, n, ...) per mjData field, all in one flat buffer this class owns; one `take` copies every
observed value of every simulation and substep into a history of (rows, nsim, width) values, indexed by
global physics step (so the copy is the same for every simulation, whatever its episode's age). Reads
follow the bank's periodic read plan (`runtime.bank.read_plan`), shifted per simulation by the age of its
episode: one gather per output group, one reduction per (aggregator, buffer) group, over all simulations.

Noise runs at each sample's own step on the simulations that sample then, in place in the history
(`batch.noise`); random intervals and delays are planned per simulation by the single-simulation
channel itself (`batch.timeline`). Scheduling, buffers and noise are the single-simulation Updater's to
the bit: the per-simulation state is its episode's age (`t`), random state, noise and random plans.

Differences from the Updater: every observable must be a float64 mjData feature without a corruptor
(cameras, generic callables, corruptors and custom aggregators run Python per sample and simulation:
they are rejected with a SuiteError naming the sensor), and `samples_taken` is not kept.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np
from dm_env import specs

from ..draws import ChoiceSteps, UniformSteps
from ..errors import SuiteError
from ..runtime.bank import _REDUCERS, read_plan
from ..runtime.channels import Channel, FixedChannel, RandomChannel
from ..runtime.updater import DEFAULT_DELAY, DEFAULT_UPDATE_INTERVAL, Updater, _drawer, _episode_entropy, sensor_rng
from .noise import BatchPipeline
from .timeline import Timelines

__all__ = ["BatchUpdater"]


def _bound(label: str, attr: str, value: Any, default: int) -> int:
    """The largest value an interval or delay setting can take (drawn ones must say, to size the history)."""
    if not value:
        return default
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, UniformSteps):
        return int(value.high)
    if isinstance(value, ChoiceSteps):
        return int(max(value.values))
    raise SuiteError(f"sensor {label!r}: its {attr} is a callable ({value!r}) that cannot be vectorised across "
                     "simulations: the batch must know its largest value; use {uniform: [lo, hi]} or "
                     "{choice: [...]}")


class _Store:
    """One flat float64 buffer: the history, then the records of a control step, then the reset values.

    One buffer, so one gather can read a window whose older samples are in the history and whose samples
    of the current control step are still in the records.
    """

    def __init__(self, fields: dict[str, tuple[int, ...]], nsim: int, n: int, history: tuple[int, ...]):
        self.sizes = {f: math.prod(shape) for f, shape in fields.items()}
        hsize = math.prod(history)
        rsize = sum(nsim * n * s for s in self.sizes.values())
        zsize = sum(nsim * s for s in self.sizes.values())
        self.flat = np.zeros(hsize + rsize + zsize)
        self.history = self.flat[:hsize].reshape(history)
        self.record_offset: dict[str, int] = {}  # of each field's (nsim, n, ...) records, in `flat`
        self.reset_offset: dict[str, int] = {}
        self.record_out: dict[str, np.ndarray] = {}
        self.reset_values: dict[str, np.ndarray] = {}
        r, z = hsize, hsize + rsize
        for f, shape in fields.items():
            size = self.sizes[f]
            self.record_offset[f], self.reset_offset[f] = r, z
            self.record_out[f] = self.flat[r:r + nsim * n * size].reshape(nsim, n, *shape)
            self.reset_values[f] = self.flat[z:z + nsim * size].reshape(nsim, *shape)
            r += nsim * n * size
            z += nsim * size


class BatchUpdater:
    """Samples, delays, buffers, aggregates and corrupts observables of nsim simulations of one model.

    Per control step: `prepare(active)`, the caller's `rollout` into `record_out`, `update(active)`, then
    resets of finished simulations with `reset(ids, random_states)` (after filling `reset_values`), then
    `get_observation()`.
    """

    def __init__(self, observables: Mapping[str, Any], physics: Any, nsim: int, n: int, *,
                 strip_singleton_buffer_dim: bool = False, pad_with_initial_value: bool = False):
        """`physics`: a single-simulation physics of the model (its MjData tells field shapes; the
        observables are bound to it once, with the single-simulation Updater, for checks and specs)."""
        if not isinstance(observables, Mapping):
            raise SuiteError("BatchEnvironment needs a dict of observables (or a Suite); got "
                             f"{type(observables).__name__}")
        self.nsim, self.n, self.pad = int(nsim), int(n), bool(pad_with_initial_value)
        template = Updater(observables, n, strip_singleton_buffer_dim, pad_with_initial_value)
        template.reset(physics, np.random.RandomState(0))
        self._spec = template.observation_spec()
        enabled = [(name, obs) for name, obs in observables.items() if obs.enabled]
        channels: list[Channel] = list(template._channels)
        self.names = [name for name, _ in enabled]
        for (name, obs), ch in zip(enabled, channels):
            self._check(name, obs, ch)
        data = physics.data if not hasattr(physics.data, "ptr") else physics.data.ptr
        fixed = [(name, obs, ch) for (name, obs), ch in zip(enabled, channels) if isinstance(ch, FixedChannel)]
        drawn = [(name, obs, ch) for (name, obs), ch in zip(enabled, channels) if isinstance(ch, RandomChannel)]
        ordered = fixed + drawn  # history columns: fixed channels first (the read plan's), then random ones
        fields = {}
        for _, _, ch in ordered:
            fields.setdefault(ch.sampler.field, tuple(getattr(data, ch.sampler.field).shape))
        widths = [math.prod(ch.shape) for _, _, ch in ordered]
        self.cols = np.cumsum([0] + widths).astype(np.intp)
        self.width = int(self.cols[-1])
        self.fixed = [ch for _, _, ch in fixed]
        self.nfixed = len(fixed)
        self.output_index = {name: i for i, (name, _, _) in enumerate(ordered)}
        self.labels = [name for name, _, _ in ordered]
        self.channels = [ch for _, _, ch in ordered]
        self.noise = {i: BatchPipeline(ch.noise, self.nsim, name)
                      for i, (name, _, ch) in enumerate(ordered) if ch.noise is not None}
        self.noisy = bool(self.noise)
        self._rows(fixed, drawn)
        # history rows: one per physics step (mod rows), then the reset sample, then zeros
        self.store = _Store(fields, self.nsim, self.n, (self.rows + 2, self.nsim, self.width))
        self.record_out, self.reset_values = self.store.record_out, self.store.reset_values
        self.history, self.flat = self.store.history, self.store.flat
        self._sources()
        self._read_plans()
        self.timelines = Timelines(
            [(name, ch, self._drawers(name, obs)) for name, obs, ch in drawn], self.nsim, self.n, self.pad)
        self.G = 0  # global physics steps
        self.t = np.zeros(self.nsim, np.int64)  # physics steps since each simulation's reset
        self.control_steps = np.zeros(self.nsim, np.int64)
        self.started = np.zeros(self.nsim, bool)
        self._cache: dict[int, Any] = {}

    # -- construction -----------------------------------------------------------------------------

    @staticmethod
    def _check(name: str, obs: Any, ch: Channel) -> None:
        if getattr(obs, "corruptor", None) is not None:
            raise SuiteError(f"sensor {name!r}: a corruptor runs a Python callable per sample and simulation and "
                             "cannot be vectorised; use noise stages instead")
        sampler = ch.sampler
        what = type(obs).__name__
        if getattr(sampler, "struct", None) != "data" or not hasattr(sampler, "index"):
            kind = "a model field" if getattr(sampler, "struct", None) == "model" else f"a {what}"
            raise SuiteError(f"sensor {name!r} ({kind}) cannot run in a BatchEnvironment: only features of mjData "
                             "fields are vectorised across simulations (cameras and generic callables would run "
                             "Python per simulation); use the single-simulation Environment for it")
        if ch.dtype != np.float64:
            raise SuiteError(f"sensor {name!r}: {ch.dtype} features cannot be vectorised (float64 only)")
        aggregator = ch.aggregator
        if aggregator is not None and not (ch.builtin_aggregator and ch.has_buffer_dim
                                           and getattr(aggregator, "name", None) in _REDUCERS):
            raise SuiteError(f"sensor {name!r}: its aggregator cannot be vectorised across simulations: use one of "
                             f"{', '.join(_REDUCERS)} on a buffer (a custom callable would run per simulation)")

    def _drawers(self, label: str, obs: Any) -> Any:
        def make(random_state: Any) -> tuple[Any, Any]:
            interval = _drawer(label, "update_interval", obs.update_interval, DEFAULT_UPDATE_INTERVAL, random_state)
            delay = _drawer(label, "delay", obs.delay, DEFAULT_DELAY, random_state)
            as_fn = lambda v: v if callable(v) else (lambda: v)  # noqa: E731
            return as_fn(interval), as_fn(delay)
        return make

    def _rows(self, fixed: list[Any], drawn: list[Any]) -> None:
        """History length: a multiple of every sampling period, longer than any sample can wait to be read."""
        n = self.n
        period = math.lcm(n, *(ch.interval for _, _, ch in fixed))
        span = n + 1
        for _, _, ch in fixed:
            span = max(span, ch.delay + ch.buffer_size * ch.interval + n + 1)
        for name, obs, ch in drawn:
            interval = _bound(name, "update_interval", obs.update_interval, DEFAULT_UPDATE_INTERVAL)
            delay = _bound(name, "delay", obs.delay, DEFAULT_DELAY)
            span = max(span, delay + (ch.buffer_size + 1) * interval + 2 * n + 1)
        self.rows = period * -(-span // period)

    def _sources(self) -> None:
        """Where each column's value of simulation i at substep k sits in the records:
        `record_base[j] + i * record_stride[j] + k * record_step[j]`; and the reset sample's positions."""
        store, nsim, n = self.store, self.nsim, self.n
        base, stride, step, reset = [], [], [], []
        for ch in self.channels:
            field = ch.sampler.field
            size = store.sizes[field]
            within = ch.sampler.index.ravel().astype(np.intp)
            base.append(store.record_offset[field] + within)
            stride.append(np.full(within.size, n * size, np.intp))
            step.append(np.full(within.size, size, np.intp))
            reset.append(store.reset_offset[field] + np.arange(nsim)[:, None] * size + within[None, :])
        empty = np.zeros(0, np.intp)
        self.record_base = np.concatenate(base) if base else empty
        self.record_stride = np.concatenate(stride) if stride else empty
        self.record_step = np.concatenate(step) if step else empty
        self.reset_index = np.concatenate(reset, axis=1) if reset else np.zeros((nsim, 0), np.intp)
        # columns whose every substep goes to the history: noise runs there, random windows read there
        always = np.zeros(self.width, bool)
        for c in range(len(self.channels)):
            if c in self.noise or c >= self.nfixed:
                always[self.cols[c]:self.cols[c + 1]] = True
        self.always = always

    def _read_plans(self) -> None:
        """The bank's read plan at each phase of a read (steps since reset, mod rows), as row offsets."""
        rows, n = self.rows, self.n
        self.nphase = rows // n
        if not self.fixed:
            self.delta = np.zeros((self.nphase, 0), np.intp)
            self.plain, self.groups, self.plain_cols, self.col = [], [], np.zeros(0, np.intp), np.zeros(0, np.intp)
            self.later = np.zeros((self.nphase, self.n, self.width), bool)
            return
        fixed_cols = self.cols[:self.nfixed + 1]
        wf = int(fixed_cols[-1])
        deltas = []
        for q in range(self.nphase):
            index, groups, plain = read_plan(self.fixed, fixed_cols, rows, q * n)
            row, col = np.divmod(index, wf)
            deltas.append((row - q * n) % rows)
        self.delta = np.stack(deltas)  # (phase, read width): row offset from the read's own row
        self.col = col
        # the layout (which positions form which output) does not depend on the phase
        self.plain = []
        pos = []
        at = 0
        for i, part, shape in plain:
            size = part.stop - part.start
            self.plain.append((i, slice(at, at + size), (self.nsim, *shape)))
            pos.append(np.arange(part.start, part.stop))
            at += size
        self.plain_cols = np.concatenate(pos) if pos else np.zeros(0, np.intp)
        self.groups = [(reduce, np.arange(part.start, part.stop), block, members)
                       for reduce, part, block, members in groups]
        # Positions a read takes from this control step's records rather than the history: noise-free
        # samples of the last n steps (never at the reset read, whose samples are all in the history).
        recent = (self.delta == 0) | (self.delta > rows - n)
        plain = ~self.always[self.col]
        self.from_record = np.vstack([recent & plain[None, :], np.zeros((1, plain.size), bool)])
        k = np.where(self.delta == 0, n, self.delta - (rows - n))  # substep 1..n of a recent sample
        self.record_read = np.vstack([self.record_base[self.col] + (k - 1) * self.record_step[self.col],
                                      np.zeros((1, plain.size), np.intp)])
        self.record_read_stride = self.record_stride[self.col]
        # Per phase and substep: the noise-free columns whose sample a later read takes from the history
        later = np.zeros((self.nphase, n, self.width), bool)
        for c, ch in enumerate(self.fixed):
            if c in self.noise:
                continue
            i, d, b = ch.interval, ch.delay, ch.buffer_size
            for q in range(self.nphase):
                for kk in range(1, n + 1):
                    if (q * n + kk) % i == 0 and kk + b * i + d - 1 >= 2 * n:
                        later[q, kk - 1, self.cols[c]:self.cols[c + 1]] = True
        self.later = later

    # -- episodes ---------------------------------------------------------------------------------

    def reset(self, ids: np.ndarray, random_states: list[np.random.RandomState]) -> None:
        """Start new episodes of simulations `ids` (their `reset_values` filled after the physics reset).

        Per simulation, the same draws as the Updater's reset, in the same order: the episode entropy of
        the noise streams (if any sensor is noisy), then the reset draws of random-schedule channels.
        """
        ids = np.asarray(ids, np.intp)
        if not ids.size:
            return
        for i in ids:
            i = int(i)
            rs = random_states[i]
            if self.started[i]:
                self.timelines.finish(i, int(self.control_steps[i]))
            entropy = _episode_entropy(rs) if self.noisy else None
            for c, pipeline in self.noise.items():
                pipeline.reset(i, sensor_rng(entropy or [], self.labels[c]))
            if self.timelines.specs:
                self.timelines.start(i, rs)
        self.started[ids] = True
        values = self.flat.take(self.reset_index[ids])  # (m, width): the reset sample
        zeros = np.zeros(ids.size, np.int64)
        for c, pipeline in self.noise.items():
            lo, hi = self.cols[c], self.cols[c + 1]
            ch = self.channels[c]
            values[:, lo:hi] = pipeline(values[:, lo:hi].reshape(ids.size, *ch.shape), ids, zeros).reshape(ids.size, -1)
        h = self.history
        h[:self.rows, ids] = values[None] if self.pad else 0.0
        h[(self.G - 1) % self.rows, ids] = values
        h[self.rows, ids] = values
        h[self.rows + 1, ids] = 0.0
        self.t[ids] = 0
        self.control_steps[ids] = 0
        self._cache.clear()

    # -- the physics loop -------------------------------------------------------------------------

    def prepare(self, active: np.ndarray) -> None:
        """Before a control step: plan random schedules ahead for the simulations about to step."""
        if self.timelines.specs:
            self.timelines.ensure(np.flatnonzero(active), self.control_steps)

    def update(self, active: np.ndarray) -> None:
        """After a control step's rollout (into `record_out`): store, sample and corrupt its n steps."""
        n, gp = self.n, self.G % self.rows
        source, target = self._snapshot(gp)
        self.flat.put(target, self.flat.take(source), "clip")
        everyone = bool(active.all())
        plan = self._plan(gp)
        if self.timelines.specs:
            taken = self.timelines.taken_now()
        for k in range(1, n + 1):
            row = self.history[gp + k - 1]
            for c, sims in plan[k - 1]:
                if not everyone:
                    sims = sims[active[sims]]
                self._corrupt(row, c, sims, self.t[sims] + k)
            for r in range(len(self.timelines.specs)):
                c = self.nfixed + r
                if c not in self.noise:
                    continue
                mask = taken[:, r, k - 1] & active
                sims = np.flatnonzero(mask)
                if sims.size:
                    self._corrupt(row, c, sims, self.t[sims] + k)
        self.G += n
        self.t[active] += n
        self.control_steps[active] += 1
        if self.timelines.specs:
            self.timelines.advance(np.flatnonzero(active))

    def _corrupt(self, row: np.ndarray, c: int, sims: np.ndarray, steps: np.ndarray) -> None:
        """Noise on channel c's samples of `sims` in history row `row` (nsim, width), in place."""
        if not sims.size:
            return
        lo, hi = self.cols[c], self.cols[c + 1]
        shape = self.channels[c].shape
        if sims.size == self.nsim:
            raw = row[:, lo:hi]
            row[:, lo:hi] = self.noise[c](raw.reshape(self.nsim, *shape), sims, steps).reshape(self.nsim, -1)
        else:
            raw = row[sims, lo:hi]
            row[sims, lo:hi] = self.noise[c](raw.reshape(sims.size, *shape), sims, steps).reshape(sims.size, -1)

    def _phases(self) -> np.ndarray:
        """Each simulation's read phase: steps since reset mod rows, in control steps; `nphase` at a reset."""
        return np.where(self.t == 0, self.nphase, (self.t % self.rows) // self.n)

    def _snapshot(self, gp: int) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the values this control step stores: in the records, and in the history (cached).

        Every substep of noisy and random-schedule columns; of the others, only the samples a later
        control step's read takes from the history (the current read takes its own from the records).
        """
        key = ("snapshot", gp)
        cached = self._cache.get(key)
        if cached is None:
            nsim, w, n = self.nsim, self.width, self.n
            phases = np.unique((self.t % self.rows) // n)
            sims = np.arange(nsim)[:, None]
            source, target = [], []
            for k in range(1, n + 1):
                cols = np.flatnonzero(self.always | self.later[phases, k - 1].any(axis=0))
                if not cols.size:
                    continue
                source.append((self.record_base[cols] + (k - 1) * self.record_step[cols]
                               + sims * self.record_stride[cols]).ravel())
                target.append(((gp + k - 1) * nsim * w + sims * w + cols).ravel())
            empty = np.zeros(0, np.intp)
            cached = self._cache[key] = (np.concatenate(source) if source else empty,
                                         np.concatenate(target) if target else empty)
        return cached

    def _plan(self, gp: int) -> list[list[tuple[int, np.ndarray]]]:
        """Per substep, the noisy fixed channels and the simulations that sample them (cached per phase)."""
        key = ("noise", gp)
        plan = self._cache.get(key)
        if plan is None:
            local = self.t % self.rows
            plan = [[] for _ in range(self.n)]
            for c in range(self.nfixed):
                if c not in self.noise:
                    continue
                ch = self.channels[c]
                period = ch.period()
                needed = np.zeros(period, bool)
                needed[ch.needed_phases()] = True
                for k in range(1, self.n + 1):
                    sims = np.flatnonzero(needed[(local + k) % period])
                    if sims.size:
                        plan[k - 1].append((c, sims))
            self._cache[key] = plan
        return plan

    # -- reads ------------------------------------------------------------------------------------

    def _gathers(self, gp: int) -> tuple[np.ndarray, list[np.ndarray]]:
        """Flat history positions of every read value, per simulation (cached per phase until a reset)."""
        fresh = bool((self.t == 0).any())  # a reset read: its phase is not the one gp implies later on
        cached = None if fresh else self._cache.get(("read", gp))
        if cached is None:
            rows, nsim, w = self.rows, self.nsim, self.width
            phases = self._phases()
            delta = np.vstack([self.delta, self.delta[:1]])  # the reset read: phase 0's, from the history
            sims = np.arange(nsim)[:, None]
            index = ((gp - 1 + delta[phases]) % rows) * (nsim * w) + sims * w + self.col[None, :]
            recent = self.from_record[phases]
            index[recent] = (self.record_read[phases] + sims * self.record_read_stride[None, :])[recent]
            plain = np.ascontiguousarray(index[:, self.plain_cols])
            groups = [np.ascontiguousarray(index[:, part].reshape(nsim, *block).transpose(1, 0, 2))
                      for _, part, block, _ in self.groups]
            cached = (plain, groups)
            if not fresh:
                self._cache[("read", gp)] = cached
        return cached

    def get_observation(self) -> dict[str, np.ndarray]:
        """Every observation of every simulation, (nsim, ...) arrays in the observables' order."""
        out: list[Any] = [None] * len(self.channels)
        if self.fixed:
            plain_index, group_index = self._gathers(self.G % self.rows)
            flat = self.flat
            gathered = flat.take(plain_index)
            for i, part, shape in self.plain:
                out[i] = gathered[:, part].reshape(shape)
            for (reduce, _, _, members), index in zip(self.groups, group_index):
                reduced = reduce(flat.take(index))
                for i, sub, shape in members:
                    out[i] = reduced[:, sub].reshape(self.nsim, *shape)
        if self.timelines.specs:
            self._read_drawn(out)
        return {name: out[self.output_index[name]] for name in self.names}

    def _read_drawn(self, out: list[Any]) -> None:
        windows = self.timelines.last
        nsim, w, rows = self.nsim, self.width, self.rows
        start = (self.G - self.t)[:, None]  # each simulation's reset, in global steps
        sims = (np.arange(nsim) * w)[:, None, None]
        for r, codes in enumerate(windows):
            c = self.nfixed + r
            ch = self.channels[c]
            step = codes - 1
            old = (codes > 1) & (self.t[:, None] - step >= rows)
            if old.any():
                raise RuntimeError(f"sensor {self.labels[c]!r}: a read reaches further back than the batch's "
                                   f"history of {rows} steps (an internal sizing error)")
            row = np.where(codes == 0, rows + 1, np.where(codes == 1, rows, (start + step - 1) % rows))
            index = row[:, :, None] * (nsim * w) + sims + np.arange(self.cols[c], self.cols[c + 1])
            values = self.flat.take(index)  # (nsim, buffer, width)
            if ch.aggregator is not None:
                reduced = _REDUCERS[ch.aggregator.name](np.ascontiguousarray(values.transpose(1, 0, 2)))
                out[c] = reduced.reshape(nsim, *ch.shape)
            elif ch.has_buffer_dim:
                out[c] = values.reshape(nsim, ch.buffer_size, *ch.shape)
            else:
                out[c] = values.reshape(nsim, *ch.shape)

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
