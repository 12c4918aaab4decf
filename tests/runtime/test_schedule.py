"""`plan.schedule`, the one home of a fixed schedule's arithmetic, against brute force.

Brute force: sample k is delivered at `k * i + d`; the read at each multiple R of n sees the newest `b`
samples delivered by R (fewer early on: padding). Everything `Schedule` computes in closed form is checked
against what these reads actually see, for every (interval 1-8, delay 0-8, buffer 1-6, read interval 1-10).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from sensorcfg.plan.schedule import Schedule, newest_sample

GRID = list(itertools.product(range(1, 9), range(0, 9), range(1, 7)))


def brute_reads(i: int, d: int, b: int, n: int, horizon: int) -> dict[int, list[int]]:
    """Read step -> the sample indices its window holds (oldest first, padding as -1)."""
    reads = {}
    for read in range(0, horizon + 1, n):
        delivered = [k for k in range(horizon // i + 1) if k * i + d <= read]
        newest = delivered[-1] if delivered else -1
        reads[read] = [max(k, -1) for k in range(newest - b + 1, newest + 1)]
    return reads


@pytest.mark.parametrize("n", range(1, 11))
def test_windows_visibility_and_phases_match_brute_force(n: int) -> None:
    for i, d, b in GRID:
        schedule = Schedule(i, d, b, n)
        horizon = 4 * schedule.period + d + b * i + 2 * n
        reads = brute_reads(i, d, b, n, horizon)
        seen_by: dict[int, list[int]] = {}
        for read, window in reads.items():
            padded = [max(k, -1) for k in schedule.window(read).tolist()]  # any negative index is padding
            assert padded == [max(k, -1) for k in window], (i, d, b, n, read)
            assert max(schedule.newest(read), -1) == window[-1]
            for k in filter(lambda k: k >= 0, window):
                seen_by.setdefault(k, []).append(read)
        samples = np.arange(horizon // i - b * i - d)  # far enough from the horizon that every read is known
        for k in samples.tolist():
            visible = k in seen_by
            assert bool(schedule.visible(k)) == visible, (i, d, b, n, k)
            if visible:
                assert schedule.first_read(k) == seen_by[k][0] and schedule.last_read(k) == seen_by[k][-1]
        # the closed forms also take arrays
        assert schedule.visible(samples).tolist() == [k in seen_by for k in samples.tolist()]
        # needed phases: the visible samples of one period (periodic), and every sample when asked
        phases = [k * i for k in range(schedule.period // i) if k in seen_by]
        assert schedule.needed_phases() == phases
        assert Schedule(i, d, b, n, every_sample=True).needed_phases() == list(range(0, schedule.period, i))


@pytest.mark.parametrize("n", [1, 2, 5])
def test_the_ring_holds_every_sample_in_flight_and_the_window(n: int) -> None:
    for i, d, b in GRID:
        schedule = Schedule(i, d, b, n)
        for step in range(0, 3 * schedule.period + d + b * i):
            taken = step // i  # the newest sample taken by `step`
            oldest_needed = schedule.window_start(step)  # nothing older is read at or after `step`
            live = range(max(oldest_needed, 0), taken + 1)
            assert len({schedule.slot(k) for k in live}) == len(live) <= schedule.capacity, (i, d, b, n, step)


def test_samples_taken_counts_the_needed_phases() -> None:
    for i, d, b in GRID[::7]:
        schedule = Schedule(i, d, b, 3)
        phases = schedule.needed_phases()
        count = 1
        for step in range(1, 5 * schedule.period):
            count += step % schedule.period in phases
            assert schedule.samples_taken(phases, step) == count, (i, d, b, step)


def test_newest_sample_broadcasts_over_schedules() -> None:
    """The batch's read noise finds the samples of many schedules' reads in one expression: the same
    arithmetic as each Schedule's."""
    schedules = [Schedule(3, 2, 4, 2), Schedule(1, 0, 1, 5), Schedule(7, 11, 3, 4)]
    steps = np.arange(0, 60, 2)
    delay = np.array([[s.delay] for s in schedules])
    interval = np.array([[s.interval] for s in schedules])
    got = newest_sample(steps[None, :], delay, interval)
    for row, s in zip(got, schedules):
        np.testing.assert_array_equal(row, [s.newest(int(t)) for t in steps])
        for t in steps:
            np.testing.assert_array_equal(s.window(int(t)), s.newest(int(t)) + s.offsets())
            assert s.window(int(t))[0] == s.window_start(int(t))
