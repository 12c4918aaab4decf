"""A plan's noise programs as the Warp noise kernel reads them: one data home, built in one place (`noise_tables`).

Three device structs, named after the plan's records (`sensorcfg.plan.records`), each a table of one row per
item: `NoiseValues` (each value of a noisy sensor: its history column, sensor, index and leveled bounds),
`NoisePrograms` (each noisy sensor's `NoiseProgram` with its timing: which steps its schedule takes, its
stride, its steps' range, whether leveled, its misalign segments) and `NoiseSteps` (each `NoiseStep`: its
kernel code, stream tag, options and the step's kernel numbers, `NoiseStep.kernel`, as the plan made them).
`NoiseTables` holds them with the host's slots of what an episode draws at its reset (`warp.episode`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import warp as wp

from ..plan import FixedTiming, NoiseProgram, NoiseStep, SuitePlan
from .philox import MODULE_OPTIONS
from .support import STAGES as _RUN

__all__ = ["EPISODE_DRAWS", "PARAM_SLOTS", "STAGES", "EpisodeSlot", "NoisePrograms", "NoiseSteps", "NoiseTables",
           "NoiseValues", "ParamSlot", "TurnSlot", "noise_tables", "stage_params", "taken_at"]

wp.set_module_options(MODULE_OPTIONS)  # numpy's roundings (no fused multiply-adds)


class _Kernel(NamedTuple):
    """A stage type's kernel `code` and the kernel numbers (`NoiseStep.kernel`) filling slots 0, 1 of
    `NoiseSteps.params`."""

    code: int
    params: tuple[str, ...]


_KERNEL: Mapping[str, _Kernel] = {
    "gaussian": _Kernel(0, ("mean", "std")),
    "uniform": _Kernel(1, ("low", "width")),
    "clip": _Kernel(2, ("low", "high")),
    "quantize": _Kernel(3, ("step",)),
    "dropout": _Kernel(4, ("p",)),
    "outlier": _Kernel(5, ("p", "scale")),
    "lowpass": _Kernel(6, ("alpha",)),  # on a drawn schedule, `alphas` per gap (`NoiseSteps.alphas`)
    "bias": _Kernel(7, ()),  # the episode's drawn values (`NoiseTables.episode_slots`)
    "scale": _Kernel(8, ()),
    "random_walk": _Kernel(9, ("a", "c")),  # per sample index
    "misalign": _Kernel(10, ()),  # ends a segment of the sensor's stages: `episode.turn` mixes its 3-vectors
}
STAGES: Mapping[str, _Kernel] = {stage: _KERNEL[stage] for stage in _RUN}  # those the engine runs
EPISODE_DRAWS = frozenset({"bias", "scale", "random_walk"})  # stages with values drawn at each reset

PARAM_SLOTS = 2  # the kernel parameters a stage reads (slots 0 and 1 of `stage_params`)
_DROPOUT_MODES = {"hold": 0, "zero": 1, "nan": 2}


@wp.struct
class NoiseValues:
    """Per value of every noisy sensor (its flattened columns, sensor by sensor)."""

    column: wp.array[wp.int32]  # its history column
    sensor: wp.array[wp.int32]  # its noisy sensor
    index: wp.array[wp.int32]  # its index in the sensor's values
    low: wp.array[wp.float64]  # the interval a leveled blend is clipped to
    high: wp.array[wp.float64]


@wp.struct
class NoisePrograms:
    """Per noisy sensor: its `NoiseProgram` and the steps its schedule takes."""

    taken: wp.array[wp.int32]  # every fixed schedule's `taken` mask, sensor after sensor (a drawn one's: [1])
    first_taken: wp.array[wp.int32]  # where the sensor's mask starts in `taken`
    period: wp.array[wp.int32]  # its mask's length
    stride: wp.array[wp.int64]
    first_step: wp.array[wp.int32]  # its steps: rows first_step .. stop_step - 1 of `NoiseSteps`
    stop_step: wp.array[wp.int32]
    leveled: wp.array[wp.int32]
    turns: wp.array[wp.int32]  # its misalign stages (segments - 1)


@wp.func
def taken_at(programs: NoisePrograms, sensor: wp.int32, s: wp.int64) -> bool:
    """Whether noisy sensor `sensor`'s schedule takes a sample at step `s`: the reset sample (step 0) always,
    whether or not a read's window shows it (a padded read shows it: `Schedule.samples_taken`), then the
    steps of its plan's `taken` mask (a drawn schedule's: every step, `due` says which)."""
    at = programs.first_taken[sensor] + wp.int32(s % wp.int64(programs.period[sensor]))
    return s == wp.int64(0) or programs.taken[at] == 1


@wp.struct
class NoiseSteps:
    """Per `NoiseStep` of every noisy sensor."""

    code: wp.array[wp.int32]  # `STAGES`' kernel code
    tag: wp.array[wp.uint32]  # its stream, as the random numbers' counter carries it
    mode: wp.array[wp.int32]  # a dropout's (`_DROPOUT_MODES`)
    per_value: wp.array[wp.int32]  # a dropout's draw: one per value (1) or per sample (0)
    slot: wp.array[wp.int32]  # its episode's drawn values in `drawn` (bias, scale, a walk's start)
    drawn: wp.array[wp.int32]  # its parameters drawn per episode at this slot of `drawn`, or -1
    params: wp.array3d[wp.float64]  # (step, 3, value): its fixed kernel parameters (`stage_params`)
    alphas: wp.array3d[wp.float64]  # (step, gap, value): a lowpass's coefficient per gap (drawn schedules)


class ParamSlot(NamedTuple):
    """A stage of noisy sensor `sensor` with parameters drawn per episode: its `stream`, the sensor's `values`;
    its episode's kernel parameters at `slot` (PARAM_SLOTS x `size`)."""

    sensor: int
    stream: int
    values: int
    slot: int


