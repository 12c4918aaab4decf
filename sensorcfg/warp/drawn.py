"""Drawn intervals and delays on a Warp device: `runtime/drawn.py`'s stream rule, per world, step by step.

Sample j of a drawn sensor (j = 0: the reset sample, at step 0) is taken at step t_j = I_1 + ... + I_j and
delivered at a_j = t_j + D_j, where I_j and D_j are drawn from the uniform of sample j, stage 0, value 0,
lane 0 (intervals) or 1 (delays), under the schedule key (k0, k1 xor 2^63) of the sensor's episode key
(`draw`: `draws.UniformSteps.of_uniform` / `ChoiceSteps.of_uniform` of `philox`'s words). A read at step R
shows the last `buffer` samples delivered by R, in order of (arrival, time), padded before the first.

Per world and drawn sensor the device keeps the next sample's index and time and a ring of the latest
`ring` samples' (time, arrival); nothing is planned on the host, and every step launches the same kernels:

- `record(steps, mask, keys, due)`, after each physics step (before the noise): a world whose step is the next
  sample's time pushes it and draws the one after; at step 0 (a reset) the schedule restarts at sample 0
  with the episode's key. `due` (world, noisy sensor) tells the noise kernel whether this step is a sample
  (0: not one; else the steps since the previous sample, which a low-pass's coefficient depends on).
- `read(steps, history)`: each read's window from the ring (`windows`, -1 = padding), then its values
  gathered from the history (the row of step t is `t % rows`; padding: the reset sample, row 0, with
  `pad_with_initial_value`, else 0), which `gathered` holds per position (buffer, width) of each sensor.

Every sample of the schedule is recorded and noised at its step (stateful noise needs every sample, and a
stateless stage's numbers are a function of the sample alone), so the samples a read shows carry the noise
the CPU engines give them: sample index = step // stride (`NoiseProgram.stride`: 1 for a drawn interval).

The ring is long enough: a sample a read at R shows has t > R - (2 dmax + buffer imax) (the `buffer` samples
before R - dmax have all arrived, later than any sample older than that can), and at most W // imin + 1
samples fit in W steps; the history's `rows` (the plan's) cover `DrawnTiming.span`, so the rows of those
samples, and row 0 while a read still shows padding (before step dmax + buffer imax), are not yet reused.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import warp as wp

from ..plan import DrawnSteps, DrawnTiming, SuitePlan
from .philox import MODULE_OPTIONS, block, uniform

__all__ = ["DrawnSchedules", "DrawnView", "draw", "largest_gap", "ring_size"]

wp.set_module_options(MODULE_OPTIONS)

_SCHEDULE = wp.constant(wp.uint64(1 << 63))  # xor of a sensor key's second word: its schedule key
_LANE = wp.constant(wp.uint32(1 << 22))  # a lane's counter bits (stage 0)
_KINDS = {"fixed": 0, "uniform": 1, "choice": 2}  # 3: a choice with weights


@wp.func
def draw(kind: wp.int32, first: wp.int32, count: wp.int32, values: wp.array[wp.int64],
         cumulative: wp.array[wp.float64], k0: wp.uint64, k1: wp.uint64, j: wp.int64, lane: wp.uint32) -> wp.int64:
    """The draw of sample j, lane `lane`, of a setting (its `kind`, and `values[first:first + count]`,
    `cumulative` its cumulative weights) under sensor key (k0, k1): `UniformSteps.of_uniform` (low + floor(u
    n)) or `ChoiceSteps.of_uniform` (values[floor(u n)]; weighted: the first k with u < P_k) of the uniform u
    of sample j, stage 0, value 0 under the schedule key (k0, k1 xor 2^63)."""
    if kind == 0:
        return values[first]
    u = uniform(block(k0, k1 ^ _SCHEDULE, j, lane * _LANE, 0)[0])
    if kind == 1:
        low = values[first]
        return low + wp.int64(wp.floor(u * wp.float64(values[first + 1] - low + wp.int64(1))))
    if kind == 2:
        return values[first + wp.int32(wp.floor(u * wp.float64(count)))]
    k = wp.int32(0)
    for i in range(count):  # numpy's searchsorted(cumulative, u, side="right"), at most the last value
        if cumulative[first + i] <= u:
            k = k + 1
    return values[first + wp.min(k, count - 1)]


@wp.kernel
def _advance(steps: wp.array[wp.int64], mask: wp.array[wp.int32], keys: wp.array3d[wp.uint64],
             key_slot: wp.array[wp.int32], noisy: wp.array[wp.int32], setting: wp.array2d[wp.int32],
             values: wp.array[wp.int64], cumulative: wp.array[wp.float64], ring: wp.int32,
             next_j: wp.array2d[wp.int64], next_t: wp.array2d[wp.int64], times: wp.array3d[wp.int64],
             arrivals: wp.array3d[wp.int64], due: wp.array2d[wp.int32]):
    w, d = wp.tid()
    if mask[w] == 0:
        return
    s = steps[w]
    k0 = keys[w, key_slot[d], 0]
    k1 = keys[w, key_slot[d], 1]
    n = noisy[d]
    if s == wp.int64(0):  # a reset: sample 0 at step 0, the next after the first interval
        times[w, d, 0] = wp.int64(0)
        arrivals[w, d, 0] = draw(setting[d, 3], setting[d, 4], setting[d, 5], values, cumulative, k0, k1,
                                 wp.int64(0), wp.uint32(1))
        next_j[w, d] = wp.int64(1)
        next_t[w, d] = draw(setting[d, 0], setting[d, 1], setting[d, 2], values, cumulative, k0, k1,
                            wp.int64(1), wp.uint32(0))
        if n >= 0:
            due[w, n] = 1
        return
    if s != next_t[w, d]:
        if n >= 0:
            due[w, n] = 0
        return
    j = next_j[w, d]
    gap = s - times[w, d, wp.int32((j - wp.int64(1)) % wp.int64(ring))]
    slot = wp.int32(j % wp.int64(ring))
    times[w, d, slot] = s
    arrivals[w, d, slot] = s + draw(setting[d, 3], setting[d, 4], setting[d, 5], values, cumulative, k0, k1, j,
                                    wp.uint32(1))
    next_j[w, d] = j + wp.int64(1)
    next_t[w, d] = s + draw(setting[d, 0], setting[d, 1], setting[d, 2], values, cumulative, k0, k1,
                            j + wp.int64(1), wp.uint32(0))
    if n >= 0:
        due[w, n] = wp.int32(gap)


@wp.kernel
def _windows(steps: wp.array[wp.int64], buffer: wp.array[wp.int32], ring: wp.int32, next_j: wp.array2d[wp.int64],
             times: wp.array3d[wp.int64], arrivals: wp.array3d[wp.int64], windows: wp.array3d[wp.int64]):
    """Window entries buffer - 1, buffer - 2, ...: each the latest (arrival, time) delivered by the read's step
    before the entry after it; -1 once none is left (padding)."""
    w, d = wp.tid()
    read = steps[w]
    last = next_j[w, d]
    first = wp.max(last - wp.int64(ring), wp.int64(0))
    bound_a = read + wp.int64(1)  # entries are below (bound_a, bound_t), in (arrival, time) order
    bound_t = wp.int64(0)
    b = buffer[d]
    for i in range(b):
        best_a = wp.int64(-1)
        best_t = wp.int64(-1)
        for k in range(wp.int32(last - first)):
            slot = wp.int32((first + wp.int64(k)) % wp.int64(ring))
            a = arrivals[w, d, slot]
            t = times[w, d, slot]
            if a <= read and (a < bound_a or (a == bound_a and t < bound_t)):
                if a > best_a or (a == best_a and t > best_t):
                    best_a = a
                    best_t = t
        windows[w, d, b - 1 - i] = best_t
        if best_t >= wp.int64(0):
            bound_a = best_a
            bound_t = best_t
        else:
            bound_a = wp.int64(-1)  # nothing below: padding from here on


@wp.kernel
def _gather(windows: wp.array3d[wp.int64], sensor: wp.array[wp.int32], entry: wp.array[wp.int32],
            column: wp.array[wp.int32], rows: wp.int32, pad: wp.int32, history: wp.array3d[wp.float32],
            out: wp.array2d[wp.float32]):
    w, p = wp.tid()
    t = windows[w, sensor[p], entry[p]]
    if t >= wp.int64(0):
        out[w, p] = history[w, wp.int32(t % wp.int64(rows)), column[p]]
    elif pad == 1:
        out[w, p] = history[w, 0, column[p]]  # the reset sample (with its noise)
    else:
        out[w, p] = wp.float32(0.0)


def _setting(steps: DrawnSteps, values: list[int], cumulative: list[float]) -> tuple[int, int, int]:
    """A setting's (kind, first, count) in the tables `values` and `cumulative` (appended to)."""
    kind = _KINDS[steps.kind] + int(steps.kind == "choice" and steps.weights.size > 0)
    first = len(values)
    values += [int(v) for v in steps.values]
    cumulative += np.cumsum(steps.weights).tolist() if kind == 3 else [0.0] * len(steps.values)
    return kind, first, len(steps.values)


