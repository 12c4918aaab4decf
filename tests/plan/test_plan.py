"""The suite plan (`sensorcfg.plan`): its records are complete and mean what docs/architecture.md says.

`PlanExecutor` below is a second engine written only from the plan's records and documented conventions
(`sensorcfg.plan`, `sensorcfg.draws` and `sensorcfg.noise.streams`, no batch, runtime or noise-stage module):
it runs fixed and drawn schedules, every noise stage the Warp engine runs (parameters fixed or drawn per
episode), the episodes' reset draws and noise levels on its own MjData, and must read exactly what the
single-simulation Updater reads.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets, draws
from sensorcfg.noise import build_noise, streams
from sensorcfg.noise.level import leveled, set_level
from sensorcfg.physics import Physics
from sensorcfg.plan import DrawnSteps, DrawnTiming, FixedTiming, NoiseProgram, SuitePlan, episode
from sensorcfg.plan.bind import bind, plan_suite
from sensorcfg.warp.support import STAGES

ROBOT = str(assets.path("robot.xml"))
FEATURES = [
    ("qpos", ["joint:shoulder", "joint:elbow"]),
    ("qvel", "joint:elbow"),
    ("sensordata", "sensor:imu_accel"),
    ("xpos", "site:hand_site"),
    ("xmat", "site:fingertip"),
    ("xquat", "body:hand"),
    ("qfrc_actuator", ["joint:shoulder", "joint:elbow"]),
]


def fixed_suite(seed: int) -> dict[str, sensorcfg.Observable]:
    rng = np.random.default_rng(seed)
    out = {}
    for j in range(int(rng.integers(3, 8))):
        kind, element = FEATURES[int(rng.integers(len(FEATURES)))]
        buffer = int(rng.integers(1, 6)) if rng.random() < 0.8 else int(rng.integers(8, 14))
        out[f"s{j}_{kind}"] = sensorcfg.Feature(
            kind, element, update_interval=int(rng.integers(1, 8)), delay=int(rng.integers(0, 9)),
            buffer_size=buffer, aggregator=[None, None, "min", "max", "sum", "mean", "median"][int(rng.integers(7))])
        out[f"s{j}_{kind}"].enabled = True
    return out


def plan_of(observables, model, nsim: int, substeps: int, pad: bool = False) -> SuitePlan:
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    bound = bind(observables, physics, substeps, False)
    return plan_suite(bound, physics, bound.sources(), nsim, substeps, pad)


def _median(x: np.ndarray) -> np.ndarray:
    """The mean of the middle one or two values along axis 0 (sorted), NaN wherever a NaN is."""
    b = x.shape[0]
    s = x if b <= 2 else np.sort(x, axis=0)
    out = np.add.reduce(s[(b - 1) // 2:b // 2 + 1], 0)
    out = out / (b // 2 + 1 - (b - 1) // 2)
    if b > 2:
        out[np.isnan(s[-1])] = np.nan
    return out


REDUCE = {"min": lambda x: np.minimum.reduce(x, 0), "max": lambda x: np.maximum.reduce(x, 0),
          "sum": lambda x: np.add.reduce(x, 0), "mean": lambda x: np.add.reduce(x, 0) / x.shape[0],
          "median": _median}
_SCHEDULE_KEY = np.array([0, 1 << 63], np.uint64)  # a sensor key xor this: its schedule key


def _per_sample(key: np.ndarray, samples: np.ndarray, stream: int, lane: int, size: int, normal: bool) -> np.ndarray:
    """The per-sample numbers (len(samples), size) of a stage's lane (noise/streams.py)."""
    keys = np.broadcast_to(key, (len(samples), 2))
    return streams.numbers([streams.Draw(keys, np.asarray(samples, np.int64), stream, lane, size, normal)])[0]


def _drawn_steps(steps: DrawnSteps, key: np.ndarray, j: int, lane: int) -> int:
    """Sample j's interval (lane 0) or delay (lane 1): the stream rule of `DrawnSteps`."""
    if steps.kind == "fixed":
        return int(steps.values[0])
    u = _per_sample(key, np.array([j]), 0, lane, 1, False)[0, 0]
    if steps.kind == "uniform":
        return int(steps.values[0] + np.floor(u * (steps.values[1] - steps.values[0] + 1)))
    if not steps.weights.size:
        return int(steps.values[int(np.floor(u * len(steps.values)))])
    at = np.searchsorted(np.cumsum(steps.weights), u, side="right")
    return int(steps.values[min(int(at), len(steps.values) - 1)])


