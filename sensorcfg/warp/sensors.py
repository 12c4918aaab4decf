"""A suite plan's sensors run by Warp kernels over `nworld` worlds (no host copy per step).

Executes `sensorcfg.plan.SuitePlan` as docs/architecture.md ("The suite plan") describes, with one history
per world indexed by the world's own step: the row of step s is `s % rows` (the plan's `reset_row` is 0).

- `record(fields)` after every physics step: each field's values the suite reads are copied into the row of
  the world's current step (`steps`, counted in integers since reset: never from MuJoCo Warp's float32
  `time`), then each noisy sensor's program runs on the samples its schedule takes at that step.
- `reset(mask, fields)`: the masked worlds' reset sample (noisy as on the CPU), every other row filled with
  the pad value, the episode's keys taken from `keys`, the noise level adopted.
- `read()`: every read position gathered by the plan's read table for each world's phase, plain outputs
  as views of the gather, blocks reduced by their aggregator.

Drawn intervals and delays (`DrawnTiming`) are `warp.drawn`'s: its kernel runs in `record` before the noise
(which samples a drawn schedule takes there: `due`) and its windows in `read`; their episode keys follow the
noisy sensors' in `keys` (`key_names`).

Values are float32 (MuJoCo Warp's); noise arithmetic runs in float64 on them, with the random numbers of
`noise/streams.py` (`philox.value`), keyed by (sensor key, sample index, stage, lane, value) as on the CPU.
The noise stages run here are `support.STAGES` (`STAGES` holds each one's kernel code); `support.refusals`
refuses the others. What an episode draws at its reset (values, drawn parameters, misalign matrices) comes
from the host's episode table, and misalign stages split a sensor's stages into segments (`warp.episode`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import warp as wp

from ..plan import DrawnTiming, FixedTiming, NoiseProgram, NoiseStep, SuitePlan
from .drawn import DrawnSchedules, largest_gap
from .episode import PARAM_SLOTS, ParamSlot, Turns, TurnSlot, taken_at, turn
from .philox import MODULE_OPTIONS, Ziggurat, value, ziggurat
from .support import STAGES as _RUN

__all__ = ["STAGES", "Sensors"]

# stage type -> (code, the parameters filling slots 0..2 of `params`); a lowpass's slot 0 is computed (alpha)
_KERNEL: Mapping[str, tuple[int, tuple[str, ...]]] = {
    "gaussian": (0, ("mean", "std")),
    "uniform": (1, ("low", "high")),
    "clip": (2, ("min", "max")),
    "quantize": (3, ("step",)),
    "dropout": (4, ("p",)),
    "outlier": (5, ("p", "scale")),
    "lowpass": (6, ("cutoff",)),
    "bias": (7, ()),  # the episode's drawn values (`Sensors.episode_slots`)
    "scale": (8, ()),
    "random_walk": (9, ("std", "correlation_time")),  # slots 0, 1: the walk's a and c per sample index
    "misalign": (10, ()),  # ends a segment of the sensor's stages: `episode.turn` mixes its 3-vectors
}
STAGES: Mapping[str, tuple[int, tuple[str, ...]]] = {stage: _KERNEL[stage] for stage in _RUN}  # those it runs
EPISODE_DRAWS = frozenset({"bias", "scale", "random_walk"})  # stages with values drawn at each reset
wp.set_module_options(MODULE_OPTIONS)  # numpy's roundings in the noise arithmetic (no fused multiply-adds)

_DROPOUT_MODES = {"hold": 0, "zero": 1, "nan": 2}
_NO_BOUND = (-math.inf, math.inf)


@wp.kernel
def _gather(field: wp.array2d[wp.float32], cols: wp.array[wp.int32], pos: wp.array[wp.int32],
            steps: wp.array[wp.int64], mask: wp.array[wp.int32], rows: wp.int32,
            history: wp.array3d[wp.float32]):
    w, j = wp.tid()
    if mask[w] == 0:
        return
    r = wp.int32(steps[w] % wp.int64(rows))
    history[w, r, cols[j]] = field[w, pos[j]]


@wp.func
def _clip(x: wp.float64, low: wp.float64, high: wp.float64) -> wp.float64:
    if wp.isnan(x):
        return x
    return wp.min(wp.max(x, low), high)


@wp.kernel
def _noise(steps: wp.array[wp.int64], mask: wp.array[wp.int32], rows: wp.int32, history: wp.array3d[wp.float32],
           v_col: wp.array[wp.int32], v_sensor: wp.array[wp.int32], v_index: wp.array[wp.int32],
           v_low: wp.array[wp.float64], v_high: wp.array[wp.float64],
           s_taken: wp.array[wp.int32], s_period: wp.array[wp.int32], s_stride: wp.array[wp.int64],
           s_first: wp.array[wp.int32], s_stop: wp.array[wp.int32], s_leveled: wp.array[wp.int32],
           taken: wp.array[wp.int32], st_code: wp.array[wp.int32], st_tag: wp.array[wp.uint32],
           st_mode: wp.array[wp.int32], st_per_value: wp.array[wp.int32], st_slot: wp.array[wp.int32],
           params: wp.array3d[wp.float64], keys: wp.array3d[wp.uint64], level: wp.array[wp.float64],
           drawn: wp.array2d[wp.float64], state: wp.array3d[wp.float64], walked: wp.array3d[wp.int64],
           due: wp.array2d[wp.int32], alphas: wp.array3d[wp.float64], z: Ziggurat, segment: wp.int32,
           s_turns: wp.array[wp.int32], st_drawn: wp.array[wp.int32], work: wp.array2d[wp.float64]):
    w, i = wp.tid()
    if mask[w] == 0:
        return
    s = steps[w]
    sensor = v_sensor[i]
    if not taken_at(taken, s_taken, s_period, sensor, s) or segment > s_turns[sensor]:
        return
    gap = due[w, sensor]  # a drawn schedule's (`warp.drawn`): 0 no sample, else steps since the last; fixed: -1
    if gap == 0:
        return
    j = s // s_stride[sensor]
    r = wp.int32(s % wp.int64(rows))
    c = v_col[i]
    v = v_index[i]
    k0 = keys[w, sensor, 0]
    k1 = keys[w, sensor, 1]
    raw = wp.float64(history[w, r, c])
    x = raw
    if segment > 0:  # the values the previous segment left, turned by its misalign stage
        x = work[w, i]
    at = wp.int32(0)  # the segment of stage k
    for k in range(s_first[sensor], s_stop[sensor]):
        code = st_code[k]
        tag = st_tag[k]
        if code == 10:  # misalign: the segment ends (`episode.turn`)
            at = at + 1
            continue
        if at != segment:
            continue
        p0 = params[k, 0, v]
        p1 = params[k, 1, v]
        if st_drawn[k] >= 0:  # parameters drawn per episode: this episode's (`episode.ParamSlot`)
            p0 = drawn[w, st_drawn[k] + v]
            p1 = drawn[w, st_drawn[k] + params.shape[2] + v]
        if code == 0:  # gaussian: x + (z std + mean)
            x = x + (value(k0, k1, j, tag, v, True, z) * p1 + p0)
        elif code == 1:  # uniform: x + (u (high - low) + low); slot 1 holds high - low
            x = x + (value(k0, k1, j, tag, v, False, z) * p1 + p0)
        elif code == 2:  # clip
            x = _clip(x, p0, p1)
        elif code == 3:  # quantize: rint(x / step) step
            x = wp.rint(x / p0) * p0
        elif code == 4:  # dropout: lane 0 uniforms, one per value or one per sample
            u = value(k0, k1, j, tag, wp.where(st_per_value[k] == 1, v, 0), False, z)
            mode = st_mode[k]
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
                if gap > 0 and st_drawn[k] < 0:  # refuses it on a drawn one); a drawn schedule's fixed cutoff:
                    alpha = alphas[k, gap, v]  # the coefficient of the gap since the last sample
                state[w, k, v] = state[w, k, v] + alpha * (x - state[w, k, v])
            x = state[w, k, v]
        elif code == 7:  # bias: the episode's value
            x = x + drawn[w, st_slot[k] + v]
        elif code == 8:  # scale: the episode's gain
            x = x * drawn[w, st_slot[k] + v]
        elif code == 9:  # random walk over every sample index up to j, from the episode's start at index 0
            if j == wp.int64(0):
                state[w, k, v] = drawn[w, st_slot[k] + v]
            else:
                b = state[w, k, v]
                for index in range(wp.int32(walked[w, k, v]) + 1, wp.int32(j) + 1):  # (`i` is this thread's value)
                    b = b * p0 + value(k0, k1, wp.int64(index), tag, v, True, z) * p1
                state[w, k, v] = b
            walked[w, k, v] = j
            x = x + state[w, k, v]
    if segment < s_turns[sensor]:
        work[w, i] = x
        return
    if s_leveled[sensor] == 1 and level[w] != wp.float64(1.0):
        x = _clip(raw + level[w] * (x - raw), v_low[i], v_high[i])
    history[w, r, c] = wp.float32(x)


@wp.kernel
def _pad(mask: wp.array[wp.int32], pad: wp.int32, rows: wp.int32, history: wp.array3d[wp.float32]):
    w, c = wp.tid()
    if mask[w] == 0:
        return
    value = wp.where(pad == 1, history[w, 0, c], wp.float32(0.0))
    for r in range(1, rows):
        history[w, r, c] = value


@wp.kernel
def _scatter_keys(worlds: wp.array[wp.int32], keys: wp.array4d[wp.uint64], values: wp.array3d[wp.float64],
                  key_table: wp.array4d[wp.uint64], episode_table: wp.array3d[wp.float64]):
    i, e = wp.tid()
    w = worlds[i]
    for n in range(keys.shape[2]):
        key_table[w, e, n, 0] = keys[i, e, n, 0]
        key_table[w, e, n, 1] = keys[i, e, n, 1]
    for v in range(values.shape[2]):
        episode_table[w, e, v] = values[i, e, v]


@wp.kernel
def _start(mask: wp.array[wp.int32], episodes: wp.array[wp.int32], table: wp.array4d[wp.uint64],
           keys: wp.array3d[wp.uint64], next_level: wp.array[wp.float64], level: wp.array[wp.float64]):
    w, n = wp.tid()
    if mask[w] == 0:
        return
    e = episodes[w] % table.shape[1]
    keys[w, n, 0] = table[w, e, n, 0]
    keys[w, n, 1] = table[w, e, n, 1]
    if n == 0:
        level[w] = next_level[0]


@wp.kernel
def _start_drawn(mask: wp.array[wp.int32], episodes: wp.array[wp.int32], table: wp.array3d[wp.float64],
                 drawn: wp.array2d[wp.float64]):
    w, i = wp.tid()
    if mask[w] == 1:
        drawn[w, i] = table[w, episodes[w] % table.shape[1], i]


@wp.kernel
def _count_episode(mask: wp.array[wp.int32], episodes: wp.array[wp.int32]):
    w = wp.tid()
    if mask[w] == 1:
        episodes[w] = episodes[w] + 1


@wp.kernel
def _gather_reads(steps: wp.array[wp.int64], rows: wp.int32, cycle: wp.int32, substeps: wp.int32, nphase: wp.int32,
                  delta: wp.array2d[wp.int32], column: wp.array[wp.int32], history: wp.array3d[wp.float32],
                  out: wp.array2d[wp.float32]):
    w, p = wp.tid()
    s = steps[w]
    q = nphase
    if s > wp.int64(0):
        q = wp.int32(s % wp.int64(cycle)) / substeps
    r = wp.int32((s + wp.int64(delta[q, p])) % wp.int64(rows))
    out[w, p] = history[w, r, column[p]]


@wp.func
def _smaller(a: wp.float32, b: wp.float32) -> bool:
    return a < b


@wp.kernel
def _reduce(gathered: wp.array2d[wp.float32], first: wp.int32, buffer: wp.int32, width: wp.int32,
            aggregator: wp.int32, out: wp.array2d[wp.float32], at: wp.int32):
    """One block: positions first + b * width + c form (buffer, width); 0 min, 1 max, 2 sum, 3 mean, 4 median
    (the mean of the middle one or two; NaN wherever a NaN is, as numpy's)."""
    w, c = wp.tid()
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
    out[w, at + c] = wp.float32(result)


_AGGREGATOR_CODES = {"min": 0, "max": 1, "sum": 2, "mean": 3, "median": 4}


def _stage_params(step: NoiseStep, size: int, interval: int, timestep: float) -> np.ndarray:
    """Slots (3, size) of a stage's parameters, as the kernel reads them."""
    out = np.zeros((3, size))
    names = STAGES[step.stage][1]
    for slot, name in enumerate(names):
        param = step.param(name)
        if param is not None:
            out[slot] = param
    if step.stage == "uniform":
        out[1] = out[1] - out[0]  # high - low
    if step.stage == "clip":
        out[0] = np.where(step.param("min") is None, -np.inf, out[0])
        out[1] = np.where(step.param("max") is None, np.inf, out[1])
    if step.stage == "lowpass":  # every nominal sample is taken: `interval` steps apart
        out[0] = -np.expm1(-(interval * timestep) * (2.0 * math.pi * out[0]))
    if step.stage == "random_walk":  # `noise.stages.RandomWalk`'s coefficients for a sample index's time
        out[:2] = _walk(step, size, interval * timestep)
    return out


def _walk(step: NoiseStep, size: int, dt: float) -> np.ndarray:
    """A random walk's (a, c) per value for samples `dt` seconds apart, as `RandomWalk._coefficients` gives
    them (a Brownian walk: a = 1, which multiplies exactly)."""
    from ..noise.stages import Context, RandomWalk

    std, tau = step.param("std"), step.param("correlation_time")
    if std is None:
        raise ValueError("a random walk's std is required (its config says so)")
    walk = RandomWalk(Context((size,), np.dtype(np.float64), np.dtype(np.float64), dt), std, tau)
    a, c = walk._coefficients(dt)
    return np.stack([np.broadcast_to(1.0 if a is None else a, (size,)), np.broadcast_to(c, (size,))])


class Sensors:
    """The plan's sensors over `plan.nsim` worlds on `device`. `bounds`: per noisy sensor name, the interval
    a leveled blend is clipped to (`noise/bounds.noisy_bounds`), or absent for none."""

    def __init__(self, plan: SuitePlan, device: wp.Device, key_episodes: int,
                 bounds: Mapping[str, tuple[np.ndarray, np.ndarray]]):
        self.plan, self.device = plan, device
        n, width, rows = plan.nsim, plan.width, plan.rows
        with wp.ScopedDevice(device):
            self.history = wp.zeros((n, rows, width), dtype=wp.float32)
            self._fields = self._field_tables()
            self._noise_tables(bounds, key_episodes)
            reads = plan.reads
            self._delta = wp.array(reads.delta.astype(np.int32), dtype=wp.int32)
            self._column = wp.array(reads.column.astype(np.int32), dtype=wp.int32)
            self.gathered = wp.zeros((n, reads.column.size), dtype=wp.float32)
            reduced = sum(block.positions.size // block.buffer for block in reads.blocks)
            self.reduced = wp.zeros((n, reduced), dtype=wp.float32)
            self.everyone = wp.ones(n, dtype=wp.int32)
            self.z = ziggurat(device)
            self._drawn = DrawnSchedules(plan, device, self.key_slots, self.noisy_slots) \
                if plan.nfixed < len(plan.sensors) else None
        self.outputs = self._outputs()

    # -- construction --------------------------------------------------------------------------------

    def _field_tables(self) -> list[tuple[str, wp.array, wp.array]]:
        out = []
        for field, _ in self.plan.fields:
            cols, pos = [], []
            for sensor in self.plan.sensors:
                if sensor.source.field == field:
                    first, stop = sensor.columns
                    cols.append(np.arange(first, stop))
                    pos.append(sensor.source.positions.ravel())
            out.append((field, wp.array(np.concatenate(cols).astype(np.int32), dtype=wp.int32),
                        wp.array(np.concatenate(pos).astype(np.int32), dtype=wp.int32)))
        return out

    def _noise_tables(self, bounds: Mapping[str, tuple[np.ndarray, np.ndarray]], key_episodes: int) -> None:
        plan = self.plan
        noisy = [(c, s) for c, s in enumerate(plan.sensors) if s.noise is not None]
        self.noisy_names = [s.name for _, s in noisy]
        v_col: list[int] = []
        v_sensor: list[int] = []
        v_index: list[int] = []
        v_low: list[float] = []
        v_high: list[float] = []
        s_taken: list[int] = []
        s_period: list[int] = []
        s_stride: list[int] = []
        s_first: list[int] = []
        s_stop: list[int] = []
        s_leveled: list[int] = []
        taken: list[int] = []
        codes: list[int] = []
        tags: list[int] = []
        modes: list[int] = []
        per_value: list[int] = []
        params: list[np.ndarray] = []
        slots: list[int] = []
        self.episode_slots: list[tuple[int, int, int, int]] = []  # (noisy sensor, stream, first slot, values)
        self.param_slots: list[ParamSlot] = []  # stages with parameters drawn per episode
        self.turn_slots: list[TurnSlot] = []  # misalign stages
        s_turns: list[int] = []
        st_drawn: list[int] = []
        nslot = 0
        size = max([1, *(s.columns[1] - s.columns[0] for _, s in noisy)])
        self.size = size
        gaps = max([0, *(largest_gap(s.timing) for _, s in noisy if isinstance(s.timing, DrawnTiming))])
        alphas: list[np.ndarray] = []  # per stage, a low-pass's coefficient per gap (drawn schedules)
        for n, (_, sensor) in enumerate(noisy):
            timing, program = sensor.timing, sensor.noise
            assert isinstance(program, NoiseProgram)
            first, stop = sensor.columns
            low, high = bounds.get(sensor.name, _NO_BOUND)
            v_col += range(first, stop)
            v_sensor += [n] * (stop - first)
            v_index += range(stop - first)
            v_low += list(np.broadcast_to(np.asarray(low, np.float64), sensor.shape).ravel())
            v_high += list(np.broadcast_to(np.asarray(high, np.float64), sensor.shape).ravel())
            s_taken.append(len(taken))
            if isinstance(timing, FixedTiming):
                taken += timing.taken.astype(np.int32).tolist()
                s_period.append(timing.period)
            else:  # a drawn schedule: the steps it samples are `due`'s, per world
                taken.append(1)
                s_period.append(1)
            s_stride.append(program.stride)
            s_first.append(len(codes))
            turns = 0
            for step in program.steps:
                codes.append(STAGES[step.stage][0])
                tags.append(step.stream << 24)
                options = dict(step.options)
                modes.append(_DROPOUT_MODES.get(options.get("mode", "hold"), 0))
                per_value.append(int(options.get("per") == "value"))
                slots.append(nslot)
                if step.stage in EPISODE_DRAWS:
                    self.episode_slots.append((n, step.stream, nslot, stop - first))
                    nslot += stop - first
                st_drawn.append(nslot if step.drawn and STAGES[step.stage][1] else -1)
                if st_drawn[-1] >= 0:
                    self.param_slots.append(ParamSlot(n, step.stream, step, stop - first, program.stride, nslot))
                    nslot += PARAM_SLOTS * size
                if step.stage == "misalign":  # its 3-vectors: consecutive values (the shape's last axis)
                    self.turn_slots.append(TurnSlot(n, step.stream, nslot, turns,
                                                    tuple(range(len(v_col) - (stop - first), len(v_col), 3))))
                    nslot += 9
                    turns += 1
                block = np.zeros((3, size))
                block[:, :stop - first] = _stage_params(step, stop - first, program.stride, plan.timestep)
                params.append(block)
                table = np.zeros((gaps + 1, size))
                if step.stage == "lowpass" and isinstance(timing, DrawnTiming):
                    for gap in range(gaps + 1):
                        table[gap, :stop - first] = _stage_params(step, stop - first, gap, plan.timestep)[0]
                alphas.append(table)
            s_stop.append(len(codes))
            s_leveled.append(int(program.leveled))
            s_turns.append(turns)
        i32 = lambda xs: wp.array(np.asarray(xs, np.int32).reshape(-1), dtype=wp.int32)  # noqa: E731
        f64 = lambda xs: wp.array(np.asarray(xs, np.float64).reshape(-1), dtype=wp.float64)  # noqa: E731
        self._values = len(v_col)
        self._tables = [i32(v_col), i32(v_sensor), i32(v_index), f64(v_low), f64(v_high), i32(s_taken),
                        i32(s_period), wp.array(np.asarray(s_stride, np.int64), dtype=wp.int64), i32(s_first),
                        i32(s_stop), i32(s_leveled), i32(taken), i32(codes),
                        wp.array(np.asarray(tags, np.uint32), dtype=wp.uint32), i32(modes), i32(per_value),
                        i32(slots), wp.array(np.asarray(params, np.float64).reshape(-1, 3, size), dtype=wp.float64)]
        # the episode keys: the noisy sensors', then the clean drawn ones' (their schedules')
        clean = [s.name for s in plan.sensors if s.noise is None and isinstance(s.timing, DrawnTiming)]
        self.key_names = self.noisy_names + clean
        self.key_slots = {name: k for k, name in enumerate(self.key_names)}
        self.noisy_slots = {name: k for k, name in enumerate(self.noisy_names)}
        nsim, nnoisy, nkeyed = plan.nsim, max(1, len(noisy)), max(1, len(self.key_names))
        self.keys = wp.zeros((nsim, nkeyed, 2), dtype=wp.uint64)
        self.key_table = wp.zeros((nsim, key_episodes, nkeyed, 2), dtype=wp.uint64)
        self.due = wp.full((nsim, nnoisy), -1, dtype=wp.int32)
        self._alphas = wp.array(np.asarray(alphas, np.float64).reshape(-1, gaps + 1, size), dtype=wp.float64) \
            if alphas else wp.zeros((1, 1, 1), dtype=wp.float64)
        self.episodes = wp.zeros(nsim, dtype=wp.int32)
        self.level = wp.ones(nsim, dtype=wp.float64)
        self.next_level = wp.ones(1, dtype=wp.float64)
        self.state = wp.zeros((nsim, max(1, len(codes)), size), dtype=wp.float64)
        self.walked = wp.zeros((nsim, max(1, len(codes)), size), dtype=wp.int64)
        self.episode_table = wp.zeros((nsim, key_episodes, max(1, nslot)), dtype=wp.float64)
        self.drawn = wp.zeros((nsim, max(1, nslot)), dtype=wp.float64)
        self._segments = 1 + max([0, *s_turns])  # noise launches per record: misalign stages split them
        work = (nsim, len(v_col) if self._segments > 1 else 1)  # values between segments (float64)
        self._episode = [i32(s_turns), i32(st_drawn), wp.zeros(work, dtype=wp.float64)]
        self._turns = Turns(self.turn_slots, self.device)

    def _outputs(self) -> dict[str, wp.array]:
        """Each sensor's output: a view of the gather (plain) or of the reduced blocks, (nworld, *output)."""
        plan, out = self.plan, {}
        self._blocks = []
        at = 0
        for block in plan.reads.blocks:
            width = block.positions.size // block.buffer
            self._blocks.append((int(block.positions[0]), block.buffer, width, _AGGREGATOR_CODES[block.aggregator], at))
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
        for field, cols, pos in self._fields:
            wp.launch(_gather, dim=(n, cols.shape[0]), inputs=[fields[field], cols, pos, steps, mask, rows],
                      outputs=[self.history], device=self.device)
        if self._drawn is not None:
            self._drawn.record(steps, mask, self.keys, self.due)
        for segment in range(self._segments if self._values else 0):
            if segment:  # the misalign stages ending the previous segment
                turn(self._turns, segment - 1, steps, mask, [self._tables[i] for i in (5, 6, 11)], self.drawn,
                     self._episode[-1])
            wp.launch(_noise, dim=(n, self._values),
                      inputs=[steps, mask, rows, self.history, *self._tables, self.keys, self.level, self.drawn,
                              self.state, self.walked, self.due, self._alphas, self.z, segment, *self._episode],
                      device=self.device)

    def reset(self, mask: wp.array, fields: Mapping[str, wp.array], steps: wp.array) -> None:
        """Start the masked worlds' episodes (their `steps` already 0 and `fields` their reset state)."""
        n = self.plan.nsim
        wp.launch(_start, dim=(n, self.keys.shape[1]),
                  inputs=[mask, self.episodes, self.key_table, self.keys, self.next_level, self.level],
                  device=self.device)
        wp.launch(_start_drawn, dim=(n, self.drawn.shape[1]), inputs=[mask, self.episodes, self.episode_table],
                  outputs=[self.drawn], device=self.device)
        wp.launch(_count_episode, dim=n, inputs=[mask, self.episodes], device=self.device)
        self.record(fields, steps, mask)
        wp.launch(_pad, dim=(n, self.plan.width),
                  inputs=[mask, int(self.plan.pad_with_initial_value), self.plan.rows, self.history], device=self.device)

    def set_keys(self, worlds: np.ndarray, keys: np.ndarray, values: np.ndarray) -> None:
        """The key tables of `worlds` (their rows of `key_table` and `episode_table`), from the host."""
        if worlds.size:
            wp.launch(_scatter_keys, dim=(worlds.size, self.key_table.shape[1]),
                      inputs=[wp.array(worlds.astype(np.int32), dtype=wp.int32, device=self.device),
                              wp.array(keys, dtype=wp.uint64, device=self.device),
                              wp.array(values, dtype=wp.float64, device=self.device)],
                      outputs=[self.key_table, self.episode_table], device=self.device)

    def read(self, steps: wp.array) -> dict[str, wp.array]:
        """Every sensor's read at each world's step `steps` (a multiple of the plan's substeps)."""
        plan, reads = self.plan, self.plan.reads
        n = plan.nsim
        if reads.column.size:
            wp.launch(_gather_reads, dim=(n, reads.column.size),
                      inputs=[steps, plan.rows, reads.cycle, plan.substeps, reads.nphase, self._delta,
                              self._column, self.history], outputs=[self.gathered], device=self.device)
        for first, buffer, width, code, at in self._blocks:
            wp.launch(_reduce, dim=(n, width), inputs=[self.gathered, first, buffer, width, code],
                      outputs=[self.reduced, at], device=self.device)
        if self._drawn is not None:
            self._drawn.read(steps, self.history)
            for first, buffer, width, name, at in self._drawn.blocks:
                wp.launch(_reduce, dim=(n, width), inputs=[self._drawn.gathered, first, buffer, width,
                                                           _AGGREGATOR_CODES[name]],
                          outputs=[self._drawn.reduced, at], device=self.device)
        return self.outputs
