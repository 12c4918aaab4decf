"""One enabled observable at run time: when it samples, where samples wait, what a read returns.

Semantics are dm_control's: samples are taken at steps `0, i1, i1+i2, ...`, each is delivered `delay`
steps later, a read at step R returns the last `buffer_size` delivered samples in order of delivery
(ties in order of sampling), padded with zeros, or with the first sample when `pad_with_initial_value`.
Reads happen every `read_interval` steps (once per control step). A sample that is pushed out of the
buffer before any read can see it is never taken.

`FixedChannel` handles constant integer interval and delay: which steps must sample is periodic, so it
is computed once, and samples live in a ring sized by buffer and delay, never by episode length.
`RandomChannel` handles intervals or delays drawn per sample by callables; it plans ahead exactly as
dm_control does (the same draws, in the same order) and skips what it can prove unobservable.
"""

from __future__ import annotations

import collections
from collections.abc import Callable
from typing import Any

import numpy as np

from .schedule import Schedule

__all__ = ["Channel", "FixedChannel", "RandomChannel"]

Sampler = Callable[[], Any]


class Channel:
    """Shared parts: the sampler, the output shape and the aggregation."""

    def __init__(self, name: str, sampler: Sampler, read_into: Callable[[np.ndarray], None] | None,
                 shape: tuple[int, ...], dtype: np.dtype, buffer_size: int, strip: bool, pad: bool,
                 read_interval: int, aggregator: Callable[[np.ndarray], Any] | None,
                 builtin_aggregator: bool, noise: Any):
        self.name = name
        self.sampler = sampler
        self.read_into = read_into if noise is None else None
        self.shape = tuple(shape)
        self.dtype = np.dtype(dtype)
        self.buffer_size = buffer_size
        self.has_buffer_dim = not (strip and buffer_size == 1)
        self.buffered_shape = ((buffer_size,) if self.has_buffer_dim else ()) + self.shape
        self.pad = pad
        self.read_interval = read_interval
        self.aggregator = aggregator
        self.builtin_aggregator = builtin_aggregator
        self.noise = noise
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
    """Constant integer interval and delay: a periodic plan and a ring of samples."""

    def __init__(self, *args: Any, interval: int, delay: int, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.interval = interval
        self.delay = delay
        self.schedule = Schedule(interval, delay, self.buffer_size, self.read_interval)
        # Samples in flight (taken, not yet delivered) plus the visible window fit in `capacity` slots.
        self.capacity = c = self.schedule.capacity
        self.doubled = self.buffer_size > 1  # each sample is stored twice so every window is one contiguous slice
        self.ring = np.zeros(((2 * c) if self.doubled else c,) + self.shape, dtype=self.dtype)
        self.rows = [self.ring[i:i + 1].reshape(self.shape) for i in range(len(self.ring))]  # views, also 0-d

    def period(self) -> int:
        return self.schedule.period

    def needed_phases(self) -> list[int]:
        """Steps t in [0, period) at which a sample is needed (t > 0 steps; t = 0 is the reset sample)."""
        return self.schedule.needed_phases()

    def start(self, step: int) -> None:
        """The reset sample (always taken: it also pads the buffer when asked)."""
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
    """Interval and/or delay drawn per sample: dm_control's planning and dropping, to the sample.

    Planning extends the schedule to two control steps ahead, drawing (interval, delay) pairs in
    dm_control's order; it then drops every scheduled sample that is provably pushed out of the buffer
    before its first read. Dropping is exactly dm_control's (and so is its side effect: when the last
    scheduled sample is dropped, the next plan continues from the last one kept), so sample times,
    samples taken and every draw agree with dm_control's.
    """

    def __init__(self, *args: Any, interval: Callable[[], int], delay: Callable[[], int], **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.draw_interval = interval
        self.draw_delay = delay
        self.schedule: list[tuple[int, int]] = []  # (timestamp, delay), increasing timestamps
        self.pending: list[tuple[int, int, np.ndarray]] = []  # (arrival, timestamp, value), delivery order
        self.arrived: collections.deque[np.ndarray] = collections.deque(maxlen=self.buffer_size)

    def start(self, step: int) -> None:
        delay = self.draw_delay()
        value = np.array(self.value(step), dtype=self.dtype)
        fill = value if self.pad else np.zeros(self.shape, self.dtype)
        self.arrived.extend(fill for _ in range(self.buffer_size))
        self._insert(step, delay, value)

    def plan(self, step: int) -> None:
        """Extend the schedule two control steps ahead, then drop the samples no read can see."""
        schedule = self.schedule
        last = schedule[-1][0] if schedule else step
        horizon = step + 2 * self.read_interval
        while last < horizon:
            last += self.draw_interval()  # interval first, then delay, as dm_control draws them
            schedule.append((last, self.draw_delay()))
        self._drop_unobserved()

    def _drop_unobserved(self) -> None:
        """Drop scheduled samples with `buffer_size` or more samples delivered after them by their first read.

        Delivery order is arrival order, ties going to the earlier insertion: samples already in flight
        come before scheduled ones, and scheduled ones in timestamp order. A sample arriving at `a` is
        first read at the end of its read window ceil(a / n); what is delivered after it by then arrived
        in the same window, later in that order. So: per window, keep the last `buffer_size` samples.
        """
        n, b = self.read_interval, self.buffer_size
        schedule = self.schedule
        order = sorted((-(-(t + d) // n), t + d, j) for j, (t, d) in enumerate(schedule))
        in_flight: dict[int, list[int]] = {}
        for a, _, _ in self.pending:
            in_flight.setdefault(-(-a // n), []).append(a)
        drop: list[int] = []
        count = len(order)
        k = 0
        while k < count:  # one window at a time: order[k:m]
            window = order[k][0]
            m = k + 1
            while m < count and order[m][0] == window:
                m += 1
            keep_from = max(k, m - b)  # the rest have b or more scheduled samples after them
            drop.extend(order[i][2] for i in range(k, keep_from))
            flight = in_flight.get(window)
            if flight:
                for i in range(keep_from, m):
                    arrival = order[i][1]
                    if m - i - 1 + sum(1 for a in flight if a > arrival) >= b:
                        drop.append(order[i][2])
            k = m
        if drop:
            dropped = set(drop)
            self.schedule = [entry for j, entry in enumerate(schedule) if j not in dropped]

    def due(self, step: int) -> bool:
        return bool(self.schedule) and self.schedule[0][0] == step

    def sample(self, step: int) -> None:
        """Take the sample scheduled at `step` (the caller checked `due`)."""
        _, delay = self.schedule.pop(0)
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
        n = 0
        while n < len(pending) and pending[n][0] <= step:
            self.arrived.append(pending[n][2])
            n += 1
        if n:
            del pending[:n]

    def read(self, step: int) -> Any:
        self._deliver(step)
        if self.has_buffer_dim:
            return self.finish(np.stack(self.arrived))
        return self.finish(self.arrived[0])