class _Noise:
    """One noisy sensor's program in one episode: its episode's steps (`plan.episode`) and their state."""

    def __init__(self, program: NoiseProgram, key: np.ndarray, level: float):
        self.program, self.key, self.level = program, key, level
        self.steps = episode(program, key)
        self.state: dict[int, np.ndarray] = {}  # per step: a lowpass's state, a dropout's held value
        self.walked: dict[int, tuple[int, np.ndarray]] = {}  # per walk: its last index and state
        self.last = 0  # the step of the previous sample
        self.first = True

    def term(self, k: int, j: int, size: int) -> np.ndarray:
        """What additive step k adds to sample j."""
        at = self.steps[k]
        s = at.step
        if s.stage == "bias":
            return at.values.copy()
        if s.stage == "gaussian":
            term = _per_sample(self.key, np.array([j]), s.stream, 0, size, True)[0] * s.number("std")
            return term + s.number("mean") if "mean" in dict(s.kernel) else term
        if s.stage == "uniform":
            u = _per_sample(self.key, np.array([j]), s.stream, 0, size, False)[0]
            return u * s.number("width") + s.number("low")
        hit = _per_sample(self.key, np.array([j]), s.stream, 0, size, False)[0] < s.number("p")  # outlier
        jump = _per_sample(self.key, np.array([j]), s.stream, 1, size, True)[0] * s.number("scale")
        return np.where(hit, jump, 0.0)

    def __call__(self, raw: np.ndarray, step: int) -> np.ndarray:
        program, j, size = self.program, step // self.program.stride, raw.size
        sums = {first: stop for first, stop in program.sums}
        x, k = raw.copy(), 0
        while k < len(self.steps):
            at = self.steps[k]
            s = at.step
            if k in sums:  # adjacent additive steps: their terms added up first
                total = self.term(k, j, size)
                for other in range(k + 1, sums[k]):
                    total += self.term(other, j, size)
                x = x + total
                k = sums[k]
                continue
            if s.stage in ("gaussian", "uniform", "outlier", "bias"):
                x = x + self.term(k, j, size)
            elif s.stage == "scale":
                x = x * at.values
            elif s.stage == "random_walk":
                last, state = self.walked.get(k, (0, at.values if at.values is not None else np.zeros(size)))
                if j > last:
                    z = _per_sample(self.key, np.arange(last + 1, j + 1), s.stream, 0, size, True) * s.number("c")
                    for row in z:
                        state = state * s.number("a") + row
                self.walked[k] = (j, state)
                x = x + state
            elif s.stage == "quantize":
                x = np.rint(x / s.number("step")) * s.number("step")
            elif s.stage == "clip":
                x = np.minimum(np.maximum(x, s.number("low")), s.number("high"))
            elif s.stage == "dropout":
                per = dict(s.options).get("per") == "value"
                u = _per_sample(self.key, np.array([j]), s.stream, 0, size if per else 1, False)[0]
                lost = np.broadcast_to(u < s.number("p"), (size,))
                mode = dict(s.options).get("mode", "hold")
                if mode == "hold":
                    if self.first:
                        lost = np.zeros(size, bool)
                    x = np.where(lost, self.state.get(k, x), x)
                    self.state[k] = x
                else:
                    x = np.where(lost, 0.0 if mode == "zero" else np.nan, x)
            elif s.stage == "lowpass":
                if self.first:
                    self.state[k] = x
                elif step > self.last:
                    gap = step - self.last
                    alpha = s.number("alphas")[gap] if "alphas" in dict(s.kernel) else s.number("alpha")
                    self.state[k] = self.state[k] + (x - self.state[k]) * alpha
                x = self.state[k]
            elif s.stage == "misalign":
                v, m = x.reshape(-1, 3), at.matrix
                x = np.stack([v[:, 0] * m[i, 0] + v[:, 1] * m[i, 1] + v[:, 2] * m[i, 2] for i in range(3)], 1).ravel()
            k += 1
        self.first, self.last = False, step
        if program.leveled and self.level != 1.0:
            x = raw + self.level * (x - raw)
            if program.bounds is not None:
                x = np.clip(x, *program.bounds)
        return x


