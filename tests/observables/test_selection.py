"""Elements by id, unnamed elements in globs, `within` lists, and indices that must fit their axis."""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.selection import element_labels, select

from conftest import MODELS

MODEL = MODELS / "menagerie_like.xml"


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


QUADRUPED = MODELS / "quadruped.xml"
EVERYTHING = """\
sensors:
  sensors: {kind: sensordata, element: "sensor:*"}
  sites: {kind: xpos, element: "site:*"}
  last_site: {kind: xpos, element: "site:#4"}
"""
ADDING = """\
  shin_vel: {kind: velocimeter, element: body:shin_fl}     # a sensor and a site in shin_fl, before foot_fl
  torso_gyro: {kind: gyro, element: "body:#1"}
  torso_force: {kind: cfrc_ext, element: body:torso}       # a batch adds a sensor to fill it
  torso_momentum: {kind: subtree_angmom, element: body:torso}
"""


def test_globs_and_ids_do_not_see_what_sensorcfg_adds() -> None:
    """`sensor:*`, `site:*` and `site:#4` read the model's own elements whatever sensors the suite (or a batch)
    adds, and messages list no name sensorcfg made."""
    plain = mujoco.MjModel.from_xml_path(str(QUADRUPED))
    alone = sensorcfg.Environment(str(QUADRUPED), sensorcfg.loads(EVERYTHING), seed=0).reset().observation
    suite = sensorcfg.loads(EVERYTHING + ADDING)
    env = sensorcfg.Environment(str(QUADRUPED), suite, seed=0)
    observation = env.reset().observation
    for name in alone:
        np.testing.assert_array_equal(observation[name], alone[name], err_msg=name)
    assert observation["sensors"].shape == (1, plain.nsensordata) and observation["sites"].shape == (1, plain.nsite, 3)
    np.testing.assert_array_equal(observation["last_site"][0], env.physics.data.site("foot_br").xpos)
    compiled = suite.compile(str(QUADRUPED), batch=True)
    assert compiled.nsensor > plain.nsensor and compiled.nsite > plain.nsite
    assert select(compiled, "site:*").names == tuple(plain.site(i).name for i in range(plain.nsite))
    with pytest.raises(sensorcfg.SuiteError) as info:
        select(compiled, ["site:foot", "site:#99", "sensor:nope_*"])
    assert "sensorcfg" not in str(info.value) and "#0 to #4" in str(info.value)


@pytest.mark.parametrize("where", [
    "element: 'sensor:sensorcfg:shin_vel:0'",  # the velocimeter the suite adds
    "element: 'site:sensorcfg:shin_vel:0'",  # the site it adds at the body
    "element: 'sensor:sensorcfg:on-demand:flg_rnepost'",  # a batch's helper: exists in a batch only
    "element: 'site:torso_site', frame: 'site:sensorcfg:shin_vel:0'",
])
def test_a_name_sensorcfg_adds_is_reserved_when_named_exactly(where: str) -> None:
    """Found by review: globs and ids did not see what sensorcfg adds, but an exact name did, so a suite
    naming a batch's helper passed `validate --batch` and ran in the batch while Environment refused it."""
    kind = "framepos" if "frame:" in where else ("sensordata" if "sensor:" in where else "xpos")
    suite = sensorcfg.loads(f"sensors:\n  s: {{kind: {kind}, {where}}}\n" + ADDING, file="s.yaml")
    for batch in (False, True):
        problems = suite.check(str(QUADRUPED), batch=batch)
        key = "frame" if "frame:" in where else "element"
        assert [(p.line, p.loc) for p in problems] == [(2, f"sensors.s.{key}")], problems
        assert "reserved" in problems[0].message


