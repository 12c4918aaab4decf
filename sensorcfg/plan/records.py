"""The suite plan's records: what an engine needs to run a suite, as named, immutable integers and arrays.

A `SuitePlan` is compiled once from a suite's observables, a model and a batch size (`plan.compile`). It
holds no Python callables, no MuJoCo objects and no per-step lists: fixed shapes and masks over every
simulation, so that an engine (the CPU batch, `batch/`; a GPU engine) executes it without reading another
engine. Arrays in these records are read-only.

Conventions (one physics step is one `mj_step`; steps count from each simulation's reset, step 0):

- A *row* of values: every observed value of one simulation at one step, `width` float columns; sensor s
  owns columns `sensors[s].columns` (its values raveled in C order).
- Column j's value is element `sources[...].positions` of the flattened mjData field `field` (per
  simulation), taken after the physics step (MuJoCo's own values at that step; see docs/semantics.md).
- The *history* holds `rows` rows per simulation, addressed by global step: the row of a simulation's step
  s is `(reset_row + s) % rows`, where `reset_row` is the global row at which its episode started. At a
  reset the engine writes the reset sample into the row of step 0 and fills every other row with the pad
  value (the reset sample when `pad_with_initial_value`, else 0): a window reaching before the episode then
  reads padding with no mask.
- Reads happen after every `substeps` steps. The read at step R of a fixed-schedule sensor gathers the
  history rows `R - delta` (see `ReadTable`), chosen by the read's phase `(R % cycle) // substeps`; the read
  at a reset (R = 0) uses phase `nphase`.
"""

from __future__ import annotations

from typing import NamedTuple, TypeVar, overload

import numpy as np
import numpy.typing as npt

from ..noise.streams import ResetDraw

__all__ = ["BoolArray", "DrawnSteps", "DrawnTiming", "FixedTiming", "FloatArray", "IntArray", "NoiseProgram",
           "NoiseStep", "PlainOutput", "ReadTable", "ReducedOutput", "ReductionBlock", "ResetDraw", "SensorRecord",
           "Source", "SuitePlan", "UInt64Array", "frozen"]

IntArray = npt.NDArray[np.intp]
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
UInt64Array = npt.NDArray[np.uint64]


# quoted: numpy's scalar types take no parameters at run time
_Scalar = TypeVar("_Scalar", bound="np.generic[object]")


@overload
def frozen(array: npt.NDArray[_Scalar], dtype: None = None) -> npt.NDArray[_Scalar]: ...
@overload
def frozen(array: npt.ArrayLike, dtype: type[_Scalar]) -> npt.NDArray[_Scalar]: ...
def frozen(array: npt.ArrayLike, dtype: type[np.generic[object]] | None = None) -> npt.NDArray[np.generic[object]]:
    """A read-only contiguous copy: a plan's arrays cannot be changed by the engine that runs it."""
    out = np.array(array, dtype=dtype, copy=True, order="C")
    out.flags.writeable = False
    return out


class Source(NamedTuple):
    """Where a sensor's values are: element `positions` (C order of the sensor's shape) of one simulation's
    flattened mjData `field`."""

    field: str
    positions: IntArray


class FixedTiming(NamedTuple):
    """A constant schedule, in physics steps (dm_control's semantics, `plan/schedule.Schedule`):
    sample k is taken at step `k * interval` and delivered at `k * interval + delay`; a read shows the
    newest `buffer` delivered samples. `taken[step % period]`: a sample is taken at that step (samples no
    read can show are skipped, unless `every_sample`: stateful noise sees every nominal sample); the reset
    sample (step 0) is taken whatever `taken[0]` says, since a padded read shows it."""

    interval: int
    delay: int
    buffer: int
    period: int
    taken: BoolArray
    every_sample: bool


class DrawnSteps(NamedTuple):
    """An interval or delay drawn by sensorcfg's stream rule (`plan/drawn.py`): `kind` "uniform"
    (integers `values[0]..values[1]` inclusive), "choice" (one of `values`, with probabilities `weights`;
    equal when empty), or "fixed" (`values[0]`)."""

    kind: str
    values: IntArray
    weights: FloatArray


class DrawnTiming(NamedTuple):
    """A drawn schedule: its interval and delay rules, its buffer, and `span`: the most steps a sample may
    wait before the last read that shows it (what the history must keep). Samples no read shows are skipped,
    unless `every_sample` (stateful noise sees every sample); `plan.drawn.Drawn.of` makes the planner's
    schedule of it."""

    interval: DrawnSteps
    delay: DrawnSteps
    buffer: int
    span: int
    every_sample: bool = False


