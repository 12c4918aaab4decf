"""What a Warp world's noise draws per episode, and the `misalign` turn that mixes a sample's values.

Everything drawn at a reset is drawn on the host by the CPU pipeline's own stages from the episode's keys
(`episode_values`), into each world's row of the episode table (`Sensors.episode_table`, `key_episodes`
episodes ahead): a bias's or scale's values and a random walk's start (`Sensors.episode_slots`), the kernel
parameters of a stage whose parameters are drawn per episode (`Sensors.param_slots`: slots 0 and 1 of
`sensors._stage_params` computed from the episode's values, read by the noise kernel instead of the fixed
ones), and a misalign stage's matrix R M (`Sensors.turn_slots`, 3 x 3 row-major).

A misalign stage maps each 3-vector of a sample (consecutive values, the shape's last axis) by the episode's
matrix, which the noise kernel's one thread per value cannot do: a sensor's stages run in segments split at
its misalign stages (`segment` of `warp.sensors._noise`, the values kept in float64 in `work` between them),
and `turn` applies each segment's misalign stages to `work`, as `noise.misalign.turn` sums (j = 0, 1, 2).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import warp as wp

from ..plan import NoiseStep
from .philox import MODULE_OPTIONS

if TYPE_CHECKING:
    from .sensors import Sensors

__all__ = ["ParamSlot", "TurnSlot", "episode_values", "taken_at", "turn"]

wp.set_module_options(MODULE_OPTIONS)  # numpy's roundings (no fused multiply-adds)

PARAM_SLOTS = 2  # the kernel parameters a stage reads (slots 0 and 1 of `_stage_params`)


class ParamSlot(NamedTuple):
    """A stage of noisy sensor `sensor` with parameters drawn per episode: its `stream`, the plan's `step`,
    the sensor's `values` and `interval`; its episode's kernel parameters at `slot` (PARAM_SLOTS x `size`)."""

    sensor: int
    stream: int
    step: NoiseStep
    values: int
    interval: int
    slot: int


class TurnSlot(NamedTuple):
    """A misalign stage of noisy sensor `sensor` (`stream`), its episode's matrix at `slot` (9 values), applied
    after the sensor's stage segment `segment` to its 3-vectors starting at value-list positions `first`."""

    sensor: int
    stream: int
    slot: int
    segment: int
    first: tuple[int, ...]


@wp.func
def taken_at(taken: wp.array[wp.int32], s_taken: wp.array[wp.int32], s_period: wp.array[wp.int32],
             sensor: wp.int32, s: wp.int64) -> bool:
    """Whether noisy sensor `sensor`'s schedule takes a sample at step `s`: the reset sample (step 0) always,
    whether or not a read's window shows it (a padded read shows it: `Schedule.samples_taken`), then the
    steps of its plan's `taken` mask (a drawn schedule's: every step, `due` says which)."""
    return s == wp.int64(0) or taken[s_taken[sensor] + wp.int32(s % wp.int64(s_period[sensor]))] == 1


@wp.kernel
def _turn(steps: wp.array[wp.int64], mask: wp.array[wp.int32], segment: wp.int32, g_sensor: wp.array[wp.int32],
          g_first: wp.array[wp.int32], g_slot: wp.array[wp.int32], g_segment: wp.array[wp.int32],
          s_taken: wp.array[wp.int32], s_period: wp.array[wp.int32], taken: wp.array[wp.int32],
          drawn: wp.array2d[wp.float64], work: wp.array2d[wp.float64]):
    w, g = wp.tid()
    if mask[w] == 0 or g_segment[g] != segment:
        return
    sensor = g_sensor[g]
    if not taken_at(taken, s_taken, s_period, sensor, steps[w]):
        return
    i = g_first[g]
    m = g_slot[g]
    x = work[w, i]
    y = work[w, i + 1]
    z = work[w, i + 2]
    for r in range(3):  # dst_r = x M_r0 + y M_r1 + z M_r2, added in that order (`noise.misalign.turn`)
        out = x * drawn[w, m + 3 * r]
        out = out + y * drawn[w, m + 3 * r + 1]
        out = out + z * drawn[w, m + 3 * r + 2]
        work[w, i + r] = out


