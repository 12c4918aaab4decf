"""`sensorcfg validate` accepts exactly what `Environment` accepts, and `--batch` what `BatchEnvironment` does.

Each mistake class is checked twice: validate reports it at its line, and the environment refuses the
same suite (rather than failing at its first step, or reading a silently wrong value).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError

from conftest import MODELS

MODEL = MODELS / "menagerie_like.xml"


def validate(path: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sensorcfg", "validate", str(path), *args], capture_output=True,
                          text=True, timeout=300, cwd=path.parent)


@pytest.mark.parametrize("body, message", [
    pytest.param("options: {control_interval: 25ms}\nsensors:\n  q: {kind: qpos, element: 'joint:*'}\n",
                 "s.yaml:2:29: error: options.control_interval: 25ms is not a whole number of 2ms physics steps "
                 "(12.5 steps); use 24ms or 26ms", id="control-interval"),
    pytest.param("options: {strip_singleton_buffer_dim: true}\nsensors:\n"
                 "  q: {kind: xpos, element: body:base, aggregator: mean}\n",
                 "s.yaml:4:51: error: sensors.q.aggregator: with options.strip_singleton_buffer_dim and a buffer of 1 "
                 "there is no buffer axis, so 'mean' would reduce the value's own first axis (shape (3,)); remove the "
                 "aggregator, or use a buffer of 2 or more", id="aggregator-without-buffer-axis"),
    pytest.param("sensors:\n  q: {kind: act, element: 'actuator:*', aggregator: max, buffer: 2}\n",
                 "s.yaml:3:53: error: sensors.q.aggregator: the value has no entries (shape (0,)), so 'max' has "
                 "nothing to reduce (min and max raise, mean and median give nan); remove the aggregator or select "
                 "elements that have this value", id="aggregator-on-zero-width"),
])
def test_what_the_environment_refuses_validate_reports(tmp_path: Path, body: str, message: str) -> None:
    suite = tmp_path / "s.yaml"
    shutil.copy(MODEL, tmp_path)  # a suite's model lies in its folder tree
    suite.write_text(f"model: {MODEL.name}\n{body}")
    done = validate(suite)
    assert done.returncode == 1 and done.stdout.splitlines()[0] == message, done.stdout + done.stderr
    with pytest.raises(SuiteError, match=message.split("error: ")[1][:40]):
        sensorcfg.make_env(suite)


def test_a_schema_mistake_does_not_hide_the_model_mistake_of_its_sensor(tmp_path: Path) -> None:
    suite = tmp_path / "s.yaml"
    shutil.copy(MODEL, tmp_path)
    suite.write_text(f"model: {MODEL.name}\nsensors:\n  a: {{kind: xpos, element: body:torsoo, buffer: 0}}\n")
    assert validate(suite).stdout.splitlines()[:2] == [
        "s.yaml:3:28: error: sensors.a.element: the model has no body named 'torsoo'; its bodies are: "
        "world, base, fl_leg, fl_calf, fr_leg, fr_calf, hl_leg, hl_calf, hr_leg, hr_calf (4 unnamed: select them "
        "by id, 'body:#<id>', or with a glob)",
        "s.yaml:3:49: error: sensors.a.buffer: expected a value >= 1; got 0"]


BATCH_SUITE = f"""model: arm.xml  # copied next to the suite
sensors:
  cam:
    kind: rgb
    element: camera:hand_cam
    noise: [{{type: gaussian, std: 0.1}}]
    interval: {{uniform: [1, 3]}}
    camera: {{width: 32, height: 24}}  # small: a drawn schedule keeps the frames of its planning rounds
  mass: {{kind: mass, element: body:hand, constant: true}}
  gen: {{kind: generic, callable: "mysensors:dist"}}
  custom: {{kind: qpos, element: joint:elbow, noise: [{{type: custom, callable: "mysensors:noisy"}}]}}
  ok: {{kind: qpos, element: joint:elbow}}
"""


def test_validate_batch_reports_every_batch_problem_at_its_line(tmp_path: Path) -> None:
    suite = tmp_path / "s.yaml"
    shutil.copy(MODELS / "arm.xml", tmp_path)
    suite.write_text(BATCH_SUITE)
    assert validate(suite).returncode == 0  # the single-simulation Environment runs all of it
    assert validate(suite, "--batch").stdout.splitlines() == [
        "s.yaml:7:15: error: sensors.cam.interval: a BatchEnvironment renders cameras per simulation and cannot "
        "apply a drawn interval to them; remove it, or use the single-simulation Environment",
        "s.yaml:9:52: error: sensors.mass.constant: a BatchEnvironment reads mjData fields across simulations, not "
        "model constants; remove it, or use the single-simulation Environment",
        "s.yaml:10:15: error: sensors.gen.kind: a generic callable runs Python per sample and simulation, which a "
        "BatchEnvironment cannot vectorise; use the single-simulation Environment for it, or, on the Warp engine "
        "(WarpEnvironment), 'batched: true' with a callable that takes every world at once",
        "s.yaml:11:54: error: sensors.custom.noise.0: a custom noise stage runs Python once per sample and "
        "simulation, which a BatchEnvironment cannot vectorise; express it with built-in stages, or use the "
        "single-simulation Environment",
        "4 problems in 1 of 1 suite; 2 callables not imported (pass --import to check them)"]


def test_batch_environment_on_a_suite_raises_the_same_positioned_problems(tmp_path: Path) -> None:
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("BatchEnvironment needs MuJoCo 4")
    suite = tmp_path / "s.yaml"
    shutil.copy(MODELS / "arm.xml", tmp_path)
    suite.write_text(BATCH_SUITE.replace('"mysensors:', '"callables:'))
    (tmp_path / "callables.py").write_text("def dist(physics):\n    return 1.0\n\ndef noisy(x, rng):\n    return x\n")
    with pytest.raises(SuiteError) as e:
        sensorcfg.BatchEnvironment(str(MODELS / "arm.xml"), sensorcfg.load(suite), 2)
    assert [(p.line, p.loc) for p in e.value.problems] == [
        (7, "sensors.cam.interval"), (9, "sensors.mass.constant"), (10, "sensors.gen.kind"),
        (11, "sensors.custom.noise.0")]


def test_callables_import_next_to_the_suite_first(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "suites"
    folder.mkdir()
    (folder / "nearby_sensors_xyz.py").write_text("def height(physics):\n    return physics.data.qpos[2] * 1.0\n")
    suite = folder / "s.yaml"
    shutil.copy(MODEL, folder)
    suite.write_text(f"model: {MODEL.name}\nsensors:\n  h: {{kind: generic, callable: 'nearby_sensors_xyz:height'}}\n")
    monkeypatch.chdir(tmp_path)  # not the suite's folder
    env = sensorcfg.make_env(suite, keyframe="crouch")
    assert env.reset().observation["h"] == pytest.approx(0.22)
    assert str(folder) not in sys.path  # the folder is searched while binding only
    assert np.isfinite(env.step(np.zeros(8)).observation["h"])
