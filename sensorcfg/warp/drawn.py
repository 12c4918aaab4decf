"""Drawn intervals and delays on a Warp device: `plan/drawn.py`'s stream rule, per world, step by step.

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

__all__ = ["AGGREGATORS", "DrawnPositions", "DrawnRing", "DrawnSchedules", "DrawnSetting", "DrawnTimings", "DrawnView",
           "Reduction", "draw", "largest_gap", "reduction", "ring_size"]

wp.set_module_options(MODULE_OPTIONS)

_SCHEDULE = wp.constant(wp.uint64(1 << 63))  # xor of a sensor key's second word: its schedule key
_LANE = wp.constant(wp.uint32(1 << 22))  # a lane's counter bits (stage 0)
_KINDS = {"fixed": 0, "uniform": 1, "choice": 2}  # 3: a choice with weights


@wp.struct
class DrawnSetting:
    """A drawn interval's or delay's `DrawnSteps` as `draw` reads it: its `kind` code (`_KINDS`; 3: a choice
    with weights) and its values at `first` .. `first + count` of `DrawnTimings`' shared `values` and
    `cumulative` (its cumulative weights)."""

    kind: wp.int32
    first: wp.int32
    count: wp.int32


@wp.struct
class DrawnTimings:
    """Per drawn sensor, its plan's `DrawnTiming` as the kernels read it: its episode key's index in the keys
    (`key_slot`), its index among the noisy sensors (`noisy`, -1: clean), its `buffer`, and its `interval`'s
    and `delay`'s `DrawnSetting` in the shared `values` and `cumulative`."""

    key_slot: wp.array[wp.int32]
    noisy: wp.array[wp.int32]
    buffer: wp.array[wp.int32]
    interval: wp.array[DrawnSetting]
    delay: wp.array[DrawnSetting]
    values: wp.array[wp.int64]
    cumulative: wp.array[wp.float64]


@wp.func
def draw(setting: DrawnSetting, timings: DrawnTimings, k0: wp.uint64, k1: wp.uint64, j: wp.int64,
         lane: wp.uint32) -> wp.int64:
    """The draw of sample j, lane `lane`, of a `setting` (in `timings`' `values` and `cumulative`) under
    sensor key (k0, k1): `UniformSteps.of_uniform` (low + floor(u n)) or `ChoiceSteps.of_uniform` (values[floor(u
    n)]; weighted: the first k with u < P_k) of the uniform u of sample j, stage 0, value 0 under the schedule
    key (k0, k1 xor 2^63)."""
    kind = setting.kind
    first = setting.first
    count = setting.count
    values = timings.values
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
        if timings.cumulative[first + i] <= u:
            k = k + 1
    return values[first + wp.min(k, count - 1)]


@wp.struct
class DrawnRing:
    """Per world and drawn sensor: the next sample's index and time, and the latest `ring` samples' times and
    arrivals (sample j at slot j % ring)."""

    ring: wp.int32
    next_j: wp.array2d[wp.int64]
    next_t: wp.array2d[wp.int64]
    times: wp.array3d[wp.int64]
    arrivals: wp.array3d[wp.int64]


@wp.struct
class DrawnPositions:
    """Per gathered position of the drawn sensors' reads (buffer, width each): its drawn sensor, window entry
    and history column."""

    sensor: wp.array[wp.int32]
    entry: wp.array[wp.int32]
    column: wp.array[wp.int32]


@wp.func
def _interval(timings: DrawnTimings, d: wp.int32, k0: wp.uint64, k1: wp.uint64, j: wp.int64) -> wp.int64:
    """Drawn sensor d's interval before sample j (lane 0)."""
    return draw(timings.interval[d], timings, k0, k1, j, wp.uint32(0))


@wp.func
def _delay(timings: DrawnTimings, d: wp.int32, k0: wp.uint64, k1: wp.uint64, j: wp.int64) -> wp.int64:
    """Drawn sensor d's delay of sample j (lane 1)."""
    return draw(timings.delay[d], timings, k0, k1, j, wp.uint32(1))


