"""Drawn intervals and delays planned in blocks: the planned-schedule stream rule, for one or many simulations.

The rule (README, Semantics): a schedule drawn by sensorcfg's own draws (`{uniform}`, `{choice}`) gets its own
counter-based stream, numpy's Philox keyed by the sensor's episode key (`draws.sensor_key`, as its noise),
counter (position 0, purpose 2, block q, stage 0 for intervals / 1 for delays). Sample j (j = 0 is the reset
sample, at step 0) is taken at step t_j = I_1 + ... + I_j (j * interval when it is constant) and delivered
at a_j = t_j + D_j, where I_j and D_j are entry j % 1024 of block j // 1024 of the interval and delay streams.
So a sample's time and delay are functions of the seed, the sensor and j alone: other sensors, buffers,
reads and which samples were taken change nothing, and a block of 1024 is drawn in one call.

A read at step R (every `substeps` steps) shows the last `buffer` samples delivered by R, in order of
(arrival, time), padded before the first ones. A sample that no read shows is not taken (unless the sensor's
noise is stateful). Nothing depends on which samples were taken, so this is exact, not a bound: there is no
dm_control side effect of dropping (dm_control continues a plan from the last sample kept).

`Planner` plans one channel for a set of simulations in rounds of `chunk` steps, vectorised across them:
round (E - chunk, E] draws the samples with times in it, and returns the window of every read in it and the
samples to take. A sample is decided by the round of its first read, which is at most `delay + substeps - 1`
steps later, so callers plan one round ahead (`chunk >= largest delay + substeps`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ..noise.streams import Streams

__all__ = ["Drawn", "Planner", "Round", "SAMPLE_BLOCK", "PURPOSE", "chunk_steps"]

SAMPLE_BLOCK = 1024  # samples per counter block of a schedule's stream
PURPOSE = 2  # the counter's purpose word of schedules (noise uses 0 and 1)
_MIN_CHUNK = 1024  # steps per planning round, at least


def _largest(value: Any) -> int:
    return int(value) if isinstance(value, numbers.Integral) else int(value.largest)


class Drawn(NamedTuple):
    """A planned schedule: interval and delay (an int, or a draw with `block` and `largest`), in steps."""

    interval: Any
    delay: Any
    buffer: int
    substeps: int
    every_sample: bool = False  # stateful noise: every sample of the schedule is taken

    @property
    def stride(self) -> int:
        """Sample j of a constant interval is at step j * stride; 1 when drawn (a sample's index is its step)."""
        return int(self.interval) if isinstance(self.interval, numbers.Integral) else 1

    @property
    def span(self) -> int:
        """Steps from a sample's time to the last read that shows it, at most: it arrives by `t + dmax`, and
        the `buffer` samples taken at or after its arrival are delivered `buffer * imax + dmax` later."""
        dmax, imax = _largest(self.delay), _largest(self.interval)
        return 2 * dmax + self.buffer * imax + self.substeps + 1


def chunk_steps(schedules: list[Drawn], substeps: int) -> int:
    """Steps per planning round: a multiple of substeps and of every constant interval, at least 1024 and at
    least the largest delay plus substeps (a sample is decided one round after its own)."""
    unit = math.lcm(substeps, *(d.stride for d in schedules))
    least = max([_MIN_CHUNK] + [_largest(d.delay) + substeps for d in schedules])
    return unit * -(-least // unit)


class Round(NamedTuple):
    """What a planning round gives for simulations `sims`: `windows` (len(sims), reads, largest buffer) sample
    steps (-1: padding; a simulation with a smaller buffer reads the last `buffer` of them), and the samples
    to take, as (position in sims, step) pairs."""

    windows: np.ndarray
    take_sim: np.ndarray
    take_step: np.ndarray


class _Samples:
    """One simulation's drawn samples, generated a block at a time: times and delays not yet planned."""

    __slots__ = ("streams", "block", "last", "times", "delays")

    def __init__(self, key: np.ndarray):
        self.streams = Streams(key)
        self.restart(key)

    def restart(self, key: np.ndarray) -> None:
        """A new episode's samples (the generator is kept)."""
        self.streams.rekey(key)
        self.block = 0
        self.last = 0  # time of the newest generated sample
        self.times = np.zeros(0, np.int64)
        self.delays = np.zeros(0, np.int64)

    def until(self, drawn: Drawn, end: int) -> tuple[np.ndarray, np.ndarray]:
        """The samples with times <= end not returned before (times, delays)."""
        while not len(self.times) or self.times[-1] <= end:
            self._extend(drawn)
        cut = int(np.searchsorted(self.times, end, side="right"))
        out = self.times[:cut], self.delays[:cut]
        self.times, self.delays = self.times[cut:], self.delays[cut:]
        return out

    def _extend(self, drawn: Drawn) -> None:
        q, n = self.block, SAMPLE_BLOCK
        if isinstance(drawn.interval, numbers.Integral):
            times = (q * n + np.arange(n, dtype=np.int64)) * int(drawn.interval)
        else:
            steps = np.cumsum(drawn.interval.block(self.streams.at(0, q, PURPOSE), n))
            times = steps - steps[0] if q == 0 else self.last + steps  # sample 0 is at step 0
        if isinstance(drawn.delay, numbers.Integral):
            delays = np.full(n, int(drawn.delay), np.int64)
        else:
            delays = drawn.delay.block(self.streams.at(1, q, PURPOSE), n).astype(np.int64)
        self.last = int(times[-1])
        self.block += 1
        self.times = np.concatenate((self.times, times))
        self.delays = np.concatenate((self.delays, delays))


class Planner:
    """Planned channels across simulations: one channel for `nsim` simulations (the batch), or one
    simulation's channels, each a "simulation" of its own schedule (`drawn`: one Drawn per simulation).
    Per simulation: its samples, the last `buffer` delivered (`tail`), the samples in flight, and the end of
    its last round."""

    def __init__(self, drawn: Drawn | Sequence[Drawn], nsim: int):
        drawns = [drawn] * nsim if isinstance(drawn, Drawn) else list(drawn)
        if len(drawns) != nsim or len({d.substeps for d in drawns}) != 1:
            raise ValueError("a Planner needs one Drawn per simulation, all with the same substeps")
        self.drawns = drawns
        self.buffer = max(d.buffer for d in drawns)  # windows hold the largest buffer: the last `buffer` entries count
        self.substeps = drawns[0].substeps
        self.ties = max(_largest(d.delay) for d in drawns) + 1
        self.every = np.array([d.every_sample for d in drawns])
        # per simulation, the window entries it reads (all but the first largest - own buffer)
        self.reads = np.arange(self.buffer)[None, :] >= self.buffer - np.array([[d.buffer] for d in drawns])
        self.uneven = not self.reads.all()
        self.samples: list[_Samples | None] = [None] * nsim
        self.tail = np.full((nsim, self.buffer), -1, np.int64)
        self.end = np.full(nsim, -1, np.int64)
        self.flight = np.zeros((3, 0), np.int64)  # rows: simulation, time, arrival

    def start(self, sims: np.ndarray, keys: list[np.ndarray]) -> Round:
        """Episodes of simulations `sims` start (their sensor keys): the round of step 0 (the reset sample and
        read)."""
        for i, key in zip(sims.tolist(), keys):
            samples = self.samples[i]
            if samples is None:
                self.samples[i] = _Samples(key)
            else:
                samples.restart(key)
        self.tail[sims] = -1
        self.end[sims] = -1
        restarted = np.zeros(len(self.end), bool)
        restarted[sims] = True
        self.flight = self.flight[:, ~restarted[self.flight[0]]]
        return self.round(sims, 0)

    def round(self, sims: np.ndarray, length: int) -> Round:
        """Plan the next `length` steps of simulations `sims` (0 after `start`: step 0 only)."""
        b, n = self.buffer, self.substeps
        prev = self.end[sims]
        end = prev + (length if length else 1)
        new = [_ready(self.samples[i]).until(self.drawns[i], e) for i, e in zip(sims.tolist(), end.tolist())]
        counts = np.array([len(t) for t, _ in new], np.intp)
        g = np.repeat(np.arange(len(sims)), counts)
        t = np.concatenate([t for t, _ in new]) if new else np.zeros(0, np.int64)
        a = t + (np.concatenate([d for _, d in new]) if new else np.zeros(0, np.int64))
        g, t, a = self._in_flight(sims, end, g, t, a)
        # delivery order per simulation: by arrival (after the round's start), ties by time (longer delay first)
        w1, w2 = length + 2, self.ties
        rel = a - prev[g]
        order = np.argsort((g * w1 + rel) * w2 + (w2 - 1 - (a - t)), kind="stable")  # nearly sorted: runs
        g, t, rel = g[order], t[order], rel[order]
        m = len(sims)
        delivered = np.bincount(g, minlength=m)
        dstart = np.concatenate(([0], np.cumsum(delivered)[:-1]))
        offset = np.arange(m) * b + dstart  # each simulation's (tail, delivered) in `seq`
        seq = np.empty(m * b + len(t), np.int64)
        seq[(offset[:, None] + np.arange(b)).ravel()] = self.tail[sims].ravel()
        seq[offset[g] + b + np.arange(len(t)) - dstart[g]] = t
        first = prev + n - prev % n if length else np.zeros(m, np.int64)  # the first read after prev
        reads = first[:, None] + n * np.arange(max(1, length // n) if length else 1)
        k = (np.searchsorted(g * w1 + rel, (np.arange(m) * w1 - prev)[:, None] + reads, side="right")
             - dstart[:, None])
        windows = seq[(offset[:, None] + k)[..., None] + np.arange(b)]
        self.tail[sims] = seq[offset[:, None] + delivered[:, None] + np.arange(b)]
        self.end[sims] = end
        return Round(windows, *self._taken(sims, windows, new, prev, length))

    def _in_flight(self, sims: np.ndarray, end: np.ndarray, g: np.ndarray, t: np.ndarray,
                   a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The new samples of `sims` with their samples in flight: those that arrive by the round's end
        (the rest stay in flight)."""
        keep = self.flight
        if keep.shape[1]:
            local = np.full(len(self.end), -1, np.intp)
            local[sims] = np.arange(len(sims))
            mine = local[keep[0]] >= 0
            fg, ft, fa = local[keep[0, mine]], keep[1, mine], keep[2, mine]
            g, t, a = np.concatenate((fg, g)), np.concatenate((ft, t)), np.concatenate((fa, a))
            keep = keep[:, ~mine]
        due = a <= end[g]
        late = ~due
        self.flight = np.concatenate((keep, np.stack((sims[g[late]], t[late], a[late]))), axis=1)
        return g[due], t[due], a[due]

    def _taken(self, sims: np.ndarray, windows: np.ndarray, new: list[tuple[np.ndarray, np.ndarray]],
               prev: np.ndarray, length: int) -> tuple[np.ndarray, np.ndarray]:
        """The samples to take: every new one (stateful noise), or those some read of the round shows that
        are not yet decided (older than a round: decided by an earlier round)."""
        if not length:  # the reset sample is always taken
            return np.zeros(0, np.intp), np.zeros(0, np.int64)
        every = self.every[sims]
        floor = np.maximum(prev - length, 0)
        shown = windows > floor[:, None, None]
        if self.uneven or every.any():  # entries before a smaller buffer's, or stateful noise: not shown
            shown &= (self.reads[sims] & ~every[:, None])[:, None, :]
        sim = np.repeat(np.arange(len(sims)), np.count_nonzero(shown.reshape(len(sims), -1), axis=1))
        steps = windows[shown]
        if every.any():
            counts = [len(t) if all_new else 0 for (t, _), all_new in zip(new, every.tolist())]
            sim = np.concatenate((sim, np.repeat(np.arange(len(new)), counts)))
            steps = np.concatenate([steps] + [t for (t, _), all_new in zip(new, every.tolist()) if all_new])
        return sim, steps


def _ready(samples: _Samples | None) -> _Samples:
    if samples is None:
        raise RuntimeError("a planned schedule was used before its episode started")
    return samples
