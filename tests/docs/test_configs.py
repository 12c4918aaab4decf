"""Every example suite builds on the bundled robot and runs through the Updater."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.assets import path as asset_path

from conftest import ROOT

SUITES = sorted((ROOT / "configs").glob("*.yaml")) + [asset_path("demo.yaml")]
CONTROL_STEPS = 25


def simulate(suite: sensorcfg.Suite, seed: int = 0, control_steps: int = CONTROL_STEPS):
    """Run the suite's observables with sinusoidal controls; the observation after each control step."""
    model = mujoco.MjModel.from_xml_path(suite.model)
    observables = suite.build(model)
    physics = sensorcfg.Physics(model)
    updater = sensorcfg.Updater(observables, **suite.updater_kwargs(model))
    updater.reset(physics, np.random.RandomState(seed))
    history = []
    for k in range(control_steps):
        physics.data.ctrl[:] = 0.5 * np.sin(0.3 * k + np.arange(model.nu))
        updater.prepare_for_next_control_step()
        for _ in range(updater.physics_steps_per_control_step):
            mujoco.mj_step(physics.model, physics.data)
            updater.update()
        history.append(updater.get_observation())
    return observables, updater, history


def test_there_are_the_four_example_suites() -> None:
    assert {p.stem for p in SUITES} >= {"proprioception", "imu", "vision", "sim2real", "demo"}


@pytest.mark.parametrize("path", SUITES, ids=lambda p: p.name)
def test_suite_builds_and_runs(path: Path) -> None:
    suite = sensorcfg.load(path)
    assert suite.model is not None and Path(suite.model).is_file()
    assert suite.check(import_callables=True) == []
    observables, updater, history = simulate(suite)
    enabled = [name for name, o in observables.items() if o.enabled]
    assert list(observables) == list(suite.sensors)
    spec = updater.observation_spec()
    for obs in history:
        assert list(obs) == enabled
        for name, value in obs.items():
            assert value.shape == spec[name].shape, name
            assert value.dtype == spec[name].dtype, name
            if np.issubdtype(value.dtype, np.floating):
                assert np.isfinite(value).all(), name
    moving = [name for name in enabled if not np.array_equal(history[2][name], history[-1][name])]
    assert moving, "no observation changed while the robot moved"


def test_sim2real_is_proprioception_with_noise_and_latency() -> None:
    clean, noisy = sensorcfg.load(ROOT / "configs" / "proprioception.yaml"), sensorcfg.load(ROOT / "configs" / "sim2real.yaml")
    assert list(noisy.sensors) == [n for n in clean.sensors if n != "base_height"]
    _, _, clean_history = simulate(clean)
    _, _, noisy_history = simulate(noisy)
    clean_q = np.array([o["arm_qpos"] for o in clean_history])
    noisy_q = np.array([o["arm_qpos"] for o in noisy_history])
    error = noisy_q - clean_q
    # the same motion... (a 1-3 step latency alone moves it by up to 0.098 here; a bias of std 0.01 and
    # a gaussian of std 0.002 add at most 5 standard deviations of each: 0.15 bounds it)
    assert np.abs(error).max() < 0.15
    assert np.abs(error).max() > 1e-3  # ...seen through noise, a bias and a delay
    np.testing.assert_allclose(noisy_q / 0.001, np.round(noisy_q / 0.001), atol=1e-6)  # quantized to 1e-3
    forces = np.array([o["motor_force"] for o in noisy_history])
    assert forces.min() >= -25 and forces.max() <= 25


def test_sim2real_noise_is_seeded() -> None:
    suite = sensorcfg.load(ROOT / "configs" / "sim2real.yaml")
    first = simulate(suite, seed=3, control_steps=5)[2]
    again = simulate(suite, seed=3, control_steps=5)[2]
    other = simulate(suite, seed=4, control_steps=5)[2]
    np.testing.assert_array_equal(first[-1]["arm_qvel"], again[-1]["arm_qvel"])
    assert not np.array_equal(first[-1]["arm_qvel"], other[-1]["arm_qvel"])


def test_vision_suite_renders_images() -> None:
    _, _, history = simulate(sensorcfg.load(ROOT / "configs" / "vision.yaml"), control_steps=6)
    last = history[-1]
    assert last["wrist_rgb"].shape == (1, 48, 64, 3) and last["wrist_rgb"].std() > 0
    assert last["wrist_depth"].dtype == np.float32 and (last["wrist_depth"] > 0).any()
    assert last["overview_segmentation"].shape == (1, 60, 80, 2)