class _Drawn:
    """One drawn schedule in one episode: its samples' times and arrivals, drawn as far as asked."""

    def __init__(self, timing: DrawnTiming, key: np.ndarray):
        self.timing, self.key = timing, key ^ _SCHEDULE_KEY
        self.times = [0]
        self.arrivals = [_drawn_steps(timing.delay, self.key, 0, 1)]

    def until(self, step: int) -> None:
        while self.times[-1] <= step:
            j = len(self.times)
            self.times.append(self.times[-1] + _drawn_steps(self.timing.interval, self.key, j, 0))
            self.arrivals.append(self.times[-1] + _drawn_steps(self.timing.delay, self.key, j, 1))

    def window(self, read: int) -> list[int]:
        """The times of the last `buffer` samples delivered by step `read`, by (arrival, time); -1 pads."""
        self.until(read)
        delivered = sorted((a, t) for t, a in zip(self.times, self.arrivals) if a <= read)
        shown = [t for _, t in delivered[-self.timing.buffer:]]
        return [-1] * (self.timing.buffer - len(shown)) + shown


class PlanExecutor:
    """One simulation run from a plan (docs/architecture.md, "The suite plan"): a step-indexed history, every
    column recorded every step, each sensor's nominal samples noised by its program; reads of the read table
    (fixed schedules) and of the drawn schedules' windows. Only `sensorcfg.plan`, `sensorcfg.draws` and
    `sensorcfg.noise.streams` (and numpy)."""

    def __init__(self, plan: SuitePlan, model: mujoco.MjModel):
        self.plan, self.model, self.data = plan, model, mujoco.MjData(model)
        self.history = np.zeros((plan.rows, plan.width))
        self.reset_row = 0  # the global row of the episode's step 0
        self.step = 0
        self.noise: dict[int, _Noise] = {}
        self.drawn: dict[int, _Drawn] = {}

    def row(self) -> np.ndarray:
        return np.concatenate([np.ravel(getattr(self.data, s.source.field))[s.source.positions.ravel()]
                               for s in self.plan.sensors])

    def sampled(self, i: int, step: int) -> bool:
        timing = self.plan.sensors[i].timing
        if isinstance(timing, FixedTiming):
            return step % timing.interval == 0
        self.drawn[i].until(step)
        return step in self.drawn[i].times

    def record(self) -> None:
        values = self.row()
        for i, noise in self.noise.items():
            if self.sampled(i, self.step):
                cols = self.plan.columns(i)
                values[cols] = noise(values[cols], self.step)
        self.history[(self.reset_row + self.step) % self.plan.rows] = values

    def reset(self, random_state: np.random.RandomState | None = None, level: float = 1.0) -> dict[str, np.ndarray]:
        mujoco.mj_resetData(self.model, self.data)
        mujoco.mj_forward(self.model, self.data)
        sensors = self.plan.sensors
        keyed = [i for i, s in enumerate(sensors) if s.noise is not None or isinstance(s.timing, DrawnTiming)]
        entropy = draws.episode_entropy(random_state) if keyed else []
        keys = {i: draws.sensor_key(entropy, sensors[i].name) for i in keyed}
        self.noise = {i: _Noise(sensors[i].noise, keys[i], level) for i in keyed if sensors[i].noise is not None}
        self.drawn = {i: _Drawn(timing, keys[i]) for i in keyed
                      for timing in [sensors[i].timing] if isinstance(timing, DrawnTiming)}
        self.step = 0
        self.record()
        sample = self.history[self.reset_row % self.plan.rows].copy()
        self.pad = sample if self.plan.pad_with_initial_value else np.zeros_like(sample)
        self.history[:] = self.pad
        self.history[self.reset_row % self.plan.rows] = sample
        return self.read()

    def control_step(self, ctrl: np.ndarray) -> dict[str, np.ndarray]:
        self.data.ctrl[:] = ctrl
        for _ in range(self.plan.substeps):
            mujoco.mj_step(self.model, self.data)
            self.step += 1
            self.record()
        return self.read()

    def read(self) -> dict[str, np.ndarray]:
        plan, reads = self.plan, self.plan.reads
        phase = reads.nphase if self.step == 0 else (self.step % reads.cycle) // plan.substeps
        rows = (self.reset_row + self.step + reads.delta[phase]) % plan.rows
        values = self.history[rows, reads.column]
        out = {}
        for plain in reads.plain:
            sensor = plan.sensors[plain.sensor]
            out[sensor.name] = values[plain.positions].reshape(sensor.output)
        for block in reads.blocks:
            reduced = REDUCE[block.aggregator](values[block.positions].reshape(block.buffer, -1))
            for member in block.outputs:
                sensor = plan.sensors[member.sensor]
                out[sensor.name] = reduced[slice(*member.columns)].reshape(sensor.output)
        for i, schedule in self.drawn.items():
            sensor, cols = plan.sensors[i], plan.columns(i)
            window = np.stack([self.history[(self.reset_row + t) % plan.rows, cols] if t >= 0 else self.pad[cols]
                               for t in schedule.window(self.step)])
            if sensor.aggregator is not None:
                window = REDUCE[sensor.aggregator](window)
            out[sensor.name] = window.reshape(sensor.output)
        return {s.name: out[s.name] for s in plan.sensors}


