"""The arithmetic of a fixed schedule, in one place: which samples exist, which a read sees, where they live.

A fixed schedule is (interval i, delay d, buffer b, substeps n: physics steps per control step, so reads
happen every n steps), all in physics steps since reset.
dm_control's semantics in closed form:

- sample k is taken at step `k * i` (sample 0 is the reset sample) and delivered at `k * i + d`;
- reads happen at every multiple R of n; the read at R sees the window of samples
  `newest(R) - b + 1 .. newest(R)`, with `newest(R) = (R - d) // i` (indices below 0 are the padding);
- sample k is *visible* when it is still in the window of the first read at or after its delivery; a
  sample that is never visible need not be taken (skipping stays invisible), unless the sensor carries
  stateful noise, which must see every sample of the nominal schedule (`every_sample`);
- the pattern of visible samples repeats every `period = lcm(i, n)` steps;
- samples wait in a ring of `capacity = b + ceil(d / i) + 1` slots: sample k lives in slot `k % capacity`.

Every consumer calls this module, below the engines: the plan (`plan/compile.py`, `plan/layout.py`),
`FixedChannel`, the feature bank's sample counts, the batch's store (what the history keeps), the cameras'
rings and the CLI's timing panels. How many rows a step-indexed history has (`history_rows`, and the noise a
bank draws ahead, `noise_chunk`) is decided here too, for every history and for the memory check that bounds
them. Functions that take a sample index or a step accept numpy integer arrays too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple, TypeVar, overload

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .records import FixedTiming

__all__ = ["IntArray", "NOISE_CHUNK_STEPS", "Schedule", "Steps", "history_rows", "newest_sample", "noise_chunk"]

IntArray = NDArray[np.int64]  # sample indices or steps, many at once
Steps = TypeVar("Steps", int, IntArray)  # one sample index or step, or an array of them


@overload
def newest_sample(read_step: int, delay: int, interval: int) -> int: ...
@overload
def newest_sample(read_step: IntArray, delay: int | IntArray, interval: int | IntArray) -> IntArray: ...
def newest_sample(read_step: int | IntArray, delay: int | IntArray, interval: int | IntArray) -> int | IntArray:
    """Index of the newest sample delivered by the read at `read_step` of a schedule with `delay` and
    `interval` (negative: none yet). Any of them may be an array (they broadcast), so that the reads of many
    schedules are one expression (`batch.read_noise`)."""
    return (read_step - delay) // interval


class Schedule(NamedTuple):
    """A constant integer schedule, in physics steps."""

    interval: int
    delay: int
    buffer: int
    substeps: int
    every_sample: bool = False  # stateful noise: every sample of the nominal schedule is taken

    @classmethod
    def of(cls, timing: FixedTiming, substeps: int) -> Schedule:
        """The schedule of a plan's `FixedTiming` read every `substeps` steps: what an engine executing the
        plan calls for a rule the record does not hold (windows, newest samples)."""
        return cls(timing.interval, timing.delay, timing.buffer, substeps, timing.every_sample)

    @property
    def period(self) -> int:
        """Steps after which the pattern of taken samples and read windows repeats."""
        return math.lcm(self.interval, self.substeps)

    @property
    def capacity(self) -> int:
        """Ring slots that hold every sample in flight (taken, not delivered) plus the visible window."""
        return self.buffer + -(-self.delay // self.interval) + 1

    @property
    def wait(self) -> int:
        """Steps from a sample's time to its last read, at most (`delay + buffer * interval`)."""
        return self.delay + self.buffer * self.interval

    def newest(self, read_step: Steps) -> Steps:
        """Index of the newest sample delivered by the read at `read_step` (negative: none yet)."""
        return newest_sample(read_step, self.delay, self.interval)

    def window_start(self, read_step: Steps) -> Steps:
        """Index of the oldest sample in the window of the read at `read_step` (may be negative: padding)."""
        return self.newest(read_step) - self.buffer + 1

    def window(self, read_step: int) -> IntArray:
        """Sample indices the read at `read_step` sees, oldest first (negative ones are padding)."""
        return self.newest(read_step) + self.offsets()

    def offsets(self) -> IntArray:
        """Each window slot's sample index relative to `newest`, oldest first: -(buffer - 1) .. 0."""
        return np.arange(self.buffer) - self.buffer + 1

    def first_read(self, sample: Steps) -> Steps:
        """The step of the first read at or after sample `sample`'s delivery."""
        n = self.substeps  # reads happen at multiples of n
        return -(-(sample * self.interval + self.delay) // n) * n

    def last_read(self, sample: Steps) -> Steps:
        """The step of the last read whose window holds sample `sample` (reads at multiples of n)."""
        n = self.substeps  # reads happen at multiples of n
        return (sample * self.interval + self.wait - 1) // n * n

    @overload
    def visible(self, sample: int) -> bool: ...
    @overload
    def visible(self, sample: IntArray) -> NDArray[np.bool_]: ...
    def visible(self, sample: Steps) -> bool | NDArray[np.bool_]:
        """Whether some read sees sample `sample`: it is still in the window of its first read."""
        return self.newest(self.first_read(sample)) - sample < self.buffer

    def needed_phases(self) -> list[int]:
        """Steps t in [0, period) at which a sample must be taken (the reset sample always is)."""
        samples = np.arange(self.period // self.interval)
        if not self.every_sample:
            samples = samples[self.visible(samples)]
        return [int(k) * self.interval for k in samples]

    def needed_mask(self) -> NDArray[np.bool_]:
        """`needed_phases()` as a boolean mask over [0, period): indexed by `step % period`."""
        mask = np.zeros(self.period, bool)
        mask[self.needed_phases()] = True
        return mask

    def slot(self, sample: Steps) -> Steps:
        """The ring slot of sample `sample`."""
        return sample % self.capacity

    def samples_taken(self, phases: list[int], step: int) -> int:
        """Samples taken by `step` (inclusive) when `phases` (`needed_phases()`) are: the reset sample,
        then every needed phase of every period so far."""
        full, rest = divmod(step, self.period)
        return 1 + full * len(phases) + sum(1 for p in phases if p <= rest) - (1 if 0 in phases else 0)


def history_rows(schedules: Sequence[Schedule], substeps: int, reach: int = 0, ahead: int = 0) -> int:
    """Rows of a step-indexed history (the values of step s in row `s % rows`) that serves the reads of
    `schedules` (a sample waits `wait` steps at most, then a control step of `substeps` ends with its read),
    samples `reach` steps old (drawn schedules' `Drawn.span` and what they plan ahead), and `ahead` steps
    drawn ahead of the current one (noise or a planning round; a multiple of every sampling period).

    Rows are a multiple of every sampling period (of `ahead` when drawing ahead), so that each periodic
    pattern of samples and reads lands on the same rows every time round: `period * ceil(steps / period)`.
    The one sizing rule of the feature banks, the batch's layout and the memory check (`sensorcfg.memory`),
    so that the check bounds what they allocate."""
    unit = ahead or math.lcm(substeps, *(s.interval for s in schedules))
    steps = max(reach, substeps + 1, *(s.wait + substeps + 1 for s in schedules)) + ahead
    return unit * -(-steps // unit)


NOISE_CHUNK_STEPS = 1024  # physics steps of noise a bank draws at a time (rounded up to the sampling period)


def noise_chunk(schedules: Sequence[Schedule], substeps: int) -> int:
    """Steps of noise a feature bank draws at a time (and holds ahead in its history, `history_rows`'s
    `ahead`): `NOISE_CHUNK_STEPS` rounded up to every sampling period (one Philox call each)."""
    period = math.lcm(substeps, *(s.interval for s in schedules))
    return period * -(-NOISE_CHUNK_STEPS // period)
