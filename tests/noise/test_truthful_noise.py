"""Truthful noise: a sample's value depends on the seed, the sensor and the sample's time, never on which
other samples were taken (docs/noise.md).

Property: for random sensors with every noise stage, each value a read shows is bit-identical whatever
the buffer size and the aggregator of that sensor. Fixed schedules, so a window's sample indices are
known in closed form (`plan.schedule`); the bank (banked stages) and the per-sample path (low-pass,
dropout, custom) both run. The batch runs each simulation as the single Updater (tests/batch/test_batch.py).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_batch import NOISE

import sensorcfg
from sensorcfg import assets
from sensorcfg.noise import build_noise
from sensorcfg.observables.aggregators import AGGREGATORS
from sensorcfg.plan.schedule import Schedule

MODEL = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))


def salt(value, random_state):
    """A custom stage: dm_control's corruptor signature, its own sequential random state."""
    return value + random_state.normal(0.0, 0.01, value.shape)


CATALOG = [*NOISE, {"type": "custom", "callable": salt}]  # every stage type (the batch tests' list, and custom)


def run(stages: list, interval: int, delay: int, buffer: int, aggregator: str | None, n: int, seed: int,
        steps: int) -> list[np.ndarray]:
    """The observations of one noisy sensor (next to a noisy neighbour) over `steps` control steps."""
    target = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow", "joint:finger_slide"],
                               update_interval=interval, delay=delay, buffer_size=buffer, aggregator=aggregator)
    neighbour = sensorcfg.Feature("qvel", "joint:elbow", buffer_size=2)
    observables = {"neighbour": neighbour, "target": target}
    for obs in observables.values():
        obs.enabled = True
    target.noise = build_noise(stages, (3,), np.float64, MODEL.opt.timestep)
    neighbour.noise = build_noise([{"type": "gaussian", "std": 1.0}], (1,), np.float64, MODEL.opt.timestep)
    data = mujoco.MjData(MODEL)
    physics = sensorcfg.Physics(MODEL, data)
    updater = sensorcfg.Updater(observables, n)
    updater.reset(physics, np.random.RandomState(seed))
    controls = np.random.default_rng(seed).uniform(-1, 1, (steps, MODEL.nu))
    out = [updater.get_observation()["target"]]
    for ctrl in controls:
        data.ctrl[:] = ctrl
        updater.prepare_for_next_control_step()
        for _ in range(n):
            mujoco.mj_step(MODEL, data)
            updater.update()
        out.append(updater.get_observation()["target"])
    return out


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(stages=st.lists(st.sampled_from(CATALOG), min_size=1, max_size=4),
       interval=st.integers(1, 4), delay=st.integers(0, 6), n=st.integers(1, 5),
       buffers=st.lists(st.integers(1, 6), min_size=2, max_size=2, unique=True),
       aggregator=st.sampled_from(sorted(AGGREGATORS)), seed=st.integers(0, 2**16))
def test_a_sample_reads_the_same_whatever_the_buffer_and_aggregator(stages, interval, delay, n, buffers,
                                                                    aggregator, seed):
    steps = 24
    shown: dict[int, np.ndarray] = {}  # sample index -> the value every read shows for it
    for buffer in buffers:
        windows = run(stages, interval, delay, buffer, None, n, seed, steps)
        schedule = Schedule(interval, delay, buffer, n)
        for c, window in enumerate(windows):
            for k, value in zip(schedule.window(c * n).tolist(), window):
                if k < 0:
                    continue
                if k in shown:
                    assert np.array_equal(shown[k], value, equal_nan=True), (k, buffer, shown[k], value)
                else:
                    shown[k] = value
        aggregated = run(stages, interval, delay, buffer, aggregator, n, seed, steps)
        for c, (window, value) in enumerate(zip(windows, aggregated)):
            expected = AGGREGATORS[aggregator](window)
            assert np.array_equal(value, expected, equal_nan=True), (c, aggregator, buffer)
    assert len(shown) > 1


@pytest.mark.parametrize("stage", [s for s in CATALOG if s["type"] in ("lowpass", "dropout", "custom")])
def test_stateful_stages_see_every_sample_of_the_schedule(stage):
    # with a buffer of one and reads every 5 steps, a noise-free sensor sampling every step takes one
    # sample per read; a stateful stage makes it take all of them (so its state is the real one)
    counts = {}
    for stages in ([], [stage]):
        observable = sensorcfg.Feature("qpos", "joint:shoulder")
        observable.enabled = True
        observable.noise = build_noise(stages, (1,), np.float64, MODEL.opt.timestep) if stages else None
        updater = sensorcfg.Updater({"s": observable}, 5)
        physics = sensorcfg.Physics(MODEL, mujoco.MjData(MODEL))
        updater.reset(physics, np.random.RandomState(0))
        for _ in range(4):
            updater.prepare_for_next_control_step()
            for _ in range(5):
                mujoco.mj_step(MODEL, physics.data)
                updater.update()
        counts[bool(stages)] = updater.samples_taken()["s"]
    stateful = stage["type"] != "dropout" or stage["mode"] == "hold"
    assert counts[False] == 5 and counts[True] == (21 if stateful else 5)