class Turns:
    """The misalign groups of a suite's noisy sensors, as device tables (none: `turn` launches nothing)."""

    def __init__(self, slots: list[TurnSlot], device: wp.Device):
        rows = [(s.sensor, first, s.slot, s.segment) for s in slots for first in s.first]
        table = np.asarray(rows, np.int32).reshape(-1, 4)
        self.groups = len(rows)
        self.tables = [wp.array(np.ascontiguousarray(table[:, c]), dtype=wp.int32, device=device) for c in range(4)]


def turn(turns: Turns, segment: int, steps: wp.array, mask: wp.array, timing: list[wp.array], drawn: wp.array,
         work: wp.array) -> None:
    """The misalign stages ending segment `segment` on the values in `work`; `timing`: the noise kernel's
    (s_taken, s_period, taken) tables."""
    if turns.groups:
        wp.launch(_turn, dim=(work.shape[0], turns.groups), inputs=[steps, mask, segment, *turns.tables, *timing,
                                                                   drawn], outputs=[work], device=work.device)


def _by_stream(pipeline: Any) -> dict[int, Any]:
    """A (CPU) pipeline's stages that draw at reset, by stream: parts of a fused sum, drawn-parameter stages
    (`noise.redrawn.Redrawn`) and misalign stages as they are."""
    from ..noise.misalign import Misalign
    from ..noise.redrawn import Redrawn
    from ..noise.stages import EpisodeDraw, RandomWalk, Sum

    out = {}
    for stage in pipeline.stages:
        for part in stage.parts if isinstance(stage, Sum) else [stage]:
            if isinstance(part, (EpisodeDraw, RandomWalk, Redrawn, Misalign)):
                out[part.stream] = part
    return out


def _drawn_at_reset(stage: Any) -> np.ndarray:
    """A bias's or scale's values, or a random walk's start, of the episode just reset (`noise.stages`)."""
    from ..noise.redrawn import Redrawn
    from ..noise.stages import EpisodeDraw

    inner: Any = stage.inner if isinstance(stage, Redrawn) else stage
    return np.ravel(inner.value if isinstance(inner, EpisodeDraw) else inner.start)


def _parameters(slot: ParamSlot, stage: Any, timestep: float) -> np.ndarray:
    """The kernel parameters (slots 0 and 1) of a stage with the values its episode drew (`Redrawn.values`)."""
    from .sensors import _stage_params

    drawn = stage.values
    params = tuple((name, np.full(slot.values, drawn[name]) if name in drawn else value)
                   for name, value in slot.step.params)
    return _stage_params(slot.step._replace(params=params), slot.values, slot.interval, timestep)[:PARAM_SLOTS]


def episode_values(sensors: Sensors, pipelines: Mapping[str, Any], keys: np.ndarray) -> np.ndarray:
    """The values an episode keyed `keys` (one key per noisy sensor) draws at its reset, at their slots of
    `sensors.drawn`: each noisy sensor's CPU pipeline is reset with its key, and what its stages drew is
    read off them (the rules' one home stays `noise/`)."""
    values = np.zeros(sensors.drawn.shape[1])
    size = sensors.size
    wanted = ({s[0] for s in sensors.episode_slots} | {s.sensor for s in sensors.param_slots}
              | {s.sensor for s in sensors.turn_slots})
    stages: dict[int, dict[int, Any]] = {}
    for n in sorted(wanted):
        pipeline = pipelines[sensors.noisy_names[n]]
        pipeline.reset(keys[n], pipeline.stride)
        stages[n] = _by_stream(pipeline)
    for n, stream, first, count in sensors.episode_slots:
        values[first:first + count] = _drawn_at_reset(stages[n][stream])
    for slot in sensors.param_slots:
        block = np.zeros((PARAM_SLOTS, size))
        block[:, :slot.values] = _parameters(slot, stages[slot.sensor][slot.stream], sensors.plan.timestep)
        values[slot.slot:slot.slot + PARAM_SLOTS * size] = block.ravel()
    for turning in sensors.turn_slots:
        values[turning.slot:turning.slot + 9] = np.ravel(stages[turning.sensor][turning.stream].matrix)
    return values
