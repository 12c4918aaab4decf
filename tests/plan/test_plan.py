"""The suite plan (`sensorcfg.plan`): its records are complete and mean what docs/architecture.md says.

`PlanExecutor` below is a second engine written only from the plan's records and documented conventions
(no batch or runtime module): it runs noise-free fixed schedules on its own MjData and must read exactly
what the single-simulation `Environment` reads.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.noise import build_noise
from sensorcfg.observables.aggregators import AGGREGATORS
from sensorcfg.physics import Physics
from sensorcfg.plan import FixedTiming, SuitePlan
from sensorcfg.plan.bind import bind, plan_suite

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


class PlanExecutor:
    """One simulation run from a plan: a step-indexed history, every column recorded every step."""

    def __init__(self, plan: SuitePlan, model: mujoco.MjModel):
        self.plan, self.model, self.data = plan, model, mujoco.MjData(model)
        self.history = np.zeros((plan.rows, plan.width))
        self.reset_row = 0  # the global row of the episode's step 0
        self.step = 0

    def row(self) -> np.ndarray:
        return np.concatenate([np.ravel(getattr(self.data, s.source.field))[s.source.positions.ravel()]
                               for s in self.plan.sensors])

    def reset(self) -> dict[str, np.ndarray]:
        mujoco.mj_resetData(self.model, self.data)
        mujoco.mj_forward(self.model, self.data)
        sample = self.row()
        self.history[:] = sample if self.plan.pad_with_initial_value else 0.0
        self.history[self.reset_row % self.plan.rows] = sample
        self.step = 0
        return self.read()

    def control_step(self, ctrl: np.ndarray) -> dict[str, np.ndarray]:
        self.data.ctrl[:] = ctrl
        for _ in range(self.plan.substeps):
            mujoco.mj_step(self.model, self.data)
            self.step += 1
            self.history[(self.reset_row + self.step) % self.plan.rows] = self.row()
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
            reduced = AGGREGATORS[block.aggregator].reduce(values[block.positions].reshape(block.buffer, -1))
            for member in block.outputs:
                sensor = plan.sensors[member.sensor]
                out[sensor.name] = reduced[slice(*member.columns)].reshape(sensor.output)
        return out


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