@pytest.mark.parametrize("seed", range(8))
def test_an_engine_written_from_the_plan_reads_what_the_updater_reads(seed: int) -> None:
    model = mujoco.MjModel.from_xml_path(ROBOT)
    substeps, pad = 1 + seed % 3, bool(seed % 2)
    physics = Physics(model)
    updater = sensorcfg.Updater(fixed_suite(seed), substeps, pad_with_initial_value=pad)
    executor = PlanExecutor(plan_of(fixed_suite(seed), model, 1, substeps, pad), model)
    executor.reset_row = 17 + seed  # any global row: reads are relative to the episode's own step 0
    mujoco.mj_resetData(model, physics.data)
    mujoco.mj_forward(model, physics.data)
    updater.reset(physics, np.random.RandomState(0))
    expected, got = updater.get_observation(), executor.reset()
    lo, hi = model.actuator_ctrlrange.T
    for a in np.random.default_rng(seed).uniform(lo, hi, (40, model.nu)):
        physics.data.ctrl[:] = a
        updater.control_step(lambda: mujoco.mj_step(model, physics.data))
        expected, got = updater.get_observation(), executor.control_step(a)
        assert expected.keys() == got.keys()
        for name, value in expected.items():
            assert value.shape == got[name].shape and value.tobytes() == got[name].tobytes(), name


def test_records_are_read_only_and_typed() -> None:
    model = mujoco.MjModel.from_xml_path(ROBOT)
    plan = plan_of(fixed_suite(3), model, 4, 2)
    assert plan.nsim == 4 and plan.substeps == 2 and plan.timestep == model.opt.timestep
    for array in (plan.taken, plan.read_later, plan.reads.delta, plan.reads.column,
                  *(s.source.positions for s in plan.sensors)):
        with pytest.raises(ValueError):
            array.flat[0] = array.flat[0]
    assert plan.rows % plan.reads.cycle == 0
    for sensor in plan.sensors:
        timing = sensor.timing
        assert isinstance(timing, FixedTiming)
        assert plan.rows >= timing.delay + timing.buffer * timing.interval + plan.substeps + 1
        assert plan.rows % timing.period == 0 and timing.taken.shape == (timing.period,)
        assert sensor.columns[1] - sensor.columns[0] == math.prod(sensor.shape)


def test_a_noise_program_holds_each_stage_as_configured() -> None:
    model = mujoco.MjModel.from_xml_path(ROBOT)
    physics = Physics(model)
    obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], update_interval=2)
    obs.reader(physics)
    obs.noise = build_noise([{"type": "gaussian", "std": [0.1, 0.2]}, {"type": "clip", "min": -1, "max": 1},
                             {"type": "dropout", "p": 0.3, "mode": "hold"}, {"type": "scale", "low": 0.9, "high": 1.1}],
                            (2,), np.float64, model.opt.timestep)
    obs.enabled = True
    program = plan_of({"q": obs}, model, 2, 1).sensors[0].noise
    assert program is not None
    assert [(s.stage, s.stream) for s in program.steps] == [("gaussian", 0), ("clip", 1), ("dropout", 2), ("scale", 3)]
    gaussian, clip, dropout, scale = program.steps
    assert gaussian.param("std").tolist() == [0.1, 0.2] and gaussian.param("mean").tolist() == [0.0, 0.0]
    assert clip.param("min").tolist() == [-1.0, -1.0] and clip.param("max").tolist() == [1.0, 1.0]
    assert ("mode", "hold") in dropout.options and dropout.param("p").tolist() == [0.3, 0.3]
    assert scale.param("low").tolist() == [0.9, 0.9]
    assert program.stride == 2 and program.stateful and not program.additive and not program.leveled


