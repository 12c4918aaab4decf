"""A suite plan's sensors run by Warp kernels over `nworld` worlds (no host copy per step).

Executes `sensorcfg.plan.SuitePlan` as docs/architecture.md ("The suite plan") describes, with one history
per world indexed by the world's own step: the row of step s is `s % rows` (the plan's `reset_row` is 0).

- `record(fields)` after every physics step: each field's values the suite reads are copied into the row of
  the world's current step (`steps`, counted in integers since reset: never from MuJoCo Warp's float32
  `time`), then each noisy sensor's program runs on the samples its schedule takes at that step.
- `reset(mask, fields)`: the masked worlds' reset sample (noisy as on the CPU), every other row filled with
  the pad value, the episode's keys and reset draws taken from the tables ahead, the noise level adopted (each
  world's episodes: `Sensors.episodes`, an `Episodes`).
- `read()`: every read position gathered by the plan's read table for each world's phase, plain outputs
  as views of the gather, blocks reduced by their aggregator.

Drawn intervals and delays (`DrawnTiming`) are `warp.drawn`'s: its kernel runs in `record` before the noise
(which samples a drawn schedule takes there: `due`) and its windows in `read`; their episode keys follow the
noisy sensors' in `Episodes.keys` (`key_names`).

Values are float32 (MuJoCo Warp's); noise arithmetic runs in float64 on them, with the random numbers of
`noise/streams.py` (`philox.value`), keyed by (sensor key, sample index, stage, lane, value) as on the CPU.
The noise stages run here are `support.STAGES` (`program.STAGES` holds each one's kernel code), their tables
`program.NoiseTables` (`Sensors.noise`); `support.refusals` refuses the others. What an episode draws at its
reset (values, drawn parameters, misalign matrices) comes from the host's episode table, and misalign stages
split a sensor's stages into segments (`warp.episode`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import warp as wp

from ..plan import DrawnTiming, SuitePlan
from .drawn import DrawnSchedules, Reduction, reduction
from .episode import Turns, turn
from .philox import MODULE_OPTIONS, Ziggurat, value, ziggurat
from .program import STAGES, NoisePrograms, NoiseSteps, NoiseValues, noise_tables, taken_at

__all__ = ["STAGES", "Episodes", "FieldCopy", "NoiseMemory", "ReadTable", "Sensors"]

wp.set_module_options(MODULE_OPTIONS)  # numpy's roundings in the noise arithmetic (no fused multiply-adds)


@wp.struct
class NoiseMemory:
    """What the noise keeps per world between samples: `state` and `walked` per (step, value) of
    `NoiseSteps` (a dropout's held value, a lowpass's state, a random walk's value and its last sample index),
    `work` per noise value (the values between a sensor's misalign segments)."""

    state: wp.array3d[wp.float64]
    walked: wp.array3d[wp.int64]
    work: wp.array2d[wp.float64]


@wp.struct
class Episodes:
    """Per world, its episodes: the `key_episodes` ahead whose keys and reset draws the host wrote (`set_keys`,
    from `layer.EpisodeKeys`; episode e at row e % key_episodes), how many it started, and the running one's
    keys, values drawn at its reset (at `NoiseTables`' slots) and noise level."""

    key_table: wp.array4d[wp.uint64]  # (world, row, keyed sensor, 2): the keys of the episodes ahead
    value_table: wp.array3d[wp.float64]  # (world, row, slot): what they draw at their resets (`warp.episode`)
    count: wp.array[wp.int32]  # the episodes each world started (since the keys' `EpisodeKeys.start`)
    keys: wp.array3d[wp.uint64]  # (world, keyed sensor, 2): the running episode's keys (`key_names`' order)
    drawn: wp.array2d[wp.float64]  # (world, slot): what it drew at its reset
    level: wp.array[wp.float64]  # its noise level
    next_level: wp.array[wp.float64]  # (1,): the level the next episodes adopt (`set_noise_level`)


@wp.struct
class FieldCopy:
    """What `record` copies of one plan field: its values at `positions` into history `columns`."""

    columns: wp.array[wp.int32]
    positions: wp.array[wp.int32]


@wp.struct
class ReadTable:
    """The plan's `ReadTable` as the read kernel gathers it, with the plan's history `rows` and `substeps`:
    per read position p, its history `column[p]` and the row offset `delta[q, p]` of each phase q."""

    rows: wp.int32
    substeps: wp.int32
    cycle: wp.int32
    nphase: wp.int32
    delta: wp.array2d[wp.int32]
    column: wp.array[wp.int32]


@wp.kernel
def _gather(
    # In:
    field: wp.array2d[wp.float32], copy: FieldCopy, steps: wp.array[wp.int64], mask: wp.array[wp.int32],
    rows: wp.int32,
    # Out:
    history: wp.array3d[wp.float32],
):
    w, j = wp.tid()
    if mask[w] == 0:
        return
    r = wp.int32(steps[w] % wp.int64(rows))
    history[w, r, copy.columns[j]] = field[w, copy.positions[j]]


@wp.func
def _clip(x: wp.float64, low: wp.float64, high: wp.float64) -> wp.float64:
    if wp.isnan(x):
        return x
    return wp.min(wp.max(x, low), high)


@wp.kernel
def _noise(
    # In:
    steps: wp.array[wp.int64], mask: wp.array[wp.int32], rows: wp.int32, segment: wp.int32,
    values: NoiseValues, programs: NoisePrograms, stages: NoiseSteps, z: Ziggurat,
    # In, per world: the episode's keys, noise level and drawn values; a drawn schedule's gaps (`due`)
    keys: wp.array3d[wp.uint64], level: wp.array[wp.float64], drawn: wp.array2d[wp.float64],
    due: wp.array2d[wp.int32],
    # Out:
    history: wp.array3d[wp.float32], memory: NoiseMemory,
):
    w, i = wp.tid()
    if mask[w] == 0:
        return
    s = steps[w]
    sensor = values.sensor[i]
    if not taken_at(programs, sensor, s) or segment > programs.turns[sensor]:
        return
    gap = due[w, sensor]  # a drawn schedule's (`warp.drawn`): 0 no sample, else steps since the last; fixed: -1
    if gap == 0:
        return
    j = s // programs.stride[sensor]
    r = wp.int32(s % wp.int64(rows))
    c = values.column[i]
    v = values.index[i]
    k0 = keys[w, sensor, 0]
    k1 = keys[w, sensor, 1]
    state = memory.state
    raw = wp.float64(history[w, r, c])
    x = raw
    if segment > 0:  # the values the previous segment left, turned by its misalign stage
        x = memory.work[w, i]
    at = wp.int32(0)  # the segment of stage k
    for k in range(programs.first_step[sensor], programs.stop_step[sensor]):
        code = stages.code[k]
        tag = stages.tag[k]
        if code == 10:  # misalign: the segment ends (`episode.turn`)
            at = at + 1
            continue
        if at != segment:
            continue
        p0 = stages.params[k, 0, v]
        p1 = stages.params[k, 1, v]
        if stages.drawn[k] >= 0:  # parameters drawn per episode: this episode's (`program.ParamSlot`)
            p0 = drawn[w, stages.drawn[k] + v]
            p1 = drawn[w, stages.drawn[k] + stages.params.shape[2] + v]
        if code == 0:  # gaussian: x + (z std + mean)
            x = x + (value(k0, k1, j, tag, v, True, z) * p1 + p0)
        elif code == 1:  # uniform: x + (u (high - low) + low); slot 1 holds high - low
            x = x + (value(k0, k1, j, tag, v, False, z) * p1 + p0)
        elif code == 2:  # clip
            x = _clip(x, p0, p1)
        elif code == 3:  # quantize: rint(x / step) step
            x = wp.rint(x / p0) * p0
        elif code == 4:  # dropout: lane 0 uniforms, one per value or one per sample
            u = value(k0, k1, j, tag, wp.where(stages.per_value[k] == 1, v, 0), False, z)
            mode = stages.mode[k]
            lost = u < p0
            if mode == 0:
                if s == wp.int64(0):
                    lost = bool(False)  # nothing delivered yet: the first sample always is
                if lost:
                    x = state[w, k, v]
                state[w, k, v] = x
            elif lost:
                x = wp.where(mode == 1, wp.float64(0.0), wp.float64(wp.nan))
        elif code == 5:  # outlier: a hit (lane 0 uniform < p) adds a jump (lane 1 normal x scale)
            if value(k0, k1, j, tag, v, False, z) < p0:
                x = x + value(k0, k1, j, tag | wp.uint32(1 << 22), v, True, z) * p1
        elif code == 6:  # lowpass: settled at the first sample, then state += alpha (x - state)
            if s == wp.int64(0):
                state[w, k, v] = x
            else:
                alpha = p0  # a cutoff drawn per episode: the episode's, for the constant interval (`support`
                if gap > 0 and stages.drawn[k] < 0:  # refuses it on a drawn one); a drawn schedule's fixed cutoff:
                    alpha = stages.alphas[k, gap, v]  # the coefficient of the gap since the last sample
                state[w, k, v] = state[w, k, v] + alpha * (x - state[w, k, v])
            x = state[w, k, v]
        elif code == 7:  # bias: the episode's value
            x = x + drawn[w, stages.slot[k] + v]
        elif code == 8:  # scale: the episode's gain
            x = x * drawn[w, stages.slot[k] + v]
        elif code == 9:  # random walk over every sample index up to j, from the episode's start at index 0
            if j == wp.int64(0):
                state[w, k, v] = drawn[w, stages.slot[k] + v]
            else:
                b = state[w, k, v]
                for index in range(wp.int32(memory.walked[w, k, v]) + 1, wp.int32(j) + 1):  # (`i`: this value)
                    b = b * p0 + value(k0, k1, wp.int64(index), tag, v, True, z) * p1
                state[w, k, v] = b
            memory.walked[w, k, v] = j
            x = x + state[w, k, v]
    if segment < programs.turns[sensor]:
        memory.work[w, i] = x
        return
    if programs.leveled[sensor] == 1 and level[w] != wp.float64(1.0):
        x = _clip(raw + level[w] * (x - raw), values.low[i], values.high[i])
    history[w, r, c] = wp.float32(x)


@wp.kernel
def _pad(
    # In:
    mask: wp.array[wp.int32], pad: wp.int32, rows: wp.int32,
    # In and out:
    history: wp.array3d[wp.float32],
):
    w, c = wp.tid()
    if mask[w] == 0:
        return
    value = wp.where(pad == 1, history[w, 0, c], wp.float32(0.0))
    for r in range(1, rows):
        history[w, r, c] = value


@wp.kernel
def _scatter_keys(
    # In: per world of `worlds`, the keys and reset draws of its episodes ahead
    worlds: wp.array[wp.int32], keys: wp.array4d[wp.uint64], values: wp.array3d[wp.float64],
    # Out:
    episodes: Episodes,
):
    i, e = wp.tid()
    w = worlds[i]
    for n in range(keys.shape[2]):
        episodes.key_table[w, e, n, 0] = keys[i, e, n, 0]
        episodes.key_table[w, e, n, 1] = keys[i, e, n, 1]
    for v in range(values.shape[2]):
        episodes.value_table[w, e, v] = values[i, e, v]


@wp.kernel
def _start(
    # In:
    mask: wp.array[wp.int32],
    # In and out: the running episode's keys and level, from the tables and `next_level`
    episodes: Episodes,
):
    w, n = wp.tid()
    if mask[w] == 0:
        return
    e = episodes.count[w] % episodes.key_table.shape[1]
    episodes.keys[w, n, 0] = episodes.key_table[w, e, n, 0]
    episodes.keys[w, n, 1] = episodes.key_table[w, e, n, 1]
    if n == 0:
        episodes.level[w] = episodes.next_level[0]


@wp.kernel
def _start_drawn(
    # In:
    mask: wp.array[wp.int32],
    # In and out: the running episode's drawn values, from the table
    episodes: Episodes,
):
    w, i = wp.tid()
    if mask[w] == 1:
        episodes.drawn[w, i] = episodes.value_table[w, episodes.count[w] % episodes.value_table.shape[1], i]


@wp.kernel
def _count_episode(
    # In:
    mask: wp.array[wp.int32],
    # In and out: the count of episodes started
    episodes: Episodes,
):
    w = wp.tid()
    if mask[w] == 1:
        episodes.count[w] = episodes.count[w] + 1


@wp.kernel
def _gather_reads(
    # In:
    steps: wp.array[wp.int64], reads: ReadTable, history: wp.array3d[wp.float32],
    # Out:
    out: wp.array2d[wp.float32],
):
    w, p = wp.tid()
    s = steps[w]
    q = reads.nphase
    if s > wp.int64(0):
        q = wp.int32(s % wp.int64(reads.cycle)) / reads.substeps
    r = wp.int32((s + wp.int64(reads.delta[q, p])) % wp.int64(reads.rows))
    out[w, p] = history[w, r, reads.column[p]]


@wp.func
def _smaller(a: wp.float32, b: wp.float32) -> bool:
    return a < b


@wp.kernel
def _reduce(
    # In:
    gathered: wp.array2d[wp.float32], block: Reduction,
    # Out:
    out: wp.array2d[wp.float32],
):
    """One block: positions first + b * width + c form (buffer, width); 0 min, 1 max, 2 sum, 3 mean, 4 median
    (`drawn.AGGREGATORS`: the mean of the middle one or two; NaN wherever a NaN is, as numpy's), into columns
    at + c."""
    w, c = wp.tid()
    first = block.first
    buffer = block.buffer
    width = block.width
    aggregator = block.aggregator
    nan = bool(False)
    total = wp.float64(0.0)
    low = gathered[w, first + c]
    high = low
    for b in range(buffer):
        x = gathered[w, first + b * width + c]
        nan = nan or wp.isnan(x)
        total = total + wp.float64(x)
        low = wp.min(low, x)
        high = wp.max(high, x)
    result = wp.float64(0.0)
    if aggregator == 0:
        result = wp.float64(low)
    elif aggregator == 1:
        result = wp.float64(high)
    elif aggregator == 2:
        result = total
    elif aggregator == 3:
        result = total / wp.float64(buffer)
    else:
        lo_rank = (buffer - 1) / 2
        hi_rank = buffer / 2
        middle = wp.float64(0.0)
        for b in range(buffer):  # the value of rank lo_rank and hi_rank (ties broken by position)
            x = gathered[w, first + b * width + c]
            rank = wp.int32(0)
            for o in range(buffer):
                y = gathered[w, first + o * width + c]
                if _smaller(y, x) or (y == x and o < b):
                    rank = rank + 1
            if rank == lo_rank:
                middle = middle + wp.float64(x)
            if rank == hi_rank:
                middle = middle + wp.float64(x)
        result = middle / wp.float64(2.0)
    if nan:
        result = wp.float64(wp.nan)
    out[w, block.at + c] = wp.float32(result)


class Sensors:
    """The plan's sensors over `plan.nsim` worlds on `device`, with `key_episodes` episodes of keys ahead."""

    def __init__(self, plan: SuitePlan, device: wp.Device, key_episodes: int):
        self.plan, self.device = plan, device
        n, width, rows = plan.nsim, plan.width, plan.rows
        with wp.ScopedDevice(device):
            self.history = wp.zeros((n, rows, width), dtype=wp.float32)
            self._fields = self._field_copies()
            self._noise_worlds(key_episodes)
            reads = plan.reads
            self._reads = table = ReadTable()
            table.rows, table.substeps, table.cycle, table.nphase = plan.rows, plan.substeps, reads.cycle, reads.nphase
            table.delta = wp.array(reads.delta.astype(np.int32), dtype=wp.int32)
            table.column = wp.array(reads.column.astype(np.int32), dtype=wp.int32)
            self.gathered = wp.zeros((n, reads.column.size), dtype=wp.float32)
            reduced = sum(block.positions.size // block.buffer for block in reads.blocks)
            self.reduced = wp.zeros((n, reduced), dtype=wp.float32)
            self.everyone = wp.ones(n, dtype=wp.int32)
            self.z = ziggurat(device)
            self._drawn = DrawnSchedules(plan, device, self.key_slots, self.noisy_slots) \
                if plan.nfixed < len(plan.sensors) else None
        self.outputs = self._outputs()

    # -- construction --------------------------------------------------------------------------------

    def _field_copies(self) -> dict[str, FieldCopy]:
        """Per plan field, what `record` copies of it."""
        out = {}
        for field, _ in self.plan.fields:
            cols, pos = [], []
            for sensor in self.plan.sensors:
                if sensor.source.field == field:
                    first, stop = sensor.columns
                    cols.append(np.arange(first, stop))
                    pos.append(sensor.source.positions.ravel())
            out[field] = copy = FieldCopy()
            copy.columns = wp.array(np.concatenate(cols).astype(np.int32), dtype=wp.int32)
            copy.positions = wp.array(np.concatenate(pos).astype(np.int32), dtype=wp.int32)
        return out

    def _noise_worlds(self, key_episodes: int) -> None:
        """The noise tables (`program.noise_tables`) and, per world, its episodes (`Episodes`) and memory."""
        plan = self.plan
        self.noise = noise = noise_tables(plan)
        self.noisy_names = [s.name for s in plan.sensors if s.noise is not None]
        # the episode keys: the noisy sensors', then the clean drawn ones' (their schedules')
        clean = [s.name for s in plan.sensors if s.noise is None and isinstance(s.timing, DrawnTiming)]
        self.key_names = self.noisy_names + clean
        self.key_slots = {name: k for k, name in enumerate(self.key_names)}
        self.noisy_slots = {name: k for k, name in enumerate(self.noisy_names)}
        nsim, nnoisy, nkeyed = plan.nsim, max(1, len(self.noisy_names)), max(1, len(self.key_names))
        self.episodes = episodes = Episodes()
        episodes.key_table = wp.zeros((nsim, key_episodes, nkeyed, 2), dtype=wp.uint64)
        episodes.value_table = wp.zeros((nsim, key_episodes, max(1, noise.nslot)), dtype=wp.float64)
        episodes.count = wp.zeros(nsim, dtype=wp.int32)
        episodes.keys = wp.zeros((nsim, nkeyed, 2), dtype=wp.uint64)
        episodes.drawn = wp.zeros((nsim, max(1, noise.nslot)), dtype=wp.float64)
        episodes.level = wp.ones(nsim, dtype=wp.float64)
        episodes.next_level = wp.ones(1, dtype=wp.float64)
        self.due = wp.full((nsim, nnoisy), -1, dtype=wp.int32)  # per step: a drawn schedule's gaps (`warp.drawn`)
        self.memory = NoiseMemory()
        self.memory.state = wp.zeros((nsim, max(1, noise.nstep), noise.size), dtype=wp.float64)
        self.memory.walked = wp.zeros((nsim, max(1, noise.nstep), noise.size), dtype=wp.int64)
        self.memory.work = wp.zeros((nsim, noise.nvalue if noise.segments > 1 else 1), dtype=wp.float64)
        self._turns = Turns(noise.turn_slots, self.device)

    def _outputs(self) -> dict[str, wp.array]:
        """Each sensor's output: a view of the gather (plain) or of the reduced blocks, (nworld, *output)."""
        plan, out = self.plan, {}
        self._blocks: list[Reduction] = []
        at = 0
        for block in plan.reads.blocks:
            width = block.positions.size // block.buffer
            self._blocks.append(reduction(int(block.positions[0]), block.buffer, width, block.aggregator, at))
            for member in block.outputs:
                sensor = plan.sensors[member.sensor]
                out[sensor.name] = self._view(self.reduced, at + member.columns[0], sensor.output)
            at += width
        for plain in plan.reads.plain:
            sensor = plan.sensors[plain.sensor]
            out[sensor.name] = self._view(self.gathered, int(plain.positions[0]), sensor.output)
        for index, table, first in self._drawn.views if self._drawn is not None else ():
            sensor = plan.sensors[index]
            out[sensor.name] = self._view(getattr(self._drawn, table), first, sensor.output)
        return {s.name: out[s.name] for s in plan.sensors}

    def _view(self, table: wp.array, first: int, shape: tuple[int, ...]) -> wp.array:
        """Columns first.. of `table` as (nworld, *shape): strided over worlds, no copy."""
        n = table.shape[0]
        itemsize = 4
        inner = [itemsize * math.prod(shape[i + 1:]) for i in range(len(shape))]
        return wp.array(ptr=table.ptr + first * itemsize, dtype=wp.float32, shape=(n, *shape),
                        strides=(table.strides[0], *inner), device=self.device, copy=False)

    # -- running ---------------------------------------------------------------------------------------

    def record(self, fields: Mapping[str, wp.array], steps: wp.array, mask: wp.array | None = None) -> None:
        """After a physics step: the row of each world's step `steps` (where `mask`, (nworld,) int32, is set;
        all worlds when None), then noise. `fields`: each plan field as an (nworld, size) float32 view."""
        mask = self.everyone if mask is None else mask
        n, rows = self.plan.nsim, self.plan.rows
        for field, copy in self._fields.items():
            wp.launch(_gather, dim=(n, copy.columns.shape[0]), inputs=[fields[field], copy, steps, mask, rows],
                      outputs=[self.history], device=self.device)
        episodes = self.episodes
        if self._drawn is not None:
            self._drawn.record(steps, mask, episodes.keys, self.due)
        noise = self.noise
        for segment in range(noise.segments if noise.nvalue else 0):
            if segment:  # the misalign stages ending the previous segment
                turn(self._turns, segment - 1, steps, mask, noise.programs, episodes.drawn, self.memory.work)
            wp.launch(_noise, dim=(n, noise.nvalue),
                      inputs=[steps, mask, rows, segment, noise.values, noise.programs, noise.steps, self.z,
                              episodes.keys, episodes.level, episodes.drawn, self.due],
                      outputs=[self.history, self.memory], device=self.device)

    def reset(self, mask: wp.array, fields: Mapping[str, wp.array], steps: wp.array) -> None:
        """Start the masked worlds' episodes (their `steps` already 0 and `fields` their reset state)."""
        n, episodes = self.plan.nsim, self.episodes
        wp.launch(_start, dim=(n, episodes.keys.shape[1]), inputs=[mask], outputs=[episodes], device=self.device)
        wp.launch(_start_drawn, dim=(n, episodes.drawn.shape[1]), inputs=[mask], outputs=[episodes],
                  device=self.device)
        wp.launch(_count_episode, dim=n, inputs=[mask], outputs=[episodes], device=self.device)
        self.record(fields, steps, mask)
        wp.launch(_pad, dim=(n, self.plan.width),
                  inputs=[mask, int(self.plan.pad_with_initial_value), self.plan.rows], outputs=[self.history],
                  device=self.device)

    def set_keys(self, worlds: np.ndarray, keys: np.ndarray, values: np.ndarray) -> None:
        """The episodes ahead of `worlds` (their rows of `Episodes.key_table` and `value_table`), from the host."""
        if worlds.size:
            wp.launch(_scatter_keys, dim=(worlds.size, self.episodes.key_table.shape[1]),
                      inputs=[wp.array(worlds.astype(np.int32), dtype=wp.int32, device=self.device),
                              wp.array(keys, dtype=wp.uint64, device=self.device),
                              wp.array(values, dtype=wp.float64, device=self.device)],
                      outputs=[self.episodes], device=self.device)

    def read(self, steps: wp.array) -> dict[str, wp.array]:
        """Every sensor's read at each world's step `steps` (a multiple of the plan's substeps)."""
        plan, reads = self.plan, self.plan.reads
        n = plan.nsim
        if reads.column.size:
            wp.launch(_gather_reads, dim=(n, reads.column.size), inputs=[steps, self._reads, self.history],
                      outputs=[self.gathered], device=self.device)
        for block in self._blocks:
            self._reduce_block(self.gathered, block, self.reduced)
        if self._drawn is not None:
            self._drawn.read(steps, self.history)
            for block in self._drawn.blocks:
                self._reduce_block(self._drawn.gathered, block, self._drawn.reduced)
        return self.outputs

    def _reduce_block(self, gathered: wp.array, block: Reduction, out: wp.array) -> None:
        wp.launch(_reduce, dim=(self.plan.nsim, block.width), inputs=[gathered, block], outputs=[out],
                  device=self.device)