@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
def test_a_batch_reads_the_shapes_and_values_of_its_environment() -> None:
    from conftest import assert_batch_equals_single
    from sensorcfg.batch import BatchEnvironment

    suite = sensorcfg.loads(EVERYTHING + ADDING)
    single = sensorcfg.Environment(str(QUADRUPED), suite, seed=0).observation_spec()
    batch = BatchEnvironment(str(QUADRUPED), suite, 2, seed=0).observation_spec()
    assert {k: (2,) + s.shape for k, s in single.items()} == {k: s.shape for k, s in batch.items()}
    assert_batch_equals_single(str(QUADRUPED), suite, nsim=2, seed=0, steps=10)


@pytest.mark.parametrize("where", ["kind: qpos, element: 'joint:#²'", "kind: xpos, element: body:torso, within: 'body:#²'",
                                   "kind: qpos, element: ['joint:#1', 'joint:#١']"])
def test_an_id_in_other_digits_is_a_positioned_mistake(where: str) -> None:
    suite = sensorcfg.loads(f"sensors:\n  s: {{{where}}}\n", file="s.yaml")
    problems = suite.check(str(QUADRUPED))
    assert len(problems) == 1 and problems[0].line == 2 and " is not a " in problems[0].message, problems


def test_a_keyframe_id_in_other_digits_is_a_positioned_mistake() -> None:
    suite = sensorcfg.loads("options: {keyframe: '#²'}\nsensors:\n  s: {kind: qpos, element: 'joint:*'}\n", file="s.yaml")
    assert [p.format() for p in suite.check(str(MODEL))] == [
        "s.yaml:1:21: error: options.keyframe: key:#² is not a keyframe id: the model's keyframes are #0 to #1"]


def test_a_camera_by_id_is_the_camera_its_selector_names() -> None:
    from sensorcfg.observables import Camera

    arm = mujoco.MjModel.from_xml_path(str(MODELS / "arm.xml"))
    suite = sensorcfg.loads("sensors:\n  c: {kind: rgb, element: 'camera:#1'}\n")
    assert suite.check(arm) == []
    assert Camera("camera:#1").camera_id(arm) == select(arm, "camera:#1").ids[0] == arm.camera("hand_cam").id
    with pytest.raises(sensorcfg.SuiteError, match="camera:#2 is not a camera id: the model's cameras are #0 to #1"):
        Camera("camera:#2").camera_id(arm)