U = lambda low, high: {"uniform": [low, high]}  # noqa: E731  a parameter drawn per episode
NOISE = [  # every stage the Warp engine runs (`warp.support.STAGES`), fixed and drawn per episode
    {"type": "gaussian", "std": 0.015}, {"type": "gaussian", "mean": 0.01, "std": U(0.01, 0.03)},
    {"type": "uniform", "low": -0.02, "high": 0.03}, {"type": "uniform", "low": U(-0.03, -0.01), "high": 0.02},
    {"type": "bias", "std": 0.1}, {"type": "bias", "low": U(-0.2, -0.1), "high": 0.3},
    {"type": "scale", "std": 0.05}, {"type": "scale", "mean": U(0.9, 1.1), "std": U(0.0, 0.05)},
    {"type": "random_walk", "std": 0.02, "correlation_time": 0.05}, {"type": "random_walk", "std": U(0.005, 0.02)},
    {"type": "quantize", "step": 0.005}, {"type": "quantize", "step": U(0.001, 0.01)},
    {"type": "clip", "min": -0.4, "max": 0.5}, {"type": "clip", "min": U(-0.6, -0.3)},
    {"type": "dropout", "p": 0.3, "mode": "hold"}, {"type": "dropout", "p": U(0.1, 0.5), "mode": "nan", "per": "value"},
    {"type": "dropout", "p": 0.2, "mode": "zero"},
    {"type": "outlier", "p": 0.1, "scale": 1.0}, {"type": "outlier", "p": U(0.05, 0.2), "scale": U(0.5, 1.0)},
    {"type": "lowpass", "cutoff": 20.0}, {"type": "lowpass", "cutoff": U(5.0, 40.0)},
]
MISALIGN = [{"type": "misalign", "std": 0.05},
            {"type": "misalign", "matrix": [[1.0, 0.02, 0.0], [0.0, 0.98, 0.03], [0.01, 0.0, 1.02]], "std": "2deg"}]
SCALARS = [("qpos", ["joint:shoulder", "joint:elbow"]), ("qvel", "joint:elbow")]
VECTORS = [("sensordata", "sensor:imu_accel"), ("xpos", ["site:hand_site", "site:imu"])]
SCHEDULES = [(draws.UniformSteps(1, 3), 0), (2, draws.UniformSteps(0, 4)),
             (draws.ChoiceSteps((1, 2, 4), (0.5, 0.25, 0.25)), draws.ChoiceSteps((0, 3)))]  # drawn schedules


def noisy_suite(seed: int) -> dict[str, sensorcfg.Observable]:
    """Random sensors, fixed or drawn schedules, each with random noise stages (misalign on 3-vectors), leveled."""
    rng = np.random.default_rng(seed)
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
    out = {}
    for j in range(int(rng.integers(3, 6))):
        vector = rng.random() < 0.5
        kind, element = (VECTORS if vector else SCALARS)[int(rng.integers(2))]
        interval, delay = int(rng.integers(1, 4)), int(rng.integers(0, 4))
        if rng.random() < 0.4:
            interval, delay = SCHEDULES[int(rng.integers(len(SCHEDULES)))]
        obs = sensorcfg.Feature(kind, element, update_interval=interval, delay=delay,
                                buffer_size=int(rng.integers(1, 4)),
                                aggregator=[None, None, "mean", "median", "max"][int(rng.integers(5))])
        obs.reader(physics)
        stages = [NOISE[int(p)] for p in rng.choice(len(NOISE), size=int(rng.integers(1, 5)), replace=False)]
        if vector:
            stages.insert(int(rng.integers(len(stages) + 1)), MISALIGN[int(rng.integers(len(MISALIGN)))])
        obs.noise = build_noise(stages, obs.array_spec.shape, obs.array_spec.dtype, physics.timestep)
        obs.enabled = True
        out[f"s{j}_{kind}"] = obs
    leveled(out)
    return out