def _extreme(steps: DrawnSteps, largest: bool) -> int:
    values = steps.values[:2] if steps.kind == "uniform" else steps.values
    return int(values.max() if largest else values.min())


def ring_size(timing: DrawnTiming) -> int:
    """Samples a world keeps of a drawn sensor: every one a read may still show (see the module's doc)."""
    dmax, imax = _extreme(timing.delay, True), _extreme(timing.interval, True)
    return (2 * dmax + timing.buffer * imax) // max(1, _extreme(timing.interval, False)) + 1


def largest_gap(timing: DrawnTiming) -> int:
    """The most steps between two consecutive samples (a low-pass's coefficients are tabled up to it)."""
    return _extreme(timing.interval, True)


class DrawnView(NamedTuple):
    """Where a drawn sensor's read is: `table` ("gathered" or "reduced") columns from `first` on."""

    sensor: int
    table: str
    first: int


class DrawnSchedules:
    """The plan's drawn sensors over `plan.nsim` worlds on `device`. `key_slot`: per drawn sensor's name, its
    episode key's index in the engine's keys; `noisy`: its index among the noisy sensors (absent: clean)."""

    def __init__(self, plan: SuitePlan, device: wp.Device, key_slot: Mapping[str, int], noisy: Mapping[str, int]):
        self.plan, self.device = plan, device
        drawn = [(i, s) for i, s in enumerate(plan.sensors) if isinstance(s.timing, DrawnTiming)]
        self.names = [s.name for _, s in drawn]
        values: list[int] = []
        cumulative: list[float] = []
        setting: list[list[int]] = []
        buffers: list[int] = []
        rings: list[int] = []
        sensor: list[int] = []
        entry: list[int] = []
        column: list[int] = []
        self.views: list[DrawnView] = []
        self.blocks: list[tuple[int, int, int, str, int]] = []  # (first position, buffer, width, aggregator, column)
        at = reduced = 0
        for d, (index, record) in enumerate(drawn):
            timing = record.timing
            assert isinstance(timing, DrawnTiming)
            setting.append([*_setting(timing.interval, values, cumulative),
                            *_setting(timing.delay, values, cumulative)])
            buffers.append(timing.buffer)
            rings.append(ring_size(timing))
            lo, hi = record.columns
            width = hi - lo
            for b in range(timing.buffer):  # positions (buffer, width): oldest entry first
                sensor += [d] * width
                entry += [b] * width
                column += range(lo, hi)
            if record.aggregator is None:
                self.views.append(DrawnView(index, "gathered", at))
            else:
                self.blocks.append((at, timing.buffer, width, record.aggregator, reduced))
                self.views.append(DrawnView(index, "reduced", reduced))
                reduced += width
            at += timing.buffer * width
        n, m = plan.nsim, len(drawn)
        i32 = lambda xs: wp.array(np.asarray(xs, np.int32).reshape(-1), dtype=wp.int32)  # noqa: E731
        self.ring = max(rings)
        with wp.ScopedDevice(device):
            self._key_slot = i32([key_slot[name] for name in self.names])
            self._noisy = i32([noisy.get(name, -1) for name in self.names])
            self._setting = wp.array(np.asarray(setting, np.int32).reshape(m, 6), dtype=wp.int32)
            self._values = wp.array(np.asarray(values, np.int64), dtype=wp.int64)
            self._cumulative = wp.array(np.asarray(cumulative, np.float64), dtype=wp.float64)
            self._buffer = i32(buffers)
            self._sensor, self._entry, self._column = i32(sensor), i32(entry), i32(column)
            self.next_j = wp.zeros((n, m), dtype=wp.int64)
            self.next_t = wp.zeros((n, m), dtype=wp.int64)
            self.times = wp.zeros((n, m, self.ring), dtype=wp.int64)
            self.arrivals = wp.zeros((n, m, self.ring), dtype=wp.int64)
            self.windows = wp.zeros((n, m, max(buffers)), dtype=wp.int64)
            self.gathered = wp.zeros((n, at), dtype=wp.float32)
            self.reduced = wp.zeros((n, max(1, reduced)), dtype=wp.float32)

    def record(self, steps: wp.array, mask: wp.array, keys: wp.array, due: wp.array) -> None:
        """After a physics step of the worlds of `mask`: each drawn sensor's sample at that step, if any
        (`due`, (world, noisy sensor), says so to the noise kernel); at step 0 the schedule restarts."""
        wp.launch(_advance, dim=(self.plan.nsim, len(self.names)),
                  inputs=[steps, mask, keys, self._key_slot, self._noisy, self._setting, self._values,
                          self._cumulative, self.ring, self.next_j, self.next_t, self.times, self.arrivals, due],
                  device=self.device)

    def read(self, steps: wp.array, history: wp.array) -> None:
        """Every drawn sensor's window at each world's step `steps`, its values into `gathered`."""
        n = self.plan.nsim
        wp.launch(_windows, dim=(n, len(self.names)),
                  inputs=[steps, self._buffer, self.ring, self.next_j, self.times, self.arrivals],
                  outputs=[self.windows], device=self.device)
        wp.launch(_gather, dim=(n, self._column.shape[0]),
                  inputs=[self.windows, self._sensor, self._entry, self._column, self.plan.rows,
                          int(self.plan.pad_with_initial_value), history],
                  outputs=[self.gathered], device=self.device)
