"""Clean twins: a sensor's noise-free, latency-free copy under another key, declared once."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError

TERRAIN = str(Path(__file__).parent / "models" / "terrain.xml")

SUITE = """\
options: {control_interval: 10, strip_singleton_buffer_dim: true}
defaults: {twin: "{name}_clean"}
sensors:
  base_lin_vel:
    kind: velocimeter
    element: body:base
    delay: 4
    interval: 5
    noise: [{type: gaussian, std: 0.1}, {type: bias, std: 0.2}]
  joints:
    kind: qpos
    element: ["joint:hip_f", "joint:hip_r"]
    noise: [{type: gaussian, std: 0.01}]
    twin: joints_true
  touch:
    kind: contact
    element: geom:FL
    buffer: 10
    aggregator: max
    twin: false
"""


def test_twins_are_clean_views_read_at_the_control_step() -> None:
    suite = sensorcfg.loads(SUITE)
    assert list(suite.sensors) == ["base_lin_vel", "base_lin_vel_clean", "joints", "joints_true", "touch"]
    env = sensorcfg.Environment(TERRAIN, suite, seed=0)
    model = env.physics.model
    assert model.nsensor == 2  # the twin reads its source's MuJoCo sensor: none added for it
    env.reset()
    rng = np.random.default_rng(0)
    for _ in range(20):
        obs = env.step(rng.uniform(-1, 1, 2)).observation
        data = env.physics.data
        adr = model.sensor("sensorcfg:base_lin_vel:0").adr[0]
        np.testing.assert_array_equal(obs["base_lin_vel_clean"], data.sensordata[adr:adr + 3])  # at the read
        np.testing.assert_array_equal(obs["joints_true"], data.qpos[[7, 8]])
        assert not np.array_equal(obs["joints"], obs["joints_true"])
        assert not np.allclose(obs["base_lin_vel"], obs["base_lin_vel_clean"], atol=0.05)


def test_a_twin_named_like_a_sensor_is_a_problem_at_its_line() -> None:
    with pytest.raises(SuiteError) as info:
        sensorcfg.loads("sensors:\n  a: {kind: qpos, element: joint:hip_f, twin: b}\n"
                        "  b: {kind: qvel, element: joint:hip_f}\n", file="t.yaml")
    assert str(info.value) == "t.yaml:2:47: error: sensors.a.twin: twin 'b' is already a sensor's name; choose another"
