"""What a Warp world's noise draws per episode, and the `misalign` turn that mixes a sample's values.

Everything drawn at a reset is drawn on the host by the CPU pipeline's own stages from the episode's keys
(`episode_values`), into each world's row of the episode table (`Sensors.episodes.value_table`, `key_episodes`
episodes ahead): a bias's or scale's values and a random walk's start (`NoiseTables.episode_slots`), the
kernel parameters of a stage whose parameters are drawn per episode (`NoiseTables.param_slots`: slots 0 and 1
of `program.stage_params` computed from the episode's values, read by the noise kernel instead of the fixed
ones), and a misalign stage's matrix R M (`NoiseTables.turn_slots`, 3 x 3 row-major).

A misalign stage maps each 3-vector of a sample (consecutive values, the shape's last axis) by the episode's
matrix, which the noise kernel's one thread per value cannot do: a sensor's stages run in segments split at
its misalign stages (`segment` of `warp.sensors._noise`, the values kept in float64 in `NoiseMemory.work`),
and `turn` applies each segment's misalign stages to `work`, as `noise.misalign.turn` sums (j = 0, 1, 2).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import warp as wp

from .philox import MODULE_OPTIONS
from .program import PARAM_SLOTS, NoisePrograms, NoiseTables, ParamSlot, TurnSlot, stage_params, taken_at

if TYPE_CHECKING:
    from .sensors import Sensors

__all__ = ["Turns", "episode_values", "turn"]

wp.set_module_options(MODULE_OPTIONS)  # numpy's roundings (no fused multiply-adds)


@wp.struct
class TurnGroups:
    """Per 3-vector a misalign stage turns (`TurnSlot.first`): its noisy sensor, its first value's position in
    the noise values, its matrix's slot of `drawn`, the segment its stage ends."""

    sensor: wp.array[wp.int32]
    first: wp.array[wp.int32]
    slot: wp.array[wp.int32]
    segment: wp.array[wp.int32]


@wp.kernel
def _turn(
    # In:
    steps: wp.array[wp.int64], mask: wp.array[wp.int32], segment: wp.int32, groups: TurnGroups,
    programs: NoisePrograms, drawn: wp.array2d[wp.float64],
    # Out:
    work: wp.array2d[wp.float64],
):
    w, g = wp.tid()
    if mask[w] == 0 or groups.segment[g] != segment:
        return
    if not taken_at(programs, groups.sensor[g], steps[w]):
        return
    i = groups.first[g]
    m = groups.slot[g]
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

    def __init__(self, slots: tuple[TurnSlot, ...], device: wp.Device):
        groups = [(s, first) for s in slots for first in s.first]
        self.count = len(groups)
        self.groups = TurnGroups()
        i32 = lambda xs: wp.array(np.asarray(xs, np.int32), dtype=wp.int32, device=device)  # noqa: E731
        self.groups.sensor = i32([s.sensor for s, _ in groups])
        self.groups.first = i32([first for _, first in groups])
        self.groups.slot = i32([s.slot for s, _ in groups])
        self.groups.segment = i32([s.segment for s, _ in groups])


def turn(turns: Turns, segment: int, steps: wp.array, mask: wp.array, programs: NoisePrograms, drawn: wp.array,
         work: wp.array) -> None:
    """The misalign stages ending segment `segment` on the values in `work` (`programs`: which samples each
    noisy sensor's schedule takes)."""
    if turns.count:
        wp.launch(_turn, dim=(work.shape[0], turns.count), inputs=[steps, mask, segment, turns.groups, programs,
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
    drawn = stage.values
    params = tuple((name, np.full(slot.values, drawn[name]) if name in drawn else value)
                   for name, value in slot.step.params)
    return stage_params(slot.step._replace(params=params), slot.values, slot.interval, timestep)[:PARAM_SLOTS]


def episode_values(sensors: Sensors, pipelines: Mapping[str, Any], keys: np.ndarray) -> np.ndarray:
    """The values an episode keyed `keys` (one key per noisy sensor) draws at its reset, at their slots of
    `sensors.episodes.drawn`: each noisy sensor's CPU pipeline is reset with its key, and what its stages drew is
    read off them (the rules' one home stays `noise/`)."""
    tables: NoiseTables = sensors.noise
    values = np.zeros(sensors.episodes.drawn.shape[1])
    size = tables.size
    wanted = ({s.sensor for s in tables.episode_slots} | {s.sensor for s in tables.param_slots}
              | {s.sensor for s in tables.turn_slots})
    stages: dict[int, dict[int, Any]] = {}
    for n in sorted(wanted):
        pipeline = pipelines[sensors.noisy_names[n]]
        pipeline.reset(keys[n], pipeline.stride)
        stages[n] = _by_stream(pipeline)
    for drawn in tables.episode_slots:
        values[drawn.slot:drawn.slot + drawn.values] = _drawn_at_reset(stages[drawn.sensor][drawn.stream])
    for slot in tables.param_slots:
        block = np.zeros((PARAM_SLOTS, size))
        block[:, :slot.values] = _parameters(slot, stages[slot.sensor][slot.stream], sensors.plan.timestep)
        values[slot.slot:slot.slot + PARAM_SLOTS * size] = block.ravel()
    for turning in tables.turn_slots:
        values[turning.slot:turning.slot + 9] = np.ravel(stages[turning.sensor][turning.stream].matrix)
    return values
