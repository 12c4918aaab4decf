"""What a sensor keeps between its samples and its reads, by its schedule: the bytes `validate` and run
check against `MAX_KEPT_BYTES` before anything is allocated (a delay of 1,000,000 steps on a camera would
otherwise validate, then fail allocating gigabytes).

A sensor's samples wait in one of three stores, by the path that runs it; the sizes are those rules':

- a ring of `Schedule.capacity` slots (buffer + ceil(delay / interval) + 1), doubled when the buffer holds
  more than one sample (so every window is one slice): cameras, height scans, callables, per-sample
  features (`runtime/channels.FixedChannel`, `batch/camera.py`);
- a step-indexed history of `Schedule.wait + substeps + 1` rows (delay + buffer x interval), rounded up to a
  multiple of every member's sampling period (`plan/schedule.history_rows`, which the allocators call too):
  the plain float64 features of an Updater or a batch, together (`runtime/bank.py`, `batch/layout.py`): its
  rows are its longest member's, its width every member's values, so one long delay lengthens every feature's
  rows, and intervals with a large common multiple lengthen it too;
- a drawn schedule's rounds (`plan/drawn.py`): `Drawn.span` and two planning rounds of steps, with each
  read's window of sample indices, and the samples taken within them.

A slot or row also costs a numpy view in the single-simulation paths (`ROW_BYTES`). A batch keeps each
store for every simulation; its features (fixed or drawn schedules) share one flat history of
(rows, nsim, width) float64 that its noise corrupts in place (`batch/layout.py`: a row per step, no views,
no block of noise drawn ahead), and a drawn schedule's read windows for rounds of `ROUND_STEPS` steps
(`plan/drawn.ROUND_STEPS`). Each figure is an upper bound: the paths a sensor does not take cost less.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any, NamedTuple

import mujoco
import numpy as np

from .config.limits import MAX_KEPT_BYTES
from .draws import ChoiceSteps, UniformSteps
from .observables.feature import Feature
from .physics import Physics
from .plan.drawn import ROUND_STEPS, Drawn, chunk_steps, drawn_bank_rows, drawn_of
from .plan.schedule import Schedule, history_rows, noise_chunk

__all__ = ["Kept", "kept", "kept_problems"]

# Bytes each store costs beyond its samples, measured on the paths named (tests/runtime/test_memory.py checks
# that the estimate stays above what the Updater allocates):
ROW_BYTES = 192  # a ring slot: its numpy view and list entry (`FixedChannel.rows`)
STEP_BYTES = 448  # a history row: its view, snapshot flag and share of the bounded read-layout caches
READ_BYTES = 128  # a drawn schedule's planned read: its row of gather indices' view
_GIB = float(1 << 30)
_FIXES = {"delay": "use a shorter delay or a longer interval", "buffer": "use a smaller buffer or a longer interval"}
DRAWS = (UniformSteps, ChoiceSteps)  # schedules sensorcfg draws and plans (`DrawnChannel`, `DrawnBank`)


class Kept(NamedTuple):
    """What one sensor keeps: `rows` slots or steps of `row` bytes each (`sample` of them its value)."""

    rows: int
    unit: str  # what a row is: 'samples' (a ring's slots) or 'steps of history'
    row: int
    sample: int
    steps: int  # rows of the step-indexed history it needs (features): the shared history's length
    key: str  # the key whose value sets the size: 'delay' or 'buffer'
    what: str  # that value, in words
    schedule: Schedule | Drawn | None = None  # a feature's schedule at its largest values (None: not a feature)
    noisy: bool = False  # it carries noise (a bank draws it a chunk ahead)

    def bytes(self, nsim: int = 1) -> int:
        return self.rows * self.row * nsim


def _bounds(value: Any, default: int) -> tuple[int, int] | None:
    """The least and largest steps a schedule value gives; None for a Python callable (unknown until drawn)."""
    if value is None:
        return default, default
    if isinstance(value, numbers.Integral):
        return int(value), int(value)
    if isinstance(value, UniformSteps):
        return value.low, value.high
    if isinstance(value, ChoiceSteps):
        return min(value.values), max(value.values)
    return None


def kept(observable: Any, substeps: int, batch: bool = False) -> Kept | None:
    """What `observable` keeps in one simulation (of a `BatchEnvironment` with `batch`), or None when its
    shape or its schedule is unknown until it runs (a callable's value without a spec, a feature not yet
    bound to a model, a schedule drawn by Python)."""
    spec = observable.array_spec
    interval, delay = _bounds(observable.update_interval, 1), _bounds(observable.delay, 0)
    if spec is None or interval is None or delay is None or interval[0] < 1:
        return None
    sample = int(np.prod(spec.shape, dtype=np.int64)) * np.dtype(spec.dtype).itemsize
    buffer, n = observable.buffer_size or 1, substeps
    (shortest, longest), (_, latest) = interval, delay
    noisy = 2 if getattr(observable, "noise", None) is not None else 1  # the bank's noise: a second history
    drawn = isinstance(observable.update_interval, DRAWS) or isinstance(observable.delay, DRAWS)
    feature = isinstance(observable, Feature)
    planned = drawn_of(observable.update_interval, observable.delay, buffer, n)  # (sized by the largest values)
    schedule = Schedule(longest, latest, buffer, n)
    if feature and batch:  # the batch's layout: a history row per step, of the values alone
        rows = steps = _history_rows([planned if drawn else schedule], n, batch, noisy > 1)
        unit, row = "steps of history", sample
        if drawn:  # each read's window of sample steps, three rounds of control steps held
            row += -(-3 * chunk_steps([planned], n, ROUND_STEPS) // n * buffer * 8 // rows)
    elif drawn and feature:  # `DrawnBank`: the history, and each read's gather of buffer x values
        rows = steps = _history_rows([planned], n, batch, noisy > 1)
        unit = "steps of history"
        row = noisy * sample + STEP_BYTES + (2 * buffer * sample + READ_BYTES) // n
    elif drawn:  # `DrawnChannel`: `Drawn.span` back and rounds of at least 1,024 steps ahead: the samples
        steps = planned.span + 5 * chunk_steps([planned], n) + 1  # taken within them, and each read's window
        rows, unit = steps // shortest + 1, "samples"
        row = sample + ROW_BYTES + (steps // n * buffer * 8 + steps * 9) // rows
    else:
        ring = Schedule(shortest, latest, buffer, n).capacity * (2 if buffer > 1 else 1)
        steps = _history_rows([schedule], n, batch, noisy > 1)
        if feature and steps > ring:  # `FeatureBank` / the batch's layout: a row per step
            rows, unit, row = steps, "steps of history", (noisy + 1) * sample + STEP_BYTES
        else:  # `FixedChannel`'s ring, the batch's camera rings
            rows, unit, row = ring, "samples", sample + ROW_BYTES
    history = (planned if drawn else schedule) if feature else None
    if latest >= buffer * longest:
        up_to = "up to " if delay[0] != latest else ""
        at = f" at an interval of {shortest:,}" if interval[0] == interval[1] else f" at intervals from {shortest:,}"
        what = f"a delay of {up_to}{latest:,} steps" + (at if longest > 1 else "")
        return Kept(rows, unit, row, sample, steps, "delay", what, history, noisy > 1)
    at = (f" at an interval of {longest:,} steps" if interval[0] == interval[1]
          else f" at intervals up to {longest:,} steps")
    what = f"a buffer of {buffer:,}" + (at if longest > 1 else "")
    return Kept(rows, unit, row, sample, steps, "buffer", what, history, noisy > 1)


def _history_rows(schedules: list[Schedule | Drawn], substeps: int, batch: bool, noisy: bool) -> int:
    """Rows of the step-indexed history that features of `schedules` share, as its allocator sizes it
    (`schedule.history_rows`): the batch's layout (one history for every feature), a `FeatureBank` (fixed
    schedules, noise drawn a chunk ahead) or a `DrawnBank` (drawn ones)."""
    fixed = [s for s in schedules if isinstance(s, Schedule)]
    drawn = [s for s in schedules if isinstance(s, Drawn)]
    if batch:
        return history_rows(fixed, substeps, reach=max((d.span for d in drawn), default=0))
    if drawn:
        return drawn_bank_rows(drawn, substeps)
    return history_rows(fixed, substeps, ahead=noise_chunk(fixed, substeps) if noisy else 0)


def _shape(observable: Any) -> str:
    spec = observable.array_spec
    return f"{'x'.join(map(str, spec.shape)) or 'scalar'} {np.dtype(spec.dtype)}"


def kept_problems(observables: Mapping[str, Any], model: mujoco.MjModel, substeps: int,
                  nsim: int = 1, batch: bool = False) -> list[tuple[str, str, str]]:
    """(sensor, key, message) for each enabled sensor that would keep more than `MAX_KEPT_BYTES`, in all
    `nsim` simulations (of a `BatchEnvironment` with `batch`), and for the shared history of the plain features
    when it would. Features learn their shape by binding to `model` (as the Updater binds them at reset)."""
    unbound = [o for o in observables.values() if isinstance(o, Feature) and o.array_spec is None]
    if unbound:
        physics = Physics(model)
        for feature in unbound:
            feature.reader(physics)
    found: list[tuple[str, str, str]] = []
    where, everything = (f" in each of {nsim:,} simulations", " in all") if nsim > 1 else ("", "")
    limit = f"a sensor may keep at most {MAX_KEPT_BYTES / _GIB:g} GiB between its samples and its reads"
    sized = {name: k for name, o in observables.items() if o.enabled
             for k in [kept(o, substeps, batch)] if k is not None}
    for name, k in sized.items():
        if k.bytes(nsim) > MAX_KEPT_BYTES:
            found.append((name, k.key, f"{k.what} keeps {k.rows:,} {k.unit} of {k.sample:,} bytes "
                          f"({_shape(observables[name])}){where}: {k.bytes(nsim) / _GIB:.1f} GiB{everything}; {limit}: "
                          f"{_FIXES[k.key]}, or a smaller value"))
    features = {name: k for name, k in sized.items() if k.schedule is not None
                and np.dtype(observables[name].array_spec.dtype) == np.float64}
    # the histories they share: the batch's one, or an Updater's feature bank and its drawn bank
    stores = [features] if batch else [{name: k for name, k in features.items() if isinstance(k.schedule, kind)}
                                       for kind in (Schedule, Drawn)]
    for store in stores:
        if len(store) < 2 or any(name in store for name, _, _ in found):
            continue
        longest = max(store, key=lambda name: store[name].steps)
        k = store[longest]
        steps = _history_rows([s.schedule for s in store.values() if s.schedule is not None], substeps, batch,
                              any(s.noisy for s in store.values()))
        width = sum(f.sample for f in store.values())
        total = steps * (width if batch else 2 * width + STEP_BYTES) * nsim
        if total <= MAX_KEPT_BYTES:
            continue
        size = (f"shared history {steps:,} steps long, each of {width:,} bytes (the {len(store)} float64 features' "
                f"values){where}: {total / _GIB:.1f} GiB{everything}; {limit}")
        if steps > k.steps:  # longer than any member's own: the rows are a multiple of every member's period
            intervals = sorted({s.schedule.interval for s in store.values() if isinstance(s.schedule, Schedule)})
            widest = max(store, key=lambda name: getattr(store[name].schedule, "interval", 0))
            found.append((widest, "interval", f"the plain features' intervals ({', '.join(map(str, intervals))} "
                          f"steps) repeat together only every {math.lcm(substeps, *intervals):,} steps, which makes "
                          f"their {size}: use intervals with a smaller common multiple, or observe fewer values"))
        else:
            found.append((longest, k.key, f"{k.what} makes the plain features' {size}: {_FIXES[k.key]}, or observe "
                          "fewer values"))
    return found
