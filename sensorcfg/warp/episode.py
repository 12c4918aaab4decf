"""What a Warp world's noise draws per episode, and the `misalign` turn that mixes a sample's values.

Everything drawn at a reset is drawn on the host from the plan's records and the episode's keys
(`episode_values`, by `plan.episode`: `noise.streams.draw_episode` of each step's `ResetDraw` records), into
each world's row of the episode table (`Sensors.episodes.value_table`, `key_episodes` episodes ahead): a bias's or
scale's values and a random walk's start (`NoiseTables.episode_slots`), the kernel parameters of a stage whose
parameters are drawn per episode (`NoiseTables.param_slots`: slots 0 and 1 of `program.stage_params` of the
episode's step, read by the noise kernel instead of the fixed ones), and a misalign stage's matrix R M
(`NoiseTables.turn_slots`, 3 x 3 row-major).

A misalign stage maps each 3-vector of a sample (consecutive values, the shape's last axis) by the episode's
matrix, which the noise kernel's one thread per value cannot do: a sensor's stages run in segments split at
its misalign stages (`segment` of `warp.sensors._noise`, the values kept in float64 in `NoiseMemory.work`),
and `turn` applies each segment's misalign stages to `work`, as `noise.misalign.turn` sums (j = 0, 1, 2).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..plan import NoiseProgram, SuitePlan, episode
from .philox import MODULE_OPTIONS
from .program import PARAM_SLOTS, NoisePrograms, NoiseTables, TurnSlot, stage_params, taken_at

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


def episode_values(plan: SuitePlan, tables: NoiseTables, keys: np.ndarray) -> np.ndarray:
    """The values an episode keyed `keys` (one key per noisy sensor of `plan`) draws at its reset, at their slots
    of `tables` (`Sensors.episodes.drawn`): each noisy sensor's program's draws (`plan.episode`, from the plan's
    records alone)."""
    values = np.zeros(max(1, tables.nslot))
    size = tables.size
    wanted = ({s.sensor for s in tables.episode_slots} | {s.sensor for s in tables.param_slots}
              | {s.sensor for s in tables.turn_slots})
    programs: list[NoiseProgram] = [s.noise for s in plan.sensors if s.noise is not None]
    drawn = {n: episode(programs[n], keys[n]) for n in sorted(wanted)}
    for slot in tables.episode_slots:
        got = drawn[slot.sensor][slot.stream].values  # None: a Brownian walk, which starts at 0
        values[slot.slot:slot.slot + slot.values] = 0.0 if got is None else got
    for param in tables.param_slots:
        block = np.zeros((PARAM_SLOTS, size))
        block[:, :param.values] = stage_params(drawn[param.sensor][param.stream].step, param.values)[:PARAM_SLOTS]
        values[param.slot:param.slot + PARAM_SLOTS * size] = block.ravel()
    for turning in tables.turn_slots:
        matrix = drawn[turning.sensor][turning.stream].matrix
        assert matrix is not None  # (a misalign step's)
        values[turning.slot:turning.slot + 9] = matrix.ravel()
    return values