@wp.kernel
def _advance(
    # In:
    steps: wp.array[wp.int64], mask: wp.array[wp.int32], keys: wp.array3d[wp.uint64], timings: DrawnTimings,
    # Out:
    ring: DrawnRing, due: wp.array2d[wp.int32],
):
    w, d = wp.tid()
    if mask[w] == 0:
        return
    s = steps[w]
    k0 = keys[w, timings.key_slot[d], 0]
    k1 = keys[w, timings.key_slot[d], 1]
    n = timings.noisy[d]
    if s == wp.int64(0):  # a reset: sample 0 at step 0, the next after the first interval
        ring.times[w, d, 0] = wp.int64(0)
        ring.arrivals[w, d, 0] = _delay(timings, d, k0, k1, wp.int64(0))
        ring.next_j[w, d] = wp.int64(1)
        ring.next_t[w, d] = _interval(timings, d, k0, k1, wp.int64(1))
        if n >= 0:
            due[w, n] = 1
        return
    if s != ring.next_t[w, d]:
        if n >= 0:
            due[w, n] = 0
        return
    j = ring.next_j[w, d]
    gap = s - ring.times[w, d, wp.int32((j - wp.int64(1)) % wp.int64(ring.ring))]
    slot = wp.int32(j % wp.int64(ring.ring))
    ring.times[w, d, slot] = s
    ring.arrivals[w, d, slot] = s + _delay(timings, d, k0, k1, j)
    ring.next_j[w, d] = j + wp.int64(1)
    ring.next_t[w, d] = s + _interval(timings, d, k0, k1, j + wp.int64(1))
    if n >= 0:
        due[w, n] = wp.int32(gap)


@wp.kernel
def _windows(
    # In:
    steps: wp.array[wp.int64], timings: DrawnTimings, ring: DrawnRing,
    # Out:
    windows: wp.array3d[wp.int64],
):
    """Window entries buffer - 1, buffer - 2, ...: each the latest (arrival, time) delivered by the read's step
    before the entry after it; -1 once none is left (padding)."""
    w, d = wp.tid()
    read = steps[w]
    last = ring.next_j[w, d]
    first = wp.max(last - wp.int64(ring.ring), wp.int64(0))
    bound_a = read + wp.int64(1)  # entries are below (bound_a, bound_t), in (arrival, time) order
    bound_t = wp.int64(0)
    b = timings.buffer[d]
    for i in range(b):
        best_a = wp.int64(-1)
        best_t = wp.int64(-1)
        for k in range(wp.int32(last - first)):
            slot = wp.int32((first + wp.int64(k)) % wp.int64(ring.ring))
            a = ring.arrivals[w, d, slot]
            t = ring.times[w, d, slot]
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
def _gather(
    # In:
    windows: wp.array3d[wp.int64], positions: DrawnPositions, rows: wp.int32, pad: wp.int32,
    history: wp.array3d[wp.float32],
    # Out:
    out: wp.array2d[wp.float32],
):
    w, p = wp.tid()
    t = windows[w, positions.sensor[p], positions.entry[p]]
    column = positions.column[p]
    if t >= wp.int64(0):
        out[w, p] = history[w, wp.int32(t % wp.int64(rows)), column]
    elif pad == 1:
        out[w, p] = history[w, 0, column]  # the reset sample (with its noise)
    else:
        out[w, p] = wp.float32(0.0)


def _setting(steps: DrawnSteps, values: list[int], cumulative: list[float]) -> DrawnSetting:
    """A setting in the tables `values` and `cumulative` (appended to)."""
    setting = DrawnSetting()
    setting.kind = kind = _KINDS[steps.kind] + int(steps.kind == "choice" and steps.weights.size > 0)
    setting.first, setting.count = len(values), len(steps.values)
    values += [int(v) for v in steps.values]
    cumulative += np.cumsum(steps.weights).tolist() if kind == 3 else [0.0] * len(steps.values)
    return setting


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


AGGREGATORS = {"min": 0, "max": 1, "sum": 2, "mean": 3, "median": 4}  # an aggregator -> `sensors._reduce`'s code


@wp.struct
class Reduction:
    """A block of gathered positions `first` + b * `width` + c ((`buffer`, `width`)) reduced by `aggregator`
    (its `AGGREGATORS` code) into columns `at` .. `at` + `width` (`sensors._reduce`): the plan's
    `ReductionBlock`, or a drawn sensor's."""

    first: wp.int32
    buffer: wp.int32
    width: wp.int32
    aggregator: wp.int32
    at: wp.int32


