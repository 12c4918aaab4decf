"""One enabled observable at run time: when it samples, where samples wait, what a read returns.

Semantics are dm_control's: samples are taken at steps `0, i1, i1+i2, ...`, each is delivered `delay`
steps later, a read at step R returns the last `buffer_size` delivered samples in order of delivery
(ties in order of sampling), padded with zeros, or with the first sample when `pad_with_initial_value`.
Reads happen every `substeps` steps (once per control step). A sample that is pushed out of the
buffer before any read can see it is never taken.

`FixedChannel` handles constant integer interval and delay: which steps must sample is periodic, so it
is computed once, and samples live in a ring sized by buffer and delay, never by episode length.
`RandomChannel` handles intervals or delays drawn per sample by callables; it plans ahead exactly as
dm_control does (the same draws, in the same order) and skips what it can prove unobservable.
"""

from __future__ import annotations

import collections
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple, cast

import numpy as np

from ..draws import as_draw
from ..plan.bound import Entry, bind_sensor, buffered_shape, every_sample, has_buffer_dim
from ..plan.drawn import Drawn, Planner, Round, chunk_steps
from ..plan.schedule import Schedule, history_rows

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline

__all__ = ["Channel", "ChannelSpec", "DrawnChannel", "FixedChannel", "RandomChannel", "channel_of", "make_channel"]

Sampler = Callable[[], Any]


class ChannelSpec(NamedTuple):
    """What a channel is, apart from its schedule: built by `channel_of`, shared by every channel type."""

    name: str
    sampler: Sampler
    read_into: Callable[[np.ndarray], None] | None  # writes a sample into a buffer row (features)
    shape: tuple[int, ...]
    dtype: np.dtype
    buffer_size: int
    strip: bool  # strip_singleton_buffer_dim
    pad: bool  # pad_with_initial_value
    substeps: int  # physics steps per control step: reads happen every `substeps` steps
    aggregator: Callable[[np.ndarray], Any] | None
    builtin_aggregator: bool
    noise: NoisePipeline | None
    key: np.ndarray  # the sensor's episode key (`draws.sensor_key`): its noise streams and drawn schedule


class Channel:
    """Shared parts: the sampler, the output shape and the aggregation."""

    def __init__(self, spec: ChannelSpec):
        self.spec = spec
        self.name = spec.name
        self.sampler = spec.sampler
        self.read_into = spec.read_into if spec.noise is None else None
        self.shape = tuple(spec.shape)
        self.dtype = np.dtype(spec.dtype)
        self.buffer_size = spec.buffer_size
        self.has_buffer_dim = has_buffer_dim(spec.buffer_size, spec.strip)
        self.buffered_shape = buffered_shape(self.shape, spec.buffer_size, spec.strip)
        self.pad = spec.pad
        self.substeps = spec.substeps
        self.aggregator = spec.aggregator
        self.builtin_aggregator = spec.builtin_aggregator
        self.noise = spec.noise
        self.key = spec.key
        self.every_sample = every_sample(spec.noise)  # stateful noise sees every sample of the schedule
        self.samples = 0

    def value(self, step: int) -> Any:
        """One processed sample (sampler, then the noise pipeline)."""
        self.samples += 1
        value = self.sampler()
        if self.noise is not None:
            value = self.noise(np.asarray(value), step)
        return value

    def finish(self, window: np.ndarray) -> Any:
        """What a read returns for `window` (a view into the channel's storage)."""
        if self.aggregator is None:
            return window.copy()
        if self.builtin_aggregator:
            return self.aggregator(window)
        return self.aggregator(window.copy())