def _lookups(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Every name look-up selection makes (by name, by id), and every did-you-mean it computes."""
    from sensorcfg import selection

    calls: list[str] = []
    for name in ("mj_name2id", "mj_id2name"):
        original = getattr(mujoco, name)
        monkeypatch.setattr(selection.mujoco, name, lambda *a, _f=original, _n=name: (calls.append(_n), _f(*a))[1])
    hint = selection.did_you_mean
    monkeypatch.setattr(selection, "did_you_mean", lambda *a: (calls.append("hint"), hint(*a))[1])
    return calls


@pytest.mark.parametrize("entries", [
    pytest.param(lambda n: f"element: {['body:shin_fl'] * n}, within: {['body:torso'] * n}", id="within"),
    pytest.param(lambda n: f"element: {['site:*'] * n}", id="globs"),
    pytest.param(lambda n: f"element: {[f'body:b{i}' for i in range(n)]}", id="misses"),
    pytest.param(lambda n: f"element: body:torso, within: {[f'body:b{i}' for i in range(n)]}", id="within-misses"),
])
def test_a_list_costs_look_ups_in_proportion_to_its_length(monkeypatch: pytest.MonkeyPatch, entries: object) -> None:
    """Twice the entries cost about twice the look-ups (an n^2 resolution costs four times), and misses get
    a bounded number of did-you-mean scans."""
    calls = _lookups(monkeypatch)

    def cost(n: int) -> tuple[int, int]:
        calls.clear()
        sensorcfg.loads(f"sensors:\n  s: {{kind: xpos, {entries(n)}}}\n").check(str(QUADRUPED))  # type: ignore[operator]
        return len(calls), calls.count("hint")

    (small, small_hints), (large, large_hints) = cost(200), cost(400)
    assert large < 2.5 * small and large_hints <= 2 * 20


# Joints listed one order, actuators another (as Menagerie's Go2 before 2025-02), a free joint no actuator
# drives, an actuator through `jointinparent`, and one driving a tendon.
DRIVEN = """
<mujoco>
  <worldbody>
    <body name="base"><freejoint/><geom size="0.1"/>
      <body name="a" pos="0.2 0 0"><joint name="ja" axis="0 1 0"/><geom size="0.05"/></body>
      <body name="b" pos="-0.2 0 0"><joint name="jb" axis="0 1 0"/><geom size="0.05"/></body>
      <body name="c" pos="0 0.2 0"><joint name="jc" type="slide"/><geom size="0.05"/></body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="ja" coef="1"/></fixed></tendon>
  <actuator>
    <motor name="mc" joint="jc"/>
    <motor name="ma" joint="ja"/>
    <general name="mb" jointinparent="jb"/>
    %s
  </actuator>
</mujoco>
"""


def _driven(tendon: bool = False) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(DRIVEN % ('<motor name="mt" tendon="t"/>' if tendon else ""))


@pytest.mark.parametrize("kind, address", [("qpos", "jnt_qposadr"), ("qvel", "jnt_dofadr"), ("qfrc_actuator", "jnt_dofadr")])
def test_actuators_on_a_joint_attribute_read_the_joints_they_drive_in_actuator_order(kind: str, address: str) -> None:
    model = _driven()
    sel = select(model, "actuator:*", kind=kind)
    assert sel.type == "joint" and sel.names == ("jc", "ja", "jb") and sel.batched
    assert sel.ids == tuple(int(j) for j in model.actuator_trnid[:, 0])
    assert select(model, "actuator:ma", kind=kind).ids == (model.joint("ja").id,)
    assert select(model, "actuator:*", kind="ctrl").type == "actuator"  # the actuator's own attribute
    suite = sensorcfg.loads(f"sensors:\n  q: {{kind: {kind}, element: 'actuator:*'}}\n"
                            f"  one: {{kind: {kind}, element: 'actuator:mb'}}\n")
    env = sensorcfg.Environment(model, suite, seed=0)
    env.reset()
    data = env.physics.data
    data.qpos[7:] = [0.1, 0.2, 0.3]
    data.qvel[6:] = [1.0, 2.0, 3.0]
    obs = env.step(np.array([0.5, -0.25, 0.75])).observation
    rows = getattr(model, address)[model.actuator_trnid[:, 0]]
    field = getattr(env.physics.data, kind)
    np.testing.assert_array_equal(obs["q"][0], field[rows])
    np.testing.assert_array_equal(obs["one"][0], field[rows[2:]])


def test_an_actuator_that_drives_no_joint_is_a_mistake_at_its_entry(tmp_path: Path) -> None:
    (tmp_path / "m.xml").write_text(DRIVEN % '<motor name="mt" tendon="t"/>')
    suite = sensorcfg.loads("sensors:\n  q: {kind: qpos, element: ['actuator:ma', 'actuator:m*']}\n", file="s.yaml")
    assert [p.format() for p in suite.check(str(tmp_path / "m.xml"))] == [
        "s.yaml:2:44: error: sensors.q.element.1: kind 'qpos' on actuators reads the joint each actuator drives, "
        "but 'mt' drives a tendon, not a joint: select joints ('joint:<name>') for this kind, or read the "
        "actuators' own attributes (ctrl, force, length, velocity)"]


def test_spec_labels_the_joints_actuators_drive(tmp_path: Path) -> None:
    from sensorcfg.cli.quantities import value_groups

    suite = sensorcfg.loads("sensors:\n  q: {kind: qpos, element: 'actuator:*'}\n")
    groups = value_groups(_driven(), suite.sensors["q"], 3)
    assert [label for g in groups for label in g.labels] == ["jc", "ja", "jb"]
