"""Gaussian noise given as a density (per square-root hertz): the std per sample follows the sensor's rate."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sensorcfg

from conftest import MODELS

TERRAIN = str(MODELS / "terrain.xml")


def _run(noise: str, interval: int, steps: int = 50) -> np.ndarray:
    suite = sensorcfg.loads(f"sensors:\n  g: {{kind: qvel, element: joint:hip_f, interval: {interval}, "
                            f"noise: [{noise}]}}\n")
    env = sensorcfg.Environment(TERRAIN, suite, seed=3, physics_steps_per_control_step=interval)
    env.reset()
    return np.array([env.step(np.full(2, 0.3)).observation["g"] for _ in range(steps)])


@pytest.mark.parametrize("interval", [1, 5])
def test_a_density_is_the_std_at_the_sensors_rate(interval: int) -> None:
    std = 0.002 * math.sqrt(1 / (interval * 0.002))  # density * sqrt(rate), the terrain model's 2 ms steps
    np.testing.assert_array_equal(_run("{type: gaussian, density: 0.002}", interval),
                                  _run(f"{{type: gaussian, std: {std!r}}}", interval))


def test_std_and_density_together_or_a_drawn_interval_are_problems() -> None:
    with pytest.raises(sensorcfg.SuiteError, match="gaussian takes std .per sample. or density"):
        sensorcfg.loads("sensors:\n  g: {kind: qpos, element: joint:hip_f, noise: [{type: gaussian, std: 1, "
                        "density: 1}]}\n")
    problems = sensorcfg.loads("sensors:\n  g: {kind: qpos, element: joint:hip_f, interval: {uniform: [1, 3]},\n"
                               "      noise: [{type: gaussian, density: 0.001}]}\n", file="f.yaml").check(TERRAIN)
    assert [p.format() for p in problems] == [
        "f.yaml:3:41: error: sensors.g.noise.0.density: a noise density needs a fixed interval (the std per "
        "sample follows the sample rate); give std instead, or a fixed interval"]
