"""The `misalign` noise stage: a fixed cross-axis matrix and a small rotation drawn per episode."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS, assert_batch_equals_single
from sensorcfg.noise.misalign import rotation

TERRAIN = str(MODELS / "terrain.xml")
MATRIX = [[1.0, 0.01, 0.0], [0.0, 0.98, 0.02], [-0.01, 0.0, 1.01]]


def _suite(stage: str) -> sensorcfg.Suite:
    return sensorcfg.loads("options: {strip_singleton_buffer_dim: true, control_interval: 5}\nsensors:\n"
                           f"  noisy: {{kind: xpos, element: site:imu, noise: [{stage}]}}\n"
                           "  clean: {kind: xpos, element: site:imu}\n")


def _episodes(stage: str, episodes: int = 2, steps: int = 10) -> list[list[dict[str, np.ndarray]]]:
    env = sensorcfg.Environment(TERRAIN, _suite(stage), seed=1)
    out = []
    for _ in range(episodes):
        env.reset()
        out.append([env.step(np.array([1.0, -0.5])).observation for _ in range(steps)])
    return out


def test_a_fixed_matrix_maps_each_vector() -> None:
    for obs in _episodes(f"{{type: misalign, matrix: {MATRIX}}}")[0]:
        np.testing.assert_allclose(obs["noisy"], np.array(MATRIX) @ obs["clean"], rtol=1e-15, atol=1e-15)


def test_a_rotation_is_drawn_per_episode_and_kept_within_it() -> None:
    runs = _episodes("{type: misalign, std: 2deg}", episodes=3)
    rotations = []
    for run in runs:
        clean = np.array([obs["clean"] for obs in run])
        noisy = np.array([obs["noisy"] for obs in run])
        np.testing.assert_allclose(np.linalg.norm(noisy, axis=1), np.linalg.norm(clean, axis=1), rtol=1e-12)
        # a rotation keeps cross products: two samples and theirs give the episode's one matrix
        a, b = clean[-1], clean[len(clean) // 2]
        fit = (np.column_stack([noisy[-1], noisy[len(clean) // 2], np.cross(noisy[-1], noisy[len(clean) // 2])])
               @ np.linalg.inv(np.column_stack([a, b, np.cross(a, b)])))
        np.testing.assert_allclose(noisy, clean @ fit.T, atol=1e-9)
        np.testing.assert_allclose(fit @ fit.T, np.eye(3), atol=1e-9)  # a rotation
        angle = np.degrees(np.arccos((np.trace(fit) - 1) / 2))
        assert 0 < angle < 15
        rotations.append(fit)
    assert not np.allclose(rotations[0], rotations[1]) and not np.allclose(rotations[1], rotations[2])
    again = _episodes("{type: misalign, std: 2deg}", episodes=1)[0]
    np.testing.assert_array_equal([o["noisy"] for o in again], [o["noisy"] for o in runs[0]])  # seeded


def test_rotation_is_rodrigues() -> None:
    vector = np.array([0.1, -0.2, 0.3])
    expected = np.zeros(9)
    quat = np.zeros(4)
    mujoco.mju_axisAngle2Quat(quat, vector / np.linalg.norm(vector), np.linalg.norm(vector))
    mujoco.mju_quat2Mat(expected, quat)
    np.testing.assert_allclose(rotation(vector), expected.reshape(3, 3), atol=1e-15)


@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
def test_batched_misalign_equals_single() -> None:
    assert_batch_equals_single(TERRAIN, _suite(f"{{type: misalign, matrix: {MATRIX}, std: 1deg}}"), nsim=3, seed=4,
                               steps=12)


@pytest.mark.parametrize("stage, expected", [
    pytest.param("{type: misalign}", "f.yaml:2:46: error: sensors.g.noise.0: misalign needs matrix, std or both",
                 id="empty"),
    pytest.param("{type: misalign, matrix: [[1, 0], [0, 1]]}", "f.yaml:2:71: error: sensors.g.noise.0.matrix: matrix "
                 "takes 3 rows of 3 numbers, e.g. [[1, 0.01, 0], [0, 1, 0], [0, 0, 1]]; got [[1, 0], [0, 1]]",
                 id="matrix"),
    pytest.param("{type: misalign, std: 1furlong}", "f.yaml:2:68: error: sensors.g.noise.0.std: unknown unit "
                 "'furlong' in '1furlong'; an angle takes rad, deg", id="unit"),
])
def test_mistakes_are_positioned(stage: str, expected: str) -> None:
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(f"sensors:\n  g: {{kind: gyro, element: site:imu, noise: [{stage}]}}\n", file="f.yaml")
    assert str(info.value) == expected


def test_a_value_that_is_not_a_3_vector_is_a_problem() -> None:
    problems = sensorcfg.loads("sensors:\n  g: {kind: jointpos, element: joint:hip_f, noise: [{type: misalign, "
                               "std: 0.01}]}\n", file="f.yaml").check(TERRAIN)
    assert [p.format() for p in problems] == [
        "f.yaml:2:60: error: sensors.g.noise.0.type: misalign turns 3-vectors: the observation's last axis must "
        "hold 3 values; its shape is (1,)"]