class TurnSlot(NamedTuple):
    """A misalign stage of noisy sensor `sensor` (`stream`), its episode's matrix at `slot` (9 values), applied
    after the sensor's stage segment `segment` to its 3-vectors starting at value-list positions `first`."""

    sensor: int
    stream: int
    slot: int
    segment: int
    first: tuple[int, ...]


class EpisodeSlot(NamedTuple):
    """A bias's or scale's values or a random walk's start drawn at each reset: noisy sensor `sensor`'s stage
    `stream`, its `values` at `slot` of `drawn`."""

    sensor: int
    stream: int
    slot: int
    values: int


@dataclass(frozen=True)
class NoiseTables:
    """A plan's noise programs on a device: `values`, `programs`, `steps`; `nvalue` values of `size` at most
    per sensor, `nstep` steps; `segments` noise launches per record (misalign stages split them); what an
    episode draws at its reset, at `nslot` slots of `drawn`: `episode_slots`, `param_slots`, `turn_slots`."""

    values: NoiseValues
    programs: NoisePrograms
    steps: NoiseSteps
    nvalue: int
    nstep: int
    size: int
    segments: int
    nslot: int
    episode_slots: tuple[EpisodeSlot, ...]
    param_slots: tuple[ParamSlot, ...]
    turn_slots: tuple[TurnSlot, ...]


def _i32(xs: object) -> wp.array:
    return wp.array(np.asarray(xs, np.int32).reshape(-1), dtype=wp.int32)


def _f64(xs: object) -> wp.array:
    return wp.array(np.asarray(xs, np.float64).reshape(-1), dtype=wp.float64)