class NoiseStep(NamedTuple):
    """One configured noise stage as data. `stage`: its type (`config.noise.STAGES`: gaussian, uniform,
    bias, scale, random_walk, quantize, clip, dropout, outlier, lowpass, misalign, custom); `stream`: its
    part of the sensor's counter (`noise/streams.py`: stage << 24); `params`: each numeric parameter in the
    stage's own units (seconds, hertz, the sensor's units), broadcast to the sensor's values and raveled
    (misalign's `matrix`: 3 x 3); `options`: its word settings (dropout's `mode`, `per`; a custom stage's
    `callable`, named by `noise.pipeline.callable_reference`); `drawn`: the parameters drawn per episode
    (their `params` hold the low end).

    What an engine computes with: `kernel`, the stage's numbers made from `params` (per value unless
    said): gaussian `std` and `mean` (absent when every mean is 0: std z alone); uniform `low`, `width`
    (values low + width u); clip `low`, `high` (a missing limit infinite); quantize `step`; dropout `p`;
    outlier `p`, `scale`; lowpass `alpha` (for samples `stride` steps apart) and, on a drawn schedule,
    `alphas` (gaps + 1, values): row g for samples g steps apart; random_walk `a`, `c` (b_j = a b_(j-1) +
    c z_j per sample index; a Brownian walk's a is 1); misalign `matrix` (M, 3 x 3). `episode`: what the
    stage draws at each reset (`ResetDraw`, drawn by `noise.streams.draw_episode`): a bias's or scale's
    values, a Gauss-Markov random walk's start, a misalign's rotation vector (R M =
    `noise.misalign.matrix`); None for none. `redraw`: the parameters `drawn` per episode (one value each,
    in that order), drawn first; `kernel` and `episode` then hold those of the low ends, and
    `plan.noise.redrawn` makes the episode's (`plan.noise.episode` does both)."""

    stage: str
    stream: int
    params: tuple[tuple[str, FloatArray], ...]
    options: tuple[tuple[str, str], ...]
    drawn: tuple[str, ...]
    kernel: tuple[tuple[str, FloatArray], ...]
    episode: ResetDraw | None
    redraw: ResetDraw | None

    def param(self, name: str) -> FloatArray | None:
        """The parameter `name`, or None when the stage's config leaves it unset."""
        return dict(self.params).get(name)

    def number(self, name: str) -> FloatArray:
        """The kernel number `name` (`kernel`)."""
        return dict(self.kernel)[name]


class NoiseProgram(NamedTuple):
    """A sensor's noise: its steps in order, applied to each sample taken. Sample j's numbers are keyed by
    the sensor's episode key and `j = step // stride` (`stride`: the interval of a constant schedule, else
    1). `stateful`: a step needs every nominal sample. `leveled`: a noise level blends the result with the
    raw value (`noise/level.blend`: raw + level (noisy - raw), clipped to `bounds`, where level != 1), its
    stream `len(steps)`. `timestep`: seconds per physics step; `gaps`: the most steps between two samples
    of a drawn schedule (0 for a fixed one); `bounds`: (low, high) per value, what the noisy values keep
    (`noise/bounds.noisy_bounds`), None for unbounded (or not leveled); `sums`: (first, stop) ranges of
    adjacent additive steps (gaussian, uniform, outlier, bias without parameters drawn per episode) whose
    terms are added up, in order, before the sum is added to the value: x + (a + b), not (x + a) + b."""

    steps: tuple[NoiseStep, ...]
    stride: int
    stateful: bool
    leveled: bool
    additive: bool  # every step only adds numbers drawn per sample (gaussian, uniform)
    timestep: float
    gaps: int
    bounds: tuple[FloatArray, FloatArray] | None
    sums: tuple[tuple[int, int], ...]


class SensorRecord(NamedTuple):
    """One enabled sensor. `name`: its output name, and the label its episode key is derived from
    (`draws.sensor_key`); `shape`: one sample's; `columns`: (first, stop) in a row; `output`: the shape a
    read returns per simulation (with the buffer axis when kept); `aggregator`: a built-in's name
    (`observables/aggregators.AGGREGATORS`) or None; `timing`: fixed or drawn; `noise`: None when clean."""

    name: str
    shape: tuple[int, ...]
    columns: tuple[int, int]
    output: tuple[int, ...]
    aggregator: str | None
    timing: FixedTiming | DrawnTiming
    noise: NoiseProgram | None
    source: Source


class PlainOutput(NamedTuple):
    """A fixed-schedule sensor read without reduction: read positions `positions` (into the read table's
    columns) reshaped to the sensor's `output` shape."""

    sensor: int
    positions: IntArray


class ReducedOutput(NamedTuple):
    """A sensor reduced in a `ReductionBlock`: columns `columns` of the reduced block."""

    sensor: int
    columns: tuple[int, int]


class ReductionBlock(NamedTuple):
    """Sensors with one built-in aggregator and buffer: read positions `positions` form a (buffer, block
    width) array (oldest sample first), reduced along its first axis once."""

    aggregator: str
    buffer: int
    positions: IntArray
    outputs: tuple[ReducedOutput, ...]


class ReadTable(NamedTuple):
    """What every fixed-schedule read gathers, per phase. A read of phase q takes, at read position p, the
    history column `column[p]` of the row `delta[q, p]` steps before the read's own step (0: the read's own
    step); `plain` and `blocks` say which positions form which output. Phases repeat every `cycle` steps
    (the lcm of the intervals and `substeps`); row `nphase` of `delta` is the reset read's."""

    cycle: int
    nphase: int
    delta: IntArray  # (nphase + 1, positions)
    column: IntArray  # (positions,)
    plain: tuple[PlainOutput, ...]
    blocks: tuple[ReductionBlock, ...]


class SuitePlan(NamedTuple):
    """Everything an engine needs to run a suite on `nsim` simulations (see the module's conventions).

    `sensors`: fixed-schedule sensors first (the read table's), then drawn ones; `width`: columns in a row;
    `rows`: history rows, a multiple of every period and longer than any sample waits; `taken`: (nphase,
    substeps, width) whether a column's sample is taken at substep k (1-based: index k - 1) of a control
    step of phase q; `read_later`: (nphase, substeps, width) whether that sample is shown by a read of a
    later control step (the others are read, if at all, by the control step's own read)."""

    nsim: int
    substeps: int
    timestep: float
    pad_with_initial_value: bool
    sensors: tuple[SensorRecord, ...]
    nfixed: int
    width: int
    rows: int
    reads: ReadTable
    taken: BoolArray
    read_later: BoolArray
    fields: tuple[tuple[str, tuple[int, ...]], ...]

    def columns(self, sensor: int) -> slice[int, int, None]:
        """Sensor `sensor`'s columns of a row."""
        first, stop = self.sensors[sensor].columns
        return slice(first, stop)