def reduction(first: int, buffer: int, width: int, aggregator: str, at: int) -> Reduction:
    """The `Reduction` of a block (`aggregator` by name)."""
    block = Reduction()
    block.first, block.buffer, block.width, block.at = first, buffer, width, at
    block.aggregator = AGGREGATORS[aggregator]
    return block


def _i32(xs: object) -> wp.array:
    return wp.array(np.asarray(xs, np.int32).reshape(-1), dtype=wp.int32)


class DrawnSchedules:
    """The plan's drawn sensors over `plan.nsim` worlds on `device`. `key_slot`: per drawn sensor's name, its
    episode key's index in the engine's keys; `noisy`: its index among the noisy sensors (absent: clean)."""

    def __init__(self, plan: SuitePlan, device: wp.Device, key_slot: Mapping[str, int], noisy: Mapping[str, int]):
        self.plan, self.device = plan, device
        drawn = [(i, s) for i, s in enumerate(plan.sensors) if isinstance(s.timing, DrawnTiming)]
        self.names = [s.name for _, s in drawn]
        values: list[int] = []
        cumulative: list[float] = []
        intervals: list[DrawnSetting] = []
        delays: list[DrawnSetting] = []
        buffers: list[int] = []
        rings: list[int] = []
        sensor: list[int] = []
        entry: list[int] = []
        column: list[int] = []
        self.views: list[DrawnView] = []
        self.blocks: list[Reduction] = []
        at = reduced = 0
        for d, (index, record) in enumerate(drawn):
            timing = record.timing
            assert isinstance(timing, DrawnTiming)
            intervals.append(_setting(timing.interval, values, cumulative))
            delays.append(_setting(timing.delay, values, cumulative))
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
                self.blocks.append(reduction(at, timing.buffer, width, record.aggregator, reduced))
                self.views.append(DrawnView(index, "reduced", reduced))
                reduced += width
            at += timing.buffer * width
        n, m = plan.nsim, len(drawn)
        with wp.ScopedDevice(device):
            self.timings = timings = DrawnTimings()
            timings.key_slot = _i32([key_slot[name] for name in self.names])
            timings.noisy = _i32([noisy.get(name, -1) for name in self.names])
            timings.buffer = _i32(buffers)
            timings.interval = wp.array(intervals, dtype=DrawnSetting)
            timings.delay = wp.array(delays, dtype=DrawnSetting)
            timings.values = wp.array(np.asarray(values, np.int64), dtype=wp.int64)
            timings.cumulative = wp.array(np.asarray(cumulative, np.float64), dtype=wp.float64)
            self.positions = positions = DrawnPositions()
            positions.sensor, positions.entry, positions.column = _i32(sensor), _i32(entry), _i32(column)
            self.ring = ring = DrawnRing()
            ring.ring = max(rings)
            ring.next_j = wp.zeros((n, m), dtype=wp.int64)
            ring.next_t = wp.zeros((n, m), dtype=wp.int64)
            ring.times = wp.zeros((n, m, ring.ring), dtype=wp.int64)
            ring.arrivals = wp.zeros((n, m, ring.ring), dtype=wp.int64)
            self.windows = wp.zeros((n, m, max(buffers)), dtype=wp.int64)
            self.gathered = wp.zeros((n, at), dtype=wp.float32)
            self.reduced = wp.zeros((n, max(1, reduced)), dtype=wp.float32)

    def record(self, steps: wp.array, mask: wp.array, keys: wp.array, due: wp.array) -> None:
        """After a physics step of the worlds of `mask`: each drawn sensor's sample at that step, if any
        (`due`, (world, noisy sensor), says so to the noise kernel); at step 0 the schedule restarts."""
        wp.launch(_advance, dim=(self.plan.nsim, len(self.names)), inputs=[steps, mask, keys, self.timings],
                  outputs=[self.ring, due], device=self.device)

    def read(self, steps: wp.array, history: wp.array) -> None:
        """Every drawn sensor's window at each world's step `steps`, its values into `gathered`."""
        n = self.plan.nsim
        wp.launch(_windows, dim=(n, len(self.names)), inputs=[steps, self.timings, self.ring],
                  outputs=[self.windows], device=self.device)
        wp.launch(_gather, dim=(n, self.positions.column.shape[0]),
                  inputs=[self.windows, self.positions, self.plan.rows, int(self.plan.pad_with_initial_value),
                          history],
                  outputs=[self.gathered], device=self.device)