def test_the_suites_cover_every_stage_the_warp_engine_runs() -> None:
    assert {s["type"] for s in NOISE + MISALIGN} == set(STAGES)


@pytest.mark.parametrize("seed", range(10))
def test_an_engine_written_from_the_plan_reads_noisy_suites_as_the_updater_does(seed: int) -> None:
    """Noise of every stage, parameters drawn per episode, drawn schedules and noise levels over three episodes:
    the plan's executor reads what the Updater reads, bit for bit."""
    model = mujoco.MjModel.from_xml_path(ROBOT)
    substeps, pad = 1 + seed % 2, bool(seed % 3)
    physics = Physics(model)
    observables = noisy_suite(seed)
    updater = sensorcfg.Updater(observables, substeps, pad_with_initial_value=pad)
    executor = PlanExecutor(plan_of(noisy_suite(seed), model, 1, substeps, pad), model)
    executor.reset_row = 5 + seed
    lo, hi = model.actuator_ctrlrange.T
    actions = np.random.default_rng(seed).uniform(lo, hi, (25, model.nu))
    for e, level in enumerate((1.0, 0.4, 0.0)):
        set_level(observables, level)
        mujoco.mj_resetData(model, physics.data)
        mujoco.mj_forward(model, physics.data)
        updater.reset(physics, np.random.RandomState(100 * e + seed))
        expected, got = updater.get_observation(), executor.reset(np.random.RandomState(100 * e + seed), level)
        for a in actions:
            assert expected.keys() == got.keys()
            for name, value in expected.items():
                assert value.shape == got[name].shape and value.tobytes() == got[name].tobytes(), (e, name)
            physics.data.ctrl[:] = a
            updater.control_step(lambda: mujoco.mj_step(model, physics.data))
            expected, got = updater.get_observation(), executor.control_step(a)


@pytest.mark.parametrize("seed", range(4))
def test_many_episodes_drawn_at_once_are_each_keys_episode(seed: int) -> None:
    """`plan.noise.episodes` (a batch's reset of many simulations, one generator rekeyed) draws what `episode`
    draws for each key alone."""
    from sensorcfg.plan.noise import episodes

    plan = plan_of(noisy_suite(seed), mujoco.MjModel.from_xml_path(ROBOT), 3, 2)
    keys = np.array([draws.sensor_key([seed, i], "s") for i in range(3)], np.uint64)
    for sensor in plan.sensors:
        program = sensor.noise
        assert program is not None
        for got, key in zip(episodes(program, keys), keys, strict=True):
            for g, w in zip(got, episode(program, key), strict=True):
                for part in ("params", "kernel"):  # the step of this episode (parameters drawn per episode)
                    assert [(n, v.tobytes()) for n, v in getattr(g.step, part)] == \
                        [(n, v.tobytes()) for n, v in getattr(w.step, part)]
                for a, b in ((g.values, w.values), (g.matrix, w.matrix)):
                    assert (a is None) == (b is None) and (a is None or a.tobytes() == b.tobytes())


@pytest.mark.parametrize("seed", range(6))
def test_a_records_timing_gives_back_the_schedule_it_was_compiled_from(seed: int) -> None:
    """`Schedule.of` and `Drawn.of` (what an engine executing the plan calls the schedule rules with) make, from a
    sensor's `FixedTiming` or `DrawnTiming`, the bound observable's own schedule: every drawn kind, stateful
    noise included."""
    from sensorcfg.plan.drawn import Drawn
    from sensorcfg.plan.schedule import Schedule

    model = mujoco.MjModel.from_xml_path(ROBOT)
    substeps = 1 + seed % 3
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    bound = bind(noisy_suite(seed), physics, substeps, False)
    plan = plan_suite(bound, physics, bound.sources(), 2, substeps, False)
    for entry, record in zip([*bound.fixed, *bound.drawn], plan.sensors):
        timing = record.timing
        remade = (Schedule.of(timing, substeps) if isinstance(timing, FixedTiming) else Drawn.of(timing, substeps))
        assert remade == entry.schedule and type(remade) is type(entry.schedule), entry.name
        assert remade.every_sample == (record.noise is not None and record.noise.stateful), entry.name
