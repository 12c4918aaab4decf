"""The feature bank applies noise with the same numbers as each sensor's own per-sample pipeline."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from pydantic import TypeAdapter

import sensorcfg
from sensorcfg import assets
from sensorcfg.config.noise import NoiseStage
from sensorcfg.noise import build_noise
from sensorcfg.runtime import updater as updater_module

STAGES = TypeAdapter(list[NoiseStage])
MODEL = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
PIPELINES = [
    [{"type": "gaussian", "std": 0.1}],
    [{"type": "gaussian", "std": 0.1}, {"type": "bias", "std": 1.0}],
    [{"type": "scale", "std": 0.1}, {"type": "uniform", "low": -1, "high": 1}, {"type": "quantize", "step": 0.05}],
    [{"type": "random_walk", "std": 0.3, "correlation_time": "20ms"}, {"type": "clip", "min": -0.5}],
    [{"type": "bias", "mean": 0.2}, {"type": "outlier", "p": 0.2, "scale": 3}, {"type": "clip", "max": 0.3}],
    [{"type": "random_walk", "std": 0.3}, {"type": "gaussian", "std": 0.2}],
]
SENSORS = [("qpos", ["joint:shoulder", "joint:elbow"]), ("sensordata", "sensor:imu_gyro"),
           ("xpos", "site:hand_site"), ("qvel", "joint:wrist")]


def run(config: dict, n: int, pad: bool, bank: bool, monkeypatch: pytest.MonkeyPatch) -> list[dict]:
    with monkeypatch.context() as patch:
        if not bank:
            patch.setattr(updater_module.Updater, "_make_bank", lambda self, physics: None)
        observables = {}
        for name, (kind, element, interval, delay, buffer, aggregator, _) in config.items():
            observables[name] = sensorcfg.Feature(kind, element, update_interval=interval, delay=delay,
                                                  buffer_size=buffer, aggregator=aggregator)
            observables[name].enabled = True
        data = mujoco.MjData(MODEL)
        physics = sensorcfg.Physics(MODEL, data)
        updater = sensorcfg.Updater(observables, n, pad_with_initial_value=pad)
        updater.reset(physics, np.random.RandomState(0))  # binds: shapes are known now
        for name, (*_, stages) in config.items():
            spec = observables[name].array_spec
            observables[name].noise = build_noise(STAGES.validate_python(stages), spec.shape, spec.dtype,
                                                  MODEL.opt.timestep)
        data.qvel[:] = 0.5
        out = []
        for episode in range(2):
            updater.reset(physics, np.random.RandomState(episode))
            assert (updater._bank is not None and updater._bank.noise is not None) == bank
            out.append(updater.get_observation())
            for _ in range(90):
                updater.prepare_for_next_control_step()
                for _ in range(n):
                    mujoco.mj_step(MODEL, data)
                    updater.update()
                out.append(updater.get_observation())
        return out


@pytest.mark.parametrize("seed", range(12))
def test_bank_noise_is_the_per_sample_noise(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(seed)
    config = {}
    for j, (kind, element) in enumerate(SENSORS):
        config[f"s{j}"] = (kind, element, int(rng.integers(1, 5)), int(rng.integers(0, 6)), int(rng.integers(1, 4)),
                           [None, "mean", "max", "median"][rng.integers(4)], PIPELINES[rng.integers(len(PIPELINES))])
    n, pad = int(rng.integers(1, 7)), bool(rng.integers(2))
    banked = run(config, n, pad, True, monkeypatch)
    reference = run(config, n, pad, False, monkeypatch)
    for step, (a, b) in enumerate(zip(banked, reference)):
        for name in a:
            assert np.array_equal(a[name], b[name], equal_nan=True), (step, name, config[name])
    assert not all(np.array_equal(banked[1][k], banked[-1][k]) for k in banked[1])  # the noise is not constant


def test_pipelines_the_bank_cannot_run_stay_per_sample(monkeypatch: pytest.MonkeyPatch) -> None:
    config = {"s": ("qpos", "joint:shoulder", 1, 0, 1, None, [{"type": "lowpass", "cutoff": "20Hz"}])}
    observables = {"s": sensorcfg.Feature("qpos", "joint:shoulder")}
    observables["s"].enabled = True
    physics = sensorcfg.Physics(MODEL)
    updater = sensorcfg.Updater(observables, 2)
    updater.reset(physics, np.random.RandomState(0))
    spec = observables["s"].array_spec
    observables["s"].noise = build_noise(STAGES.validate_python(config["s"][-1]), spec.shape, spec.dtype, 0.002)
    updater.reset(physics, np.random.RandomState(0))
    assert updater._bank is None


@pytest.mark.parametrize("stages", [
    pytest.param([{"type": "bias", "std": 0.1}, {"type": "bias", "mean": 0.2, "std": 0.05}], id="bias-bias"),
    pytest.param([{"type": "scale", "std": 0.1}, {"type": "bias", "std": 0.1}, {"type": "bias", "low": -1, "high": 1},
                  {"type": "clip", "max": 0.6}], id="scale-bias-bias-clip"),
])
def test_a_sum_of_biases_alone_is_added(stages: list, monkeypatch: pytest.MonkeyPatch) -> None:
    """Adjacent biases fuse into one term that draws no per-sample numbers: the bank still adds its values
    (it once wrote only the terms of chunks that drew some numbers, reading x + -0.0 = x)."""
    config = {"s": ("qvel", "joint:wrist", 2, 1, 2, None, stages)}
    banked = run(config, 3, False, True, monkeypatch)
    reference = run(config, 3, False, False, monkeypatch)
    for step, (a, b) in enumerate(zip(banked, reference)):
        assert np.array_equal(a["s"], b["s"]), step
    assert not np.isin(banked[-1]["s"], [0.0, 0.5]).any()  # neither the pad nor the raw qvel: the biases added
