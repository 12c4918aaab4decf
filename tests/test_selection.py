"""Elements by id, unnamed elements in globs, `within` lists, and indices that must fit their axis."""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.selection import element_labels, select

MODEL = Path(__file__).parent / "models" / "menagerie_like.xml"


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MODEL))


def test_a_glob_takes_unnamed_elements_as_find_all_does(model: mujoco.MjModel) -> None:
    joints = select(model, "joint:*")
    assert joints.ids == tuple(range(model.njnt)) and joints.names[0] == "#0"  # the unnamed free joint first
    assert select(model, "joint:fl_*").ids == (1, 2)  # a name pattern matches names only
    feet = select(model, "body:#*")  # every unnamed body: the four toes
    assert len(feet.ids) == 4 and all(not model.body(i).name for i in feet.ids)


def test_qpos_of_every_joint_includes_the_floating_base(model: mujoco.MjModel) -> None:
    suite = sensorcfg.loads('sensors:\n  q: {kind: qpos, element: "joint:*"}\n  base: {kind: qpos, element: "joint:#0"}\n')
    env = sensorcfg.Environment(model, suite, keyframe="crouch")
    obs = env.reset().observation
    np.testing.assert_array_equal(obs["q"][0], model.key_qpos[0])
    np.testing.assert_array_equal(obs["base"][0], model.key_qpos[0][:7])


def test_within_takes_a_list_of_bodies(model: mujoco.MjModel) -> None:
    sel = select(model, "body:*", within=["body:fl_calf", "body:hr_calf"])
    assert element_labels(model, "body")[sel.ids[0]] == "fl_calf"
    assert [model.body(i).parentid[0] for i in sel.ids if not model.body(i).name] == [
        model.body("fl_calf").id, model.body("hr_calf").id]


@pytest.mark.parametrize("sensor, message", [
    pytest.param('{kind: xpos, element: "body:#99"}',
                 "s.yaml:2:28: error: sensors.s.element: body:#99 is not a body id: the model's bodies are #0 to #13",
                 id="id-out-of-range"),
    pytest.param('{kind: xpos, element: [body:fl_calf, body:fr_calf, body:hl_calf, body:hr_calf], index: "3:6"}',
                 "s.yaml:2:93: error: sensors.s.index: index '3:6' reaches past axis 0 of xpos of 4 elements (shape "
                 "(4, 3): 4 entries on that axis, 0 to 3); numpy would silently return fewer values: use a range "
                 "within 0:4", id="index-past-the-elements"),
    pytest.param('{kind: xpos, element: "site:*", within: [body:fl_calf, body:nope]}',
                 "s.yaml:2:61: error: sensors.s.within.1: the model has no body named 'nope'; its bodies are: world, "
                 "base, fl_leg, fl_calf, fr_leg, fr_calf, hl_leg, hl_calf, hr_leg, hr_calf (4 unnamed: select them by "
                 "id, 'body:#<id>', or with a glob)", id="within-list-entry"),
    pytest.param('{kind: qpos, element: "joint:root"}',
                 "s.yaml:2:28: error: sensors.s.element: the model has no joint named 'root'; its joints are: fl_hip, "
                 "fl_knee, fr_hip, fr_knee, hl_hip, hl_knee, hr_hip, hr_knee (1 unnamed: select them by id, "
                 "'joint:#<id>', or with a glob)", id="unnamed-hint"),
])
def test_selection_mistakes_at_their_line(sensor: str, message: str) -> None:
    suite = sensorcfg.loads(f"sensors:\n  s: {sensor}\n", file="s.yaml")
    assert [p.format() for p in suite.check(str(MODEL))] == [message]


def test_an_index_within_the_axis_still_works(model: mujoco.MjModel) -> None:
    suite = sensorcfg.loads('sensors:\n  s: {kind: xpos, element: ["body:fl_calf", "body:fr_calf"], index: "1:2"}\n'
                            '  z: {kind: xpos, element: "body:#*", index: "..., 2"}\n')
    obs = sensorcfg.Environment(model, suite).reset().observation
    assert obs["s"].shape == (1, 1, 3) and obs["z"].shape == (1, 4)


def test_spec_says_how_unnamed_elements_are_labelled(tmp_path: Path) -> None:
    import subprocess
    import sys

    suite = tmp_path / "s.yaml"
    shutil.copy(MODEL, tmp_path)  # a suite's model lies in its folder tree
    suite.write_text(f"model: {MODEL.name}\noptions: {{keyframe: crouch}}\nsensors:\n"
                     "  q: {kind: qpos, element: 'joint:*'}\n  toes: {kind: xpos, element: 'body:#*', within: body:fl_leg}\n")
    done = subprocess.run([sys.executable, "-m", "sensorcfg", "spec", str(suite)], capture_output=True, text=True)
    lines = done.stdout.splitlines()
    assert lines[1].endswith("; episodes start from keyframe 'crouch'")
    assert lines[-1] == "unnamed elements, labelled by id: joint:#0 (q); body:#4 (toes)"