def noise_tables(plan: SuitePlan) -> NoiseTables:
    """The noise tables of `plan`'s noisy sensors (in plan order) on the current device."""
    noisy = [s for s in plan.sensors if s.noise is not None]
    size = max([1, *(s.columns[1] - s.columns[0] for s in noisy)])
    gaps = max([0, *(s.noise.gaps for s in noisy if s.noise is not None)])
    v_column: list[int] = []
    v_sensor: list[int] = []
    v_index: list[int] = []
    v_low: list[float] = []
    v_high: list[float] = []
    taken: list[int] = []
    first_taken: list[int] = []
    period: list[int] = []
    stride: list[int] = []
    first_step: list[int] = []
    stop_step: list[int] = []
    leveled: list[int] = []
    turns: list[int] = []
    code: list[int] = []
    tag: list[int] = []
    mode: list[int] = []
    per_value: list[int] = []
    slot: list[int] = []
    drawn: list[int] = []
    params: list[np.ndarray] = []
    alphas: list[np.ndarray] = []
    episode_slots: list[EpisodeSlot] = []
    param_slots: list[ParamSlot] = []
    turn_slots: list[TurnSlot] = []
    nslot = 0
    for n, sensor in enumerate(noisy):
        timing, program = sensor.timing, sensor.noise
        assert isinstance(program, NoiseProgram)
        first, stop = sensor.columns
        count = stop - first
        low, high = (np.full(count, -math.inf), np.full(count, math.inf)) if program.bounds is None else program.bounds
        v_column += range(first, stop)
        v_sensor += [n] * count
        v_index += range(count)
        v_low += low.tolist()
        v_high += high.tolist()
        first_taken.append(len(taken))
        if isinstance(timing, FixedTiming):
            taken += timing.taken.astype(np.int32).tolist()
            period.append(timing.period)
        else:  # a drawn schedule: the steps it samples are `due`'s, per world
            taken.append(1)
            period.append(1)
        stride.append(program.stride)
        first_step.append(len(code))
        segment = 0
        for step in program.steps:
            kernel = STAGES[step.stage]
            code.append(kernel.code)
            tag.append(step.stream << 24)
            options = dict(step.options)
            mode.append(_DROPOUT_MODES.get(options.get("mode", "hold"), 0))
            per_value.append(int(options.get("per") == "value"))
            slot.append(nslot)
            if step.stage in EPISODE_DRAWS:
                episode_slots.append(EpisodeSlot(n, step.stream, nslot, count))
                nslot += count
            drawn.append(nslot if step.drawn and kernel.params else -1)
            if drawn[-1] >= 0:
                param_slots.append(ParamSlot(n, step.stream, count, nslot))
                nslot += PARAM_SLOTS * size
            if step.stage == "misalign":  # its 3-vectors: consecutive values (the shape's last axis)
                turn_slots.append(TurnSlot(n, step.stream, nslot, segment,
                                           tuple(range(len(v_column) - count, len(v_column), 3))))
                nslot += 9
                segment += 1
            block = np.zeros((3, size))
            block[:, :count] = stage_params(step, count)
            params.append(block)
            table = np.zeros((gaps + 1, size))
            if "alphas" in dict(step.kernel):  # a lowpass on a drawn schedule: its coefficient per gap
                per_gap = step.number("alphas")
                table[:per_gap.shape[0], :count] = per_gap
            alphas.append(table)
        stop_step.append(len(code))
        leveled.append(int(program.leveled))
        turns.append(segment)
    values = NoiseValues()
    values.column, values.sensor, values.index = _i32(v_column), _i32(v_sensor), _i32(v_index)
    values.low, values.high = _f64(v_low), _f64(v_high)
    programs = NoisePrograms()
    programs.taken, programs.first_taken, programs.period = _i32(taken), _i32(first_taken), _i32(period)
    programs.stride = wp.array(np.asarray(stride, np.int64), dtype=wp.int64)
    programs.first_step, programs.stop_step = _i32(first_step), _i32(stop_step)
    programs.leveled, programs.turns = _i32(leveled), _i32(turns)
    steps = NoiseSteps()
    steps.code, steps.tag = _i32(code), wp.array(np.asarray(tag, np.uint32), dtype=wp.uint32)
    steps.mode, steps.per_value, steps.slot, steps.drawn = _i32(mode), _i32(per_value), _i32(slot), _i32(drawn)
    steps.params = wp.array(np.asarray(params, np.float64).reshape(-1, 3, size), dtype=wp.float64)
    steps.alphas = wp.array(np.asarray(alphas, np.float64).reshape(-1, gaps + 1, size), dtype=wp.float64) \
        if alphas else wp.zeros((1, 1, 1), dtype=wp.float64)
    return NoiseTables(values, programs, steps, len(v_column), len(code), size, 1 + max([0, *turns]), nslot,
                       tuple(episode_slots), tuple(param_slots), tuple(turn_slots))


def stage_params(step: NoiseStep, size: int) -> np.ndarray:
    """Slots (3, size) of a stage's kernel numbers (`NoiseStep.kernel`), as the kernel reads them."""
    out = np.zeros((3, size))
    kernel = dict(step.kernel)
    for at, name in enumerate(STAGES[step.stage].params):
        out[at] = kernel.get(name, 0.0)  # (a centred gaussian's mean: none)
    return out