class FixedChannel(Channel):
    """Constant integer interval and delay: a periodic sampling pattern and a ring of samples."""

    def __init__(self, spec: ChannelSpec, *, interval: int, delay: int):
        super().__init__(spec)
        self.interval = interval
        self.delay = delay
        self.schedule = Schedule(interval, delay, self.buffer_size, self.substeps, self.every_sample)
        # Samples in flight (taken, not yet delivered) plus the visible window fit in `capacity` slots.
        self.capacity = self.schedule.capacity
        self.doubled = self.buffer_size > 1  # each sample is stored twice so every window is one contiguous slice
        # allocated at the first `start`: a channel the feature bank runs never holds samples of its own
        self.ring = np.zeros((0,) + self.shape, dtype=self.dtype)
        self.rows: list[np.ndarray] = []

    def period(self) -> int:
        return self.schedule.period

    def needed_phases(self) -> list[int]:
        """Steps t in [0, period) at which a sample is needed (t > 0 steps; t = 0 is the reset sample)."""
        return self.schedule.needed_phases()

    def start(self, step: int) -> None:
        """The reset sample (always taken: it also pads the buffer when asked)."""
        if not self.rows:
            c = self.capacity
            self.ring = np.zeros(((2 * c) if self.doubled else c,) + self.shape, dtype=self.dtype)
            self.rows = [self.ring[i:i + 1].reshape(self.shape) for i in range(len(self.ring))]  # views, also 0-d
        value = self.value(step)
        if self.pad:
            self.ring[...] = value
        else:
            self.ring[...] = 0
        self._store(0, value)

    def _store(self, k: int, value: Any) -> None:
        slot = self.schedule.slot(k)
        self.rows[slot][...] = value
        if self.doubled:
            self.rows[slot + self.capacity][...] = self.rows[slot]

    def sample(self, step: int) -> None:
        slot = self.schedule.slot(step // self.interval)
        if self.read_into is not None:
            self.samples += 1
            row = self.rows[slot]
            self.read_into(row)
            if self.doubled:
                self.rows[slot + self.capacity][...] = row
        else:
            self._store(step // self.interval, self.value(step))

    def read(self, step: int) -> Any:
        start = self.schedule.slot(self.schedule.window_start(step))
        if self.has_buffer_dim:
            return self.finish(self.ring[start:start + self.buffer_size])
        return self.finish(self.rows[start])  # a 0-d array for scalar samples, as dm_control returns


class RandomChannel(Channel):
    """Interval and/or delay drawn per sample: dm_control's scheduling and dropping, to the sample.

    `draw_ahead` extends the drawn schedule (`scheduled`) to two control steps ahead, drawing (interval, delay)
    pairs in dm_control's order; it then drops every scheduled sample that is provably pushed out of the buffer
    before its first read. Dropping is exactly dm_control's (and so is its side effect: when the last
    scheduled sample is dropped, the next draws continue from the last one kept), so sample times,
    samples taken and every draw agree with dm_control's.
    """

    def __init__(self, spec: ChannelSpec, *, interval: Callable[[], int], delay: Callable[[], int]):
        super().__init__(spec)
        self.draw_interval = interval
        self.draw_delay = delay
        self.scheduled: list[tuple[int, int]] = []  # (timestamp, delay), increasing timestamps
        self.pending: list[tuple[int, int, np.ndarray]] = []  # (arrival, timestamp, value), delivery order
        self.arrived: collections.deque[np.ndarray] = collections.deque(maxlen=self.buffer_size)

    def start(self, step: int) -> None:
        delay = self.draw_delay()
        value = np.array(self.value(step), dtype=self.dtype)
        fill = value if self.pad else np.zeros(self.shape, self.dtype)
        self.arrived.extend(fill for _ in range(self.buffer_size))
        self._insert(step, delay, value)

    def draw_ahead(self, step: int) -> None:
        """Extend the drawn schedule two control steps ahead, then drop the samples no read can see."""
        scheduled = self.scheduled
        last = scheduled[-1][0] if scheduled else step
        horizon = step + 2 * self.substeps
        while last < horizon:
            last += self.draw_interval()  # interval first, then delay, as dm_control draws them
            scheduled.append((last, self.draw_delay()))
        self._drop_unobserved()

    def _drop_unobserved(self) -> None:
        """Drop scheduled samples with `buffer_size` or more samples delivered after them by their first read.

        Delivery order is arrival order, ties going to the earlier insertion: samples already in flight
        come before scheduled ones, and scheduled ones in timestamp order. A sample arriving at `a` is
        first read at the end of its read window ceil(a / substeps); what is delivered after it by then arrived
        in the same window, later in that order. So: per window, keep the last `buffer_size` samples.
        """
        if self.every_sample:  # stateful noise: every scheduled sample is taken
            return
        substeps, b = self.substeps, self.buffer_size
        scheduled = self.scheduled
        order = sorted((-(-(t + d) // substeps), t + d, j) for j, (t, d) in enumerate(scheduled))
        in_flight: dict[int, list[int]] = {}
        for a, _, _ in self.pending:
            in_flight.setdefault(-(-a // substeps), []).append(a)
        drop: list[int] = []
        count = len(order)
        k = 0
        while k < count:  # one window at a time: order[k:m]
            window = order[k][0]
            m = k + 1
            while m < count and order[m][0] == window:
                m += 1
            drop.extend(_window_drops(order[k:m], b, in_flight.get(window, [])))
            k = m
        if drop:
            dropped = set(drop)
            self.scheduled = [entry for j, entry in enumerate(scheduled) if j not in dropped]

    def due(self, step: int) -> bool:
        return bool(self.scheduled) and self.scheduled[0][0] == step

    def sample(self, step: int) -> None:
        """Take the sample scheduled at `step` (the caller checked `due`)."""
        _, delay = self.scheduled.pop(0)
        self._insert(step, delay, np.array(self.value(step), dtype=self.dtype))

    def maybe_sample(self, step: int) -> None:
        if self.due(step):
            self.sample(step)

    def _insert(self, step: int, delay: int, value: np.ndarray) -> None:
        self._deliver(step)
        arrival = step + delay
        if delay == 0:
            self.arrived.append(value)
            return
        pending = self.pending
        i = len(pending)
        while i and pending[i - 1][0] > arrival:
            i -= 1
        pending.insert(i, (arrival, step, value))

    def _deliver(self, step: int) -> None:
        pending = self.pending
        count = 0
        while count < len(pending) and pending[count][0] <= step:
            self.arrived.append(pending[count][2])
            count += 1
        if count:
            del pending[:count]

    def read(self, step: int) -> Any:
        self._deliver(step)
        if self.has_buffer_dim:
            return self.finish(np.stack(self.arrived))
        return self.finish(self.arrived[0])


class DrawnChannel(Channel):
    """Interval and/or delay drawn by sensorcfg's own draws: planned in rounds by the stream rule of
    `plan/drawn.py`, samples taken per sample by the channel's sampler (the per-sample path; plain
    float64 features join `runtime/planned.DrawnBank` instead)."""

    def __init__(self, spec: ChannelSpec, *, drawn: Drawn):
        super().__init__(spec)
        self.drawn = drawn._replace(every_sample=self.every_sample)
        self.chunk = self.rows = 0  # the per-sample path's round and history lengths, set at `start`
        self.fill: Any = None
        # the per-sample path's rounds and samples, made at `start` (a channel the bank runs needs none)
        self.need = np.zeros(0, bool)
        self.windows = np.zeros((0, self.buffer_size), np.int64)
        self.values: list[Any] = []
        self.planner: Planner | None = None

    def store(self, first: Round | None, rounds: list[Round], base: int) -> None:
        """Record planned rounds: each round's reads (the first read of `rounds[i]` follows `base + i *
        chunk`) and the samples to take."""
        n, slots = self.substeps, len(self.windows)
        if first is not None:
            self.windows[0] = first.windows[0, 0]
        for i, round_ in enumerate(rounds):
            read = (base + i * self.chunk) // n + 1
            self.windows[(read + np.arange(round_.windows.shape[1])) % slots] = round_.windows[0]
            self.need[round_.take_step % self.rows] = True

    def start(self, step: int) -> None:
        if self.planner is None:  # (a channel the bank runs is never started: it needs none of this)
            self.chunk = chunk_steps([self.drawn], self.substeps)
            self.rows = history_rows([], self.substeps, reach=self.drawn.span + self.chunk + 1, ahead=self.chunk)
            self.need = np.zeros(self.rows, bool)
            self.windows = np.full((self.rows // self.substeps, self.buffer_size), -1, np.int64)
            self.values = [None] * self.rows
            self.planner = Planner(self.drawn, 1)
        self.need[:] = False
        first = self.planner.start(_ZERO, [self.key])
        self.store(first, [self.planner.round(_ZERO, self.chunk) for _ in range(2)], 0)
        value = np.array(self.value(step), dtype=self.dtype)
        self.fill = value if self.pad else np.zeros(self.shape, self.dtype)
        self.values[0] = value

    def draw_ahead(self, step: int) -> None:
        """Before the control step after `step`: at a round's start, plan the round after next."""
        if step and step % self.chunk == 0:
            self.store(None, [cast(Planner, self.planner).round(_ZERO, self.chunk)], step + self.chunk)

    def due(self, step: int) -> bool:
        return bool(self.need[step % self.rows])

    def sample(self, step: int) -> None:
        row = step % self.rows
        self.need[row] = False
        self.values[row] = np.array(self.value(step), dtype=self.dtype)

    def maybe_sample(self, step: int) -> None:
        if self.due(step):
            self.sample(step)

    def read(self, step: int) -> Any:
        window = self.windows[(step // self.substeps) % len(self.windows)]
        values = [self.values[t % self.rows] if t >= 0 else self.fill for t in window.tolist()]
        if self.has_buffer_dim:
            return self.finish(np.stack(values))
        return self.finish(values[0])


_ZERO = np.zeros(1, np.intp)


def _window_drops(window: list[tuple[int, int, int]], b: int, flight: list[int]) -> list[int]:
    """The scheduled samples of one read window ((window, arrival, index) in delivery order) that `b` or
    more samples delivered after them push out before the window's read (`flight`: arrivals in flight)."""
    keep_from = max(0, len(window) - b)  # the rest have b or more scheduled samples after them
    drop = [index for _, _, index in window[:keep_from]]
    for i in range(keep_from, len(window)) if flight else ():
        arrival = window[i][1]
        if len(window) - i - 1 + sum(1 for a in flight if a > arrival) >= b:
            drop.append(window[i][2])
    return drop


def make_channel(label: str, observable: Any, physics: Any, random_state: np.random.RandomState | None,
                 entropy: list[int] | None, substeps: int, strip: bool,
                 pad: bool) -> FixedChannel | RandomChannel | DrawnChannel:
    """Bind `observable` to `physics` (`plan.bound.bind_sensor`, every engine's one way) and build its channel
    for an episode: the Updater's one way to turn an observable into a channel. `entropy` keys the sensor's
    noise streams (`draws.sensor_key`); `random_state` is the episode's, given to the observable and to schedule
    callables that take it."""
    return channel_of(bind_sensor(label, observable, physics, random_state, entropy, substeps, strip), substeps, pad)


def channel_of(sensor: Entry, substeps: int, pad: bool) -> FixedChannel | RandomChannel | DrawnChannel:
    """The channel type of a bound observable's schedule: sensorcfg's draws follow the planned stream rule
    (`plan/drawn.py`), other callables dm_control's planning, constants the closed form."""
    sampler = sensor.sampler
    spec = ChannelSpec(sensor.name, sampler, getattr(sampler, "read_into", None), sensor.shape, sensor.dtype,
                       sensor.buffer_size, not sensor.has_buffer_dim, pad, substeps, sensor.aggregator,
                       sensor.builtin_aggregator, sensor.noise, sensor.key)
    schedule = sensor.schedule
    if isinstance(schedule, Drawn):
        return DrawnChannel(spec, drawn=schedule)
    if schedule is None:
        return RandomChannel(spec, interval=as_draw(sensor.interval), delay=as_draw(sensor.delay))
    return FixedChannel(spec, interval=schedule.interval, delay=schedule.delay)
