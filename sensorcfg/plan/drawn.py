"""Drawn intervals and delays planned in blocks: the planned-schedule stream rule, for one or many simulations.

The rule (docs/semantics.md): a schedule drawn by sensorcfg's own draws (`{uniform}`, `{choice}`) draws from
the counter-based numbers of its noise (`noise/streams.numbers`), with the sensor's episode key (k0, k1)
(`draws.sensor_key`) turned into the schedule key (k0, k1 xor 2^63): I_j and D_j are drawn from the uniform
of sample j, stage 0, lane 0 (intervals) or 1 (delays), value 0 (`UniformSteps.of_uniform`,
`ChoiceSteps.of_uniform`). Sample j (j = 0 is the reset sample, at step 0) is taken at step t_j = I_1 + ... +
I_j (j * interval when it is constant) and delivered at a_j = t_j + D_j. So a sample's time and delay are
functions of the seed, the sensor and j alone: other sensors, buffers, reads and which samples were taken
change nothing, and any samples of any simulations are drawn in one call.

A read at step R (every `substeps` steps) shows the last `buffer` samples delivered by R, in order of
(arrival, time), padded before the first ones. A sample that no read shows is not taken (unless the sensor's
noise is stateful). Nothing depends on which samples were taken, so this is exact, not a bound: there is no
dm_control side effect of dropping (dm_control continues a plan from the last sample kept).

`Planner` plans one channel for a set of simulations in rounds of `chunk` steps, vectorised across them:
round (E - chunk, E] draws the samples with times in it, and returns the window of every read in it and the
samples to take. A sample is decided by the round of its first read, which is at most `delay + substeps - 1`
steps later, so callers plan one round ahead (`chunk >= largest delay + substeps`). How long the rounds are and
how many rows a history of drawn schedules keeps (`chunk_steps`, `ROUND_STEPS`, `drawn_bank_rows`) are decided
here too, for the engines that plan rounds and for the memory check that bounds them (`sensorcfg.memory`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from ..draws import DEFAULT_DELAY, DEFAULT_UPDATE_INTERVAL, ChoiceSteps, UniformSteps
from ..noise import streams
from .schedule import history_rows

if TYPE_CHECKING:
    from .records import DrawnSteps, DrawnTiming

__all__ = ["BANK_LONG_ROUND", "BANK_RESET_STEPS", "Drawn", "Planner", "ROUND_STEPS", "Round", "chunk_steps",
           "drawn_bank_rows", "drawn_of"]

_MIN_CHUNK = 1024  # steps per planning round, at least (a channel planned alone)
# Steps per planning round across simulations, at least (the batch): a reset plans two rounds of every
# simulation it starts, so a long round makes every reset slow; a round's fixed work does not grow with its
# length, so short rounds cost the step loop little.
ROUND_STEPS = 64
BANK_RESET_STEPS = 512  # a drawn bank's chunk, at least: what its reset plans
BANK_LONG_ROUND = 4  # a drawn bank's chunks per round after the reset's


Ints = npt.NDArray[np.int64]  # steps, sample indices, simulations
Keys = npt.NDArray[np.uint64]  # episode keys, (..., 2)
Mask = npt.NDArray[np.bool_]
Draw = UniformSteps | ChoiceSteps  # an interval or delay sensorcfg draws (`draws.planned`)
Setting = int | Draw  # a planned schedule's interval or delay: a constant or a draw


def _largest(value: Setting) -> int:
    return int(value.largest) if isinstance(value, (UniformSteps, ChoiceSteps)) else int(value)


def _ints(steps: DrawnSteps) -> tuple[int, ...]:
    return tuple(int(v) for v in steps.values)


# a plan's `DrawnSteps` as the draw it records, by kind
_SETTINGS: dict[str, Callable[[DrawnSteps], Setting]] = {
    "uniform": lambda steps: UniformSteps(*_ints(steps)),
    "choice": lambda steps: ChoiceSteps(_ints(steps), tuple(float(w) for w in steps.weights) or None),
    "fixed": lambda steps: _ints(steps)[0],
}


class Drawn(NamedTuple):
    """A planned schedule: interval and delay (an int, or a draw with `block` and `largest`), in steps."""

    interval: Setting
    delay: Setting
    buffer: int
    substeps: int
    every_sample: bool = False  # stateful noise: every sample of the schedule is taken

    @classmethod
    def of(cls, timing: DrawnTiming, substeps: int) -> Drawn:
        """The planned schedule of a plan's `DrawnTiming` read every `substeps` steps (what an engine executing
        the plan plans with: `Planner`)."""
        return cls(_SETTINGS[timing.interval.kind](timing.interval), _SETTINGS[timing.delay.kind](timing.delay),
                   timing.buffer, substeps, timing.every_sample)

    @property
    def stride(self) -> int:
        """Sample j of a constant interval is at step j * stride; 1 when drawn (a sample's index is its step)."""
        return 1 if isinstance(self.interval, (UniformSteps, ChoiceSteps)) else int(self.interval)

    @property
    def span(self) -> int:
        """Steps from a sample's time to the last read that shows it, at most: it arrives by `t + dmax`, and
        the `buffer` samples taken at or after its arrival are delivered `buffer * imax + dmax` later."""
        dmax, imax = _largest(self.delay), _largest(self.interval)
        return 2 * dmax + self.buffer * imax + self.substeps + 1


def drawn_of(interval: Setting | None, delay: Setting | None, buffer: int, substeps: int,
             every_sample: bool = False) -> Drawn:
    """The planned schedule of an observable's settings (`draws.planned` ones; None: the default)."""
    return Drawn(interval or DEFAULT_UPDATE_INTERVAL, delay or DEFAULT_DELAY, buffer, substeps, every_sample)


def chunk_steps(schedules: list[Drawn], substeps: int, least: int = _MIN_CHUNK) -> int:
    """Steps per planning round: a multiple of substeps and of every constant interval, at least `least` and
    at least the largest delay plus substeps (a sample is decided one round after its own). The rule does not
    depend on it: rounds only set how far ahead, and how much at a time, schedules are planned."""
    unit = math.lcm(substeps, *(d.stride for d in schedules))
    least = max([least] + [_largest(d.delay) + substeps for d in schedules])
    return unit * -(-least // unit)


def drawn_bank_rows(schedules: list[Drawn], substeps: int) -> int:
    """Rows of a drawn-schedule bank's history (`runtime/planned.DrawnBank`): `Drawn.span` steps back and a long
    round (`BANK_LONG_ROUND` chunks) planned ahead, plus the chunk the reset plans (`schedule.history_rows`)."""
    chunk = chunk_steps(schedules, substeps, BANK_RESET_STEPS)
    return history_rows([], substeps, reach=max(d.span for d in schedules) + BANK_LONG_ROUND * chunk + 1, ahead=chunk)


class Round(NamedTuple):
    """What a planning round gives for simulations `sims`: `windows` (len(sims), reads, largest buffer) sample
    steps (-1: padding; a simulation with a smaller buffer reads the last `buffer` of them), and the samples
    to take, as (position in sims, step) pairs."""

    windows: Ints
    take_sim: Ints
    take_step: Ints


_SCHEDULE = np.array([0, 1 << 63], np.uint64)  # xor of a sensor key that gives its schedule key


def _drawn(setting: Draw, keys: Keys, first: Ints, counts: Ints, lane: int) -> Ints:
    """Draws of `setting` for samples first[s] .. first[s] + counts[s] - 1 of schedule keys `keys` (one per
    run, (len(first), 2)), run after run, from lane `lane`."""
    return np.asarray(setting.of_uniform(streams.uniform_runs(keys, first, counts, lane)), np.int64)


class Planner:
    """Planned channels across simulations: one channel for `nsim` simulations (the batch), or one simulation's
    channels, each a "simulation" of its own schedule (`drawn`: one Drawn per simulation). Per simulation: its
    schedule key, the next sample not yet planned and the time of the one before, the last `buffer` delivered
    (`tail`), the samples in flight, and the end of its last round."""

    def __init__(self, drawn: Drawn | Sequence[Drawn], nsim: int):
        drawns = [drawn] * nsim if isinstance(drawn, Drawn) else list(drawn)
        if len(drawns) != nsim or len({d.substeps for d in drawns}) != 1:
            raise ValueError("a Planner needs one Drawn per simulation, all with the same substeps")
        self.drawns = drawns
        # simulations by schedule (interval, delay): each schedule's samples drawn in one call
        schedules: dict[tuple[Setting, Setting], list[int]] = {}
        for i, d in enumerate(drawns):
            schedules.setdefault((d.interval, d.delay), []).append(i)
        self.schedules = list(schedules)
        self.schedule_of = np.zeros(nsim, np.intp)
        for k, members in enumerate(schedules.values()):
            self.schedule_of[members] = k
        self.all = np.arange(nsim)  # sims = `all` (this array): every simulation, in order (shorter paths)
        self.members = [np.array(members, np.intp) for members in schedules.values()]
        self.buffer = max(d.buffer for d in drawns)  # windows hold the largest buffer: the last `buffer` entries count
        self.substeps = drawns[0].substeps
        self.ties = max(_largest(d.delay) for d in drawns) + 1
        self.every = np.array([d.every_sample for d in drawns])
        # per simulation, the window entries it reads (all but the first largest - own buffer)
        self.reads = np.arange(self.buffer)[None, :] >= self.buffer - np.array([[d.buffer] for d in drawns])
        self.uneven = not self.reads.all()
        self.keys = np.zeros((nsim, 2), np.uint64)
        self.started = np.zeros(nsim, bool)
        self.next = np.zeros(nsim, np.int64)  # the index of the next sample to plan
        self.last = np.zeros(nsim, np.int64)  # the time of sample next - 1
        self.tail = np.full((nsim, self.buffer), -1, np.int64)
        self.end = np.full(nsim, -1, np.int64)
        self.flight = np.zeros((3, 0), np.int64)  # rows: simulation, time, arrival

    def start(self, sims: Ints, keys: Keys | list[Keys]) -> Round:
        """Episodes of simulations `sims` start (their sensor keys): the round of step 0 (the reset sample and
        read)."""
        self.keys[sims] = np.asarray(keys, np.uint64).reshape(-1, 2) ^ _SCHEDULE
        self.started[sims] = True
        self.next[sims] = 0
        self.last[sims] = 0
        self.tail[sims] = -1
        self.end[sims] = -1
        restarted = np.zeros(len(self.end), bool)
        restarted[sims] = True
        self.flight = self.flight[:, ~restarted[self.flight[0]]]
        return self._reset_round(sims)

    def _reset_round(self, sims: Ints) -> Round:
        """`round(sims, 0)` of simulations just started, in closed form: sample 0 is at step 0 and arrives
        after its delay D_0, so the reset read shows it when D_0 = 0 and padding before it; it is in flight
        otherwise; nothing is taken (tests/runtime/test_planner.py compares the two)."""
        delays = np.zeros(len(sims), np.int64)
        kinds = self.schedule_of[sims]
        for k, (_, delay) in enumerate(self.schedules):
            pos = self.members[k] if sims is self.all else np.flatnonzero(kinds == k)
            if not len(pos):
                continue
            if isinstance(delay, (UniformSteps, ChoiceSteps)):
                delays[pos] = _drawn(delay, self.keys[sims[pos]], np.zeros(len(pos), np.int64),
                                     np.ones(len(pos), np.int64), 1)
            else:
                delays[pos] = int(delay)
        self.next[sims] = 1
        self.end[sims] = 0
        late = delays > 0
        self.flight = np.concatenate((self.flight, np.stack((sims[late], 0 * delays[late], delays[late]))), axis=1)
        windows = np.full((len(sims), 1, self.buffer), -1, np.int64)
        windows[~late, 0, -1] = 0
        self.tail[sims] = windows[:, 0]
        return Round(windows, np.zeros(0, np.intp), np.zeros(0, np.int64))

    def _until(self, sims: Ints, end: Ints) -> tuple[Ints, Ints, Ints]:
        """The samples of `sims` with times <= end not planned before: (position in sims, time, delay)."""
        if not self.started[sims].all():
            raise RuntimeError("a planned schedule was used before its episode started")
        if len(self.schedules) == 1:
            return self._samples(self.schedules[0], sims, end)
        parts = []
        kinds = self.schedule_of[sims]
        for k, schedule in enumerate(self.schedules):
            pos = self.members[k] if sims is self.all else np.flatnonzero(kinds == k)
            if len(pos):
                g, t, d = self._samples(schedule, sims[pos], end[pos])
                parts.append((pos[g], t, d))
        g, t, d = (np.concatenate(part) for part in zip(*parts))
        return g, t, d

    def _samples(self, schedule: tuple[Setting, Setting], sims: Ints, end: Ints
                 ) -> tuple[Ints, Ints, Ints]:
        """`_until` for simulations of one schedule (interval, delay)."""
        (interval, delay), first = schedule, self.next[sims]
        if not isinstance(interval, (UniformSteps, ChoiceSteps)):
            counts = np.maximum(end // int(interval) - first + 1, 0)
            g = np.repeat(np.arange(len(sims)), counts)
            j = np.repeat(first - (np.cumsum(counts) - counts), counts) + np.arange(g.size)
            t = j * int(interval)
        else:
            least = max(int(interval.minimum), 1)
            # at most this many samples fit before `end`: each interval is at least `least`
            bound = np.where(first == 0, 1 + np.maximum(end, 0) // least, np.maximum(end - self.last[sims], 0) // least)
            k = np.arange(int(bound.max()) if len(sims) else 0)
            j = first[:, None] + k
            fits = k < bound[:, None]
            gaps = np.zeros(j.shape, np.int64)
            drawn = fits & (j > 0)  # sample 0 is at step 0: no interval (a run per simulation: its j in order)
            lo = np.maximum(first, 1)
            gaps[drawn] = _drawn(interval, self.keys[sims], lo, np.maximum(first + bound - lo, 0), 0)
            times = np.where(first == 0, 0, self.last[sims])[:, None] + np.cumsum(gaps, axis=1)
            shown = fits & (times <= end[:, None])
            g, j, t = np.nonzero(shown)[0], j[shown], times[shown]
            counts = shown.sum(1)
            had = counts > 0
            self.last[sims[had]] = times[had, counts[had] - 1]
        self.next[sims] = first + counts
        d = (np.full(g.size, int(delay), np.int64) if not isinstance(delay, (UniformSteps, ChoiceSteps))
             else _drawn(delay, self.keys[sims], first, counts, 1))  # g: sorted, j from first, counts per sim
        return g, t, d

    def round(self, sims: Ints, length: int) -> Round:
        """Plan the next `length` steps of simulations `sims` (0 after `start`: step 0 only)."""
        prev = self.end[sims]
        end = prev + (length if length else 1)
        g, t, d = self._until(sims, end)
        new = (g, t)
        g, t, a = self._in_flight(sims, end, g, t, t + d)
        mask = self._mask(sims)
        floor = np.maximum(prev - length, 0)
        windows = self._windows(sims, g, t, a, prev, length)
        sim, steps = _shown(windows, floor, mask) if length else (np.zeros(0, np.intp), np.zeros(0, np.int64))
        self.end[sims] = end
        return Round(windows, *self._every(sims, new, sim, steps, length))

    def _windows(self, sims: Ints, g: Ints, t: Ints, a: Ints, prev: Ints,
                 length: int) -> Ints:
        """Each read's window of the delivered samples (g, t, a) of `sims` after their tails, which become
        the last `buffer` delivered."""
        b, n = self.buffer, self.substeps
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
        windows: Ints = seq[(offset[:, None] + k)[..., None] + np.arange(b)]
        self.tail[sims] = seq[offset[:, None] + delivered[:, None] + np.arange(b)]
        return windows

    def _mask(self, sims: Ints) -> Mask | None:
        """Per simulation, the window entries whose samples it takes (None: all): not those before a smaller
        buffer's entries, none with stateful noise (it takes every sample instead)."""
        if self.uneven or self.every[sims].any():
            mask: Mask = self.reads[sims] & ~self.every[sims][:, None]
            return mask
        return None

    def _every(self, sims: Ints, new: tuple[Ints, Ints], sim: Ints, steps: Ints,
               length: int) -> tuple[Ints, Ints]:
        """The samples to take: those shown, and every new one of a simulation with stateful noise."""
        every = self.every[sims]
        if length and every.any():
            g, t = new
            pick = every[g]
            sim, steps = np.concatenate((sim, g[pick])), np.concatenate((steps, t[pick]))
        return sim, steps

    def _in_flight(self, sims: Ints, end: Ints, g: Ints, t: Ints,
                   a: Ints) -> tuple[Ints, Ints, Ints]:
        """The new samples of `sims` with their samples in flight: those that arrive by the round's end
        (the rest stay in flight)."""
        keep = self.flight
        if keep.shape[1] and sims is self.all:  # every sample in flight is of `sims`
            g, t, a = (np.concatenate((row, new)) for row, new in zip(keep, (g, t, a)))
            keep = keep[:, :0]
        elif keep.shape[1]:
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


def _shown(windows: Ints, floor: Ints, mask: Mask | None) -> tuple[Ints, Ints]:
    """(simulation, step) of the entries some read of the round shows that are not yet decided (older than a
    round: decided by an earlier round), where `mask` (simulation, entry) allows."""
    shown = windows > floor[:, None, None]
    if mask is not None:
        shown &= mask[:, None, :]
    sim = np.repeat(np.arange(len(windows)), np.count_nonzero(shown.reshape(len(windows), -1), axis=1))
    return sim, windows[shown]
