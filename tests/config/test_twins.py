"""Clean twins: a sensor's noise-free, latency-free copy under another key, declared once."""

from __future__ import annotations

import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError

from conftest import MODELS

TERRAIN = str(MODELS / "terrain.xml")

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


_DISABLED_CONSTANT = ("sensors:\n  m: {kind: mass, element: body:base, constant: true, enabled: false, twin: m_clean}\n"
                      "  q: {kind: qpos, element: joint:hip_f}\n")


def test_the_twin_of_a_disabled_sensor_is_checked_for_the_batch_at_its_source_line() -> None:
    """The twin runs while its source is disabled: what the batch cannot run in it is refused where the
    source wrote it, by validate and by the batch's build alike, never dropped from the observations."""
    suite = sensorcfg.loads(_DISABLED_CONSTANT, file="f.yaml")
    expected = ["f.yaml:2:49: error: sensors.m.constant: its clean twin 'm_clean' runs (enabled; 'twin: false' "
                "drops it): a BatchEnvironment reads mjData fields across simulations, not model constants; remove "
                "it, or use the single-simulation Environment"]
    assert [p.format() for p in suite.check(TERRAIN, batch=True)] == expected
    with pytest.raises(SuiteError) as info:
        suite.build(TERRAIN, batch=True)
    assert [p.format() for p in info.value.problems] == expected
    assert list(suite.build(TERRAIN)) == ["m", "m_clean", "q"]  # the single Environment reads it


@pytest.mark.parametrize("kind, batch", [("velocimeter", False), ("velocimeter", True), ("framepos", True)])
def test_constant_on_a_mujoco_sensor_kind_is_refused_by_validate_and_batch_alike(kind: str, batch: bool) -> None:
    suite = sensorcfg.loads(f"sensors:\n  v: {{kind: {kind}, element: body:base, constant: true}}\n", file="f.yaml")
    assert [p.format() for p in suite.check(TERRAIN, batch=batch)] == [
        f"f.yaml:2:{45 + len(kind)}: error: sensors.v.constant: 'constant' is for features of model fields; a sensor "
        f"of kind {kind!r} (MuJoCo's {kind} sensor, read from the simulation) is not one: remove it"]


def test_constant_on_state_gets_one_message_with_batch() -> None:
    suite = sensorcfg.loads("sensors:\n  q: {kind: qpos, element: joint:hip_f, constant: true}\n", file="f.yaml")
    assert [p.format() for p in suite.check(TERRAIN, batch=True)] == [
        "f.yaml:2:51: error: sensors.q.constant: 'qpos' changes with the simulation; 'constant: true' is for model "
        "constants: remove it"]
