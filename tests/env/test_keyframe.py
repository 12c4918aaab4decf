"""`options.keyframe`, `keyframe=` of both environments and `--keyframe` of the CLI: every reset starts there."""

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
SUITE = f"""
model: {MODEL}
options: {{keyframe: crouch, control_interval: 10}}
sensors:
  q: {{kind: qpos, element: "joint:*"}}
"""


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MODEL))


def test_every_reset_starts_from_the_suites_keyframe(model: mujoco.MjModel) -> None:
    env = sensorcfg.Environment(model, sensorcfg.loads(SUITE), time_limit=0.04)
    for _ in range(3):
        np.testing.assert_array_equal(env.reset().observation["q"][0], model.key("crouch").qpos)
        ts = env.step(np.zeros(model.nu))
        assert not np.array_equal(ts.observation["q"][0], model.key("crouch").qpos)  # it moved


@pytest.mark.parametrize("keyframe", ["raised", 1])
def test_the_environments_keyframe_overrides_the_suites(model: mujoco.MjModel, keyframe: int | str) -> None:
    env = sensorcfg.Environment(model, sensorcfg.loads(SUITE), keyframe=keyframe)
    np.testing.assert_array_equal(env.reset().observation["q"][0], model.key("raised").qpos)


@pytest.mark.parametrize("keyframe, message", [
    pytest.param("crouh", "s.yaml:2:21: error: options.keyframe: the model has no keyframe named 'crouh' "
                 "(did you mean 'crouch'?)", id="name"),
    pytest.param("2", "s.yaml:2:21: error: options.keyframe: keyframe 2 is out of range: the model has keyframes 0 to 1",
                 id="index"),
])
def test_a_bad_keyframe_is_a_problem_at_its_line(keyframe: str, message: str) -> None:
    suite = sensorcfg.loads(f"model: {MODEL}\noptions: {{keyframe: {keyframe}}}\nsensors:\n"
                            "  q: {kind: qpos, element: 'joint:*'}\n", file="s.yaml")
    assert [p.format() for p in suite.check()] == [message]
    with pytest.raises(SuiteError, match="options.keyframe"):
        suite.build()


def test_a_negative_keyframe_is_a_schema_problem() -> None:
    with pytest.raises(SuiteError, match=r"s.yaml:1:21: error: options.keyframe: "):
        sensorcfg.loads("options: {keyframe: -1}\nsensors:\n  q: {kind: qpos, element: 'joint:*'}\n", file="s.yaml")


def test_batch_environment_resets_to_the_keyframe(model: mujoco.MjModel) -> None:
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("BatchEnvironment needs MuJoCo 4")
    batch = sensorcfg.BatchEnvironment(model, sensorcfg.loads(SUITE), 3, seed=0)
    obs = batch.reset().observation["q"]
    np.testing.assert_array_equal(obs[:, 0], np.tile(model.key("crouch").qpos, (3, 1)))
    raised = sensorcfg.BatchEnvironment(model, sensorcfg.loads(SUITE), 2, keyframe="raised").reset()
    np.testing.assert_array_equal(raised.observation["q"][:, 0], np.tile(model.key("raised").qpos, (2, 1)))
    single = sensorcfg.Environment(model, sensorcfg.loads(SUITE), seed=sensorcfg.batch.sim_seed(0, 1))
    single.reset()
    step = batch.step(np.zeros((3, model.nu)))
    np.testing.assert_array_equal(step.observation["q"][1], single.step(np.zeros(model.nu)).observation["q"])


@pytest.mark.parametrize("command", ["run", "demo"])
def test_run_and_demo_keyframe_option(tmp_path: Path, model: mujoco.MjModel, command: str) -> None:
    suite = tmp_path / "s.yaml"
    shutil.copy(MODEL, tmp_path)  # a suite's model lies in its folder tree
    suite.write_text(SUITE.replace(str(MODEL), MODEL.name))
    out = tmp_path / "o.npz"
    tail = ["--out", str(out)] if command == "run" else ["--prefix", str(tmp_path / "o"), "--no-plot"]
    cmd = [sys.executable, "-m", "sensorcfg", command, str(suite), "--steps", "2", "--keyframe", "raised", *tail]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    np.testing.assert_array_equal(np.load(out)["q"][0, 0], model.key("raised").qpos)
    bad = subprocess.run([*cmd[:cmd.index("--keyframe")], "--keyframe", "rased"], capture_output=True, text=True,
                         cwd=tmp_path)
    assert bad.returncode == 2
    assert "sensorcfg: error: --keyframe: the model has no keyframe named 'rased' (did you mean 'raised'?)" in bad.stderr
