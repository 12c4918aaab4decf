"""`kind: gravity`: the unit vector along the model's gravity in the element's frame ("projected gravity").

[0, 0, -1] for an upright frame under MuJoCo's default gravity; R^T g/|g| for a frame of rotation R, checked
against the frame's xmat over random orientations; it follows a model's own gravity direction; a model
without gravity is a positioned problem, not a made-up vector.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError
from sensorcfg.physics import Physics

MODEL = """\
<mujoco>
  <option gravity="{gravity}"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <geom type="box" size=".2 .1 .05"/>
      <site name="imu" pos=".05 .02 .03" euler="0 0 30"/>
    </body>
  </worldbody>
</mujoco>
"""
SUITE = """\
options: {strip_singleton_buffer_dim: true}
sensors:
  gravity: {kind: gravity, element: body:base}
  imu_gravity: {kind: gravity, element: site:imu}
  up: {kind: framezaxis, element: body:world, frame: body:base}
"""


def _model(tmp_path: Path, gravity: str = "0 0 -9.81") -> str:
    path = tmp_path / "free.xml"
    path.write_text(MODEL.format(gravity=gravity))
    return str(path)


def _readings(path: str, quats: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray], mujoco.MjModel]:
    """(gravity readings, [base xmat, imu xmat] per orientation) with the base turned to each quaternion."""
    suite = sensorcfg.loads(SUITE)
    model = suite.compile(path)
    physics = Physics(model)
    observables = suite.build(model)
    readers = [observables[name].observation_callable(physics) for name in ("gravity", "imu_gravity")]
    values, frames = [], []
    for quat in quats:
        physics.data.qpos[3:7] = quat / np.linalg.norm(quat)
        mujoco.mj_forward(model, physics.data)
        values.append(np.array([read() for read in readers]))
        frames.append(np.array([physics.data.xmat[model.body("base").id], physics.data.site("imu").xmat]))
    return values, frames, model


def test_an_upright_frame_reads_minus_z(tmp_path: Path) -> None:
    env = sensorcfg.Environment(_model(tmp_path), sensorcfg.loads(SUITE), seed=0)
    obs = env.reset().observation
    np.testing.assert_allclose(obs["gravity"], [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(obs["imu_gravity"], [0, 0, -1], atol=1e-15)
    np.testing.assert_allclose(obs["up"], [0, 0, 1], atol=1e-15)  # framezaxis of the world: the opposite


def test_a_turned_frame_reads_gravity_in_its_own_axes(tmp_path: Path) -> None:
    quats = np.random.default_rng(0).normal(size=(50, 4))
    values, frames, _ = _readings(_model(tmp_path), quats)
    for value, mats in zip(values, frames):
        expected = [m.reshape(3, 3).T @ [0, 0, -1] for m in mats]
        np.testing.assert_allclose(value, expected, atol=1e-12)


def test_pitching_nose_down_moves_gravity_towards_plus_x(tmp_path: Path) -> None:
    """A base pitched nose down by 30 degrees (about +y) sees gravity partly along its own +x (forward)."""
    angle = np.deg2rad(30)
    quat = np.array([np.cos(angle / 2), 0, np.sin(angle / 2), 0])
    values, _, _ = _readings(_model(tmp_path), quat[None])
    np.testing.assert_allclose(values[0][0], [np.sin(angle), 0, -np.cos(angle)], atol=1e-12)


def test_the_models_own_gravity_direction(tmp_path: Path) -> None:
    values, frames, _ = _readings(_model(tmp_path, "3 0 -4"), np.array([[1.0, 0, 0, 0], [0.9, 0.1, -0.3, 0.2]]))
    for value, mats in zip(values, frames):
        np.testing.assert_allclose(value, [m.reshape(3, 3).T @ [0.6, 0, -0.8] for m in mats], atol=1e-12)


def test_a_model_without_gravity_is_a_problem_at_the_kind(tmp_path: Path) -> None:
    suite = sensorcfg.loads("sensors:\n  gravity: {kind: gravity, element: body:base}\n", file="s.yaml")
    assert [p.format() for p in suite.check(_model(tmp_path, "0 0 0"))] == [
        "s.yaml:2:19: error: sensors.gravity.kind: the model's gravity is (0, 0, 0), which has no direction; give "
        "the model a gravity (<option gravity=...>) or read the frame's axes with framexaxis/frameyaxis/framezaxis"]
    with pytest.raises(SuiteError, match="which has no direction"):
        sensorcfg.Environment(_model(tmp_path, "0 0 0"), suite, seed=0)


def test_gravity_takes_no_frame(tmp_path: Path) -> None:
    suite = sensorcfg.loads("sensors:\n  g: {kind: gravity, element: body:base, frame: body:world}\n", file="s.yaml")
    assert [p.format() for p in suite.check(_model(tmp_path))] == [
        "s.yaml:2:49: error: sensors.g.frame: a gravity sensor takes no `frame:`"]
