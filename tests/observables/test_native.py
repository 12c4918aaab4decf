"""MuJoCo's own sensor types as kinds: added through MjSpec, read from sensordata, checked against MuJoCo.

Every kind of the table is compared, value for value, with the same sensor written by hand in the model's
MJCF; the issue's example is checked against MuJoCo's own functions (mj_objectVelocity, frame algebra,
the contact list), run single and batched (bit-identical), and a 2-step touch inside a 10-step control step
is seen by its contact sensor. Mistakes are positioned problems.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS, assert_batch_equals_single
from sensorcfg import SuiteError
from sensorcfg.config.tables import NATIVE_KINDS
from sensorcfg.native import NATIVE
from sensorcfg.physics import Physics

TERRAIN = str(MODELS / "terrain.xml")
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4

EXAMPLE = """\
options: {control_interval: 10}
sensors:
  base_lin_vel: {kind: velocimeter, element: body:base}      # the base's velocity in its own frame
  base_ang_vel: {kind: gyro, element: body:base}
  up_in_base:   {kind: framezaxis, element: body:world, frame: body:base}    # world z in the base frame
  feet_in_base: {kind: framepos, element: ["geom:FL", "geom:FR"], frame: body:base}
  imu_acc:      {kind: accelerometer, element: site:imu}
  feet_contact:
    kind: contact
    element: ["geom:FL", "geom:FR"]     # one contact sensor per element, matched against `with`
    with: geom:floor
    data: [found, force]
    reduce: netforce
    interval: 1                          # every physics step,
    buffer: 10                           # the whole control step,
    aggregator: max                      # so a touch of a few steps is not missed
"""

# (suite sensor, the same sensor written in MJCF): one row per kind of the table.
HAND_WRITTEN = [
    ("{kind: accelerometer, element: site:imu}", '<accelerometer site="imu"/>'),
    ("{kind: velocimeter, element: site:imu}", '<velocimeter site="imu"/>'),
    ("{kind: gyro, element: site:imu}", '<gyro site="imu"/>'),
    ("{kind: force, element: site:imu}", '<force site="imu"/>'),
    ("{kind: torque, element: site:imu}", '<torque site="imu"/>'),
    ("{kind: magnetometer, element: site:imu}", '<magnetometer site="imu"/>'),
    ("{kind: touch, element: site:foot}", '<touch site="foot"/>'),
    ("{kind: rangefinder, element: site:imu}", '<rangefinder site="imu"/>'),
    ("{kind: camprojection, element: site:imu, with: camera:cam}", '<camprojection site="imu" camera="cam"/>'),
    ("{kind: jointpos, element: joint:hip_f}", '<jointpos joint="hip_f"/>'),
    ("{kind: jointvel, element: joint:hip_f}", '<jointvel joint="hip_f"/>'),
    ("{kind: jointactfrc, element: joint:hip_f}", '<jointactuatorfrc joint="hip_f"/>'),
    ("{kind: jointlimitpos, element: joint:hip_f}", '<jointlimitpos joint="hip_f"/>'),
    ("{kind: jointlimitvel, element: joint:hip_f}", '<jointlimitvel joint="hip_f"/>'),
    ("{kind: jointlimitfrc, element: joint:hip_f}", '<jointlimitfrc joint="hip_f"/>'),
    ("{kind: ballquat, element: joint:ball}", '<ballquat joint="ball"/>'),
    ("{kind: ballangvel, element: joint:ball}", '<ballangvel joint="ball"/>'),
    ("{kind: tendonpos, element: tendon:t}", '<tendonpos tendon="t"/>'),
    ("{kind: tendonvel, element: tendon:t}", '<tendonvel tendon="t"/>'),
    ("{kind: tendonactfrc, element: tendon:t}", '<tendonactuatorfrc tendon="t"/>'),
    ("{kind: tendonlimitpos, element: tendon:t}", '<tendonlimitpos tendon="t"/>'),
    ("{kind: tendonlimitvel, element: tendon:t}", '<tendonlimitvel tendon="t"/>'),
    ("{kind: tendonlimitfrc, element: tendon:t}", '<tendonlimitfrc tendon="t"/>'),
    ("{kind: actuatorpos, element: actuator:hip_f}", '<actuatorpos actuator="hip_f"/>'),
    ("{kind: actuatorvel, element: actuator:hip_f}", '<actuatorvel actuator="hip_f"/>'),
    ("{kind: actuatorfrc, element: actuator:hip_f}", '<actuatorfrc actuator="hip_f"/>'),
    ("{kind: framepos, element: geom:FL, frame: body:base}",
     '<framepos objtype="geom" objname="FL" reftype="xbody" refname="base"/>'),
    ("{kind: framequat, element: site:imu, frame: geom:torso}",
     '<framequat objtype="site" objname="imu" reftype="geom" refname="torso"/>'),
    ("{kind: framexaxis, element: body:front}", '<framexaxis objtype="xbody" objname="front"/>'),
    ("{kind: frameyaxis, element: camera:cam, frame: site:imu}",
     '<frameyaxis objtype="camera" objname="cam" reftype="site" refname="imu"/>'),
    ("{kind: framezaxis, element: body:world, frame: body:base}",
     '<framezaxis objtype="xbody" objname="world" reftype="xbody" refname="base"/>'),
    ("{kind: framelinvel, element: geom:FR, frame: body:base}",
     '<framelinvel objtype="geom" objname="FR" reftype="xbody" refname="base"/>'),
    ("{kind: frameangvel, element: body:front, frame: body:base}",
     '<frameangvel objtype="xbody" objname="front" reftype="xbody" refname="base"/>'),
    ("{kind: framelinacc, element: site:imu}", '<framelinacc objtype="site" objname="imu"/>'),
    ("{kind: frameangacc, element: body:rear}", '<frameangacc objtype="xbody" objname="rear"/>'),
    ("{kind: subtreecom, element: body:base}", '<subtreecom body="base"/>'),
    ("{kind: subtreelinvel, element: body:base}", '<subtreelinvel body="base"/>'),
    ("{kind: subtreeangmom, element: body:front}", '<subtreeangmom body="front"/>'),
    ("{kind: insidesite, element: geom:FL, with: site:zone}",
     '<insidesite objtype="geom" objname="FL" site="zone"/>'),
    ("{kind: contact, element: geom:FL, with: geom:floor, data: [found, force, normal], reduce: netforce}",
     '<contact geom1="FL" geom2="floor" data="found force normal" reduce="netforce"/>'),
    ("{kind: contact, element: body:rear, data: [found, dist], reduce: mindist, num: 2}",
     '<contact body1="rear" data="found dist" reduce="mindist" num="2"/>'),
    ("{kind: tactile, element: geom:pad}", '<tactile geom="pad" mesh="pad"/>'),
    # gravity: MuJoCo's framezaxis of a world site whose z axis points along gravity (down), in the element's frame
    ("{kind: gravity, element: body:rear}", '<framezaxis objtype="site" objname="down" reftype="xbody" refname="rear"/>'),
    ("{kind: geomdist, element: geom:FL, with: geom:floor, cutoff: 1}", '<distance geom1="FL" geom2="floor" cutoff="1"/>'),
    ("{kind: geomnormal, element: body:rear, with: geom:floor, cutoff: 1}",
     '<normal body1="rear" geom2="floor" cutoff="1"/>'),
    ("{kind: geomfromto, element: geom:RL, with: geom:floor}", '<fromto geom1="RL" geom2="floor" cutoff="10"/>'),
]

# Extra parts the table's kinds need, added to the terrain model in both versions.
ASSET = '<mesh name="pad" vertex="-.05 -.05 0  .05 -.05 0  -.05 .05 0  .05 .05 0  0 0 .02"/>'
WORLD = """
    <site name="zone" type="box" size=".5 .5 .2"/>
    <site name="down" quat="0 1 0 0"/>
    <camera name="cam" pos="1 -1 1" xyaxes="1 1 0 -.3 .3 1" resolution="64 48"/>
    <body name="arm" pos="-1 0 .5">
      <joint name="ball" type="ball" damping=".1"/>
      <geom name="arm" type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      <site name="tip" pos=".3 0 0"/>
      <geom name="pad" type="mesh" mesh="pad" pos=".3 0 -.04"/>
    </body>"""
TENDON = '<tendon><spatial name="t" limited="true" range="0 2"><site site="imu"/><site site="tip"/></spatial></tendon>'


def _model_text(sensors: str = "") -> str:
    text = Path(TERRAIN).read_text()
    text = text.replace('<site name="imu"', '<site name="foot" pos=".18 .08 -.21" size=".04"/>\n      <site name="imu"')
    text = text.replace("<asset>", f"<asset>{ASSET}", 1).replace("<worldbody>", f"<worldbody>{WORLD}", 1)
    return text.replace("</actuator>", f"</actuator>\n{TENDON}\n<sensor>{sensors}</sensor>")


def test_the_table_is_the_config_layers_list() -> None:
    assert tuple(NATIVE) == NATIVE_KINDS


def test_every_kind_has_a_hand_written_twin() -> None:
    kinds = {row.split(",")[0].split(": ")[1] for row, _ in HAND_WRITTEN}
    assert kinds == set(NATIVE)


def test_each_kind_equals_the_hand_written_sensor(tmp_path: Path) -> None:
    """All kinds in one suite, against one model with the same sensors in its MJCF, over 200 steps."""
    plain = tmp_path / "plain.xml"
    plain.write_text(_model_text())
    written = mujoco.MjModel.from_xml_string(_model_text("".join(xml for _, xml in HAND_WRITTEN)))
    sensors = "\n".join(f"  s{i}: {row}" for i, (row, _) in enumerate(HAND_WRITTEN))
    suite = sensorcfg.loads(f"options: {{strip_singleton_buffer_dim: true}}\nsensors:\n{sensors}\n")
    model = suite.compile(str(plain))
    observables = suite.build(model)
    ours, theirs = Physics(model), Physics(written)
    for physics in (ours, theirs):
        physics.data.qpos[:3] = [0, 0, 0.22]
        physics.data.qvel[:6] = [0.3, -0.2, 0.1, 0.5, -1.0, 2.0]
        physics.data.ctrl[:] = [0.5, -0.5]
    readers = {name: obs.observation_callable(ours) for name, obs in observables.items()}
    checked = 0
    for _ in range(200):
        ours.step()
        theirs.step()
        for i, (name, read) in enumerate(readers.items()):
            adr, dim = written.sensor_adr[i], written.sensor_dim[i]
            np.testing.assert_array_equal(np.ravel(read()), theirs.data.sensordata[adr:adr + dim], err_msg=name)
            checked += int(np.any(theirs.data.sensordata[adr:adr + dim] != 0))
    assert checked > 100 * len(HAND_WRITTEN) // 2  # most sensors read something other than zeros


def _rotation(model: mujoco.MjModel, data: mujoco.MjData, body: str) -> tuple[np.ndarray, np.ndarray]:
    i = model.body(body).id
    return data.xpos[i], data.xmat[i].reshape(3, 3)


def test_issue_example_against_mujocos_functions() -> None:
    suite = sensorcfg.loads(EXAMPLE.replace("options: {", "options: {strip_singleton_buffer_dim: true, "))
    env = sensorcfg.Environment(TERRAIN, suite, seed=0)
    env.reset()
    model, data = env.physics.model, env.physics.data
    base = model.body("base").id
    rng = np.random.default_rng(0)
    seen_contact = 0
    for _ in range(60):
        obs = env.step(rng.uniform(-1, 1, 2)).observation
        velocity = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, base, velocity, 1)
        np.testing.assert_allclose(obs["base_lin_vel"], velocity[3:], rtol=0, atol=1e-12)
        np.testing.assert_allclose(obs["base_ang_vel"], velocity[:3], rtol=0, atol=1e-12)
        pos, rot = _rotation(model, data, "base")
        np.testing.assert_allclose(obs["up_in_base"], rot.T @ [0, 0, 1], atol=1e-12)
        feet = np.array([rot.T @ (data.geom_xpos[model.geom(g).id] - pos) for g in ("FL", "FR")])
        np.testing.assert_allclose(obs["feet_in_base"], feet, atol=1e-12)
        assert obs["feet_contact"].shape == (2, 4)
        for k, foot in enumerate(("FL", "FR")):  # the last step's contacts, as the sensor saw them
            pair = {model.geom(foot).id, model.geom("floor").id}
            found = sum({int(c.geom1), int(c.geom2)} == pair for c in data.contact)
            seen_contact += found
            if found:
                assert obs["feet_contact"][k, 0] >= 1
    assert seen_contact > 0


def test_a_two_step_touch_inside_a_control_step_is_seen() -> None:
    """The foot touches the floor for physics steps 3 and 4 of 10: `max` over a 10-step buffer sees it,
    a buffer of 1 (the last step only) does not."""
    last_only = EXAMPLE.replace("interval: 1                          # every physics step,",
                                "interval: 1").replace("buffer: 10", "buffer: 1").replace("aggregator: max", "")
    for text, expected in ((EXAMPLE, 1.0), (last_only, 0.0)):
        suite = sensorcfg.loads(text)
        model = suite.compile(TERRAIN)
        physics = Physics(model)
        updater = sensorcfg.Updater(suite.build(model), **suite.updater_kwargs(model))
        updater.reset(physics, np.random.RandomState(0))
        updater.prepare_for_next_control_step()
        for k in range(10):
            physics.data.qpos[:7] = [0, 0, 0.2 if k in (3, 4) else 1.0, 1, 0, 0, 0]  # feet at z 0.03 - 0.03
            physics.data.qvel[:] = 0
            physics.step()
            updater.update()
        found = updater.get_observation()["feet_contact"][..., 0]
        assert np.all(np.ravel(found) == expected), (text, found)


@pytest.mark.skipif(not MUJOCO4, reason="mujoco.batch needs MuJoCo 4")
def test_the_example_runs_batched_bit_identical_to_single() -> None:
    assert_batch_equals_single(TERRAIN, sensorcfg.loads(EXAMPLE), nsim=3, seed=7, steps=30)


def test_a_model_without_the_sensors_is_refused_at_the_kind() -> None:
    suite = sensorcfg.loads(EXAMPLE, file="ex.yaml")
    with pytest.raises(SuiteError) as info:
        suite.build(mujoco.MjModel.from_xml_path(TERRAIN))
    assert "ex.yaml:3:24: error: sensors.base_lin_vel.kind: kind 'velocimeter' is a MuJoCo sensor that the suite " \
           "adds to the model, and this model does not carry it" in str(info.value)
    model = suite.compile(TERRAIN)
    assert set(suite.build(model)) == set(suite.sensors)  # a compiled model is accepted as it is


@pytest.mark.parametrize("sensor, expected", [
    pytest.param("{kind: framepos, element: geom:FL, frame: body:bsae}",
                 "2:48: error: sensors.s.frame: the model has no body named 'bsae' (did you mean 'base'?)", id="frame"),
    pytest.param("{kind: velocimeter, element: site:imu, frame: body:base}",
                 "2:52: error: sensors.s.frame: a velocimeter sensor takes no `frame:`", id="no-frame"),
    pytest.param("{kind: contact, element: geom:FL, data: [found, forse]}",
                 "2:54: error: sensors.s.data.1: contact has no data field 'forse' (did you mean 'force'?); "
                 "fields: found, force, torque, dist, pos, normal, tangent ...", id="data"),
    pytest.param("{kind: contact, element: geom:FL, data: [force, found]}",
                 "2:46: error: sensors.s.data: list each data field once, in MuJoCo's order (the order of the "
                 "values): found, force", id="data-order"),
    pytest.param("{kind: contact, element: geom:FL, reduce: netforse}",
                 "2:48: error: sensors.s.reduce: reduce is one of none, mindist, maxforce, netforce; got 'netforse' "
                 "(did you mean 'netforce'?)", id="reduce"),
    pytest.param("{kind: insidesite, element: geom:FL}",
                 "2:13: error: sensors.s.kind: an insidesite sensor needs `with:`, one of site:<name>", id="with"),
    pytest.param("{kind: gyro, element: joint:hip_f}",
                 "2:28: error: sensors.s.element: a gyro sensor reads site:<name> or body:<name>; got 'joint:hip_f'",
                 id="element-type"),
    pytest.param("{kind: force, element: actuator:hip_f, frame: body:base}",
                 "2:45: error: sensors.s.frame: 'frame' is an option of MuJoCo's force sensor, but on an actuator "
                 "'force' is its attribute actuator_force (the element type decides): remove it", id="clash"),
    pytest.param("{kind: qpos, element: joint:hip_f, reduce: netforce}",
                 "2:41: error: sensors.s.reduce: 'reduce' is only for MuJoCo sensor kinds ...", id="not-native"),
])
def test_mistakes_are_positioned(sensor: str, expected: str) -> None:
    problems = sensorcfg.loads(f"sensors:\n  s: {sensor}\n", file="f.yaml").check(TERRAIN) \
        if "qpos" not in sensor else _load_problems(f"sensors:\n  s: {sensor}\n")
    lines = [p.format() for p in problems]
    assert len(lines) == 1, lines
    if expected.endswith(" ..."):
        assert lines[0].startswith("f.yaml:" + expected[:-4]), lines[0]
    else:
        assert lines[0] == "f.yaml:" + expected


def _load_problems(text: str) -> list[sensorcfg.Problem]:
    with pytest.raises(SuiteError) as info:
        sensorcfg.loads(text, file="f.yaml")
    return info.value.problems


def test_force_on_an_actuator_is_its_attribute_and_on_a_site_the_sensor() -> None:
    suite = sensorcfg.loads("sensors:\n  a: {kind: force, element: actuator:hip_f}\n"
                            "  s: {kind: force, element: site:imu}\n")
    model = suite.compile(TERRAIN)
    observables = suite.build(model)
    assert observables["a"].kind == "force" and observables["s"].kind == "sensordata"
    assert model.nsensor == 1 and model.sensor_type[0] == mujoco.mjtSensor.mjSENS_FORCE


def test_framelinvel_of_a_body_in_its_own_frame_is_zero() -> None:
    suite = sensorcfg.loads("sensors:\n  v: {kind: framelinvel, element: body:base, frame: body:base}\n"
                            "  w: {kind: framelinvel, element: body:base}\n")
    env = sensorcfg.Environment(TERRAIN, suite, seed=0)
    env.reset()
    for _ in range(20):
        obs = env.step(np.ones(2)).observation
    assert np.all(obs["v"] == 0) and np.any(obs["w"] != 0)


def test_a_type_this_mujoco_lacks_is_a_problem_at_the_kind(monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    from sensorcfg.native import table

    monkeypatch.setitem(table.NATIVE, "gyro", dataclasses.replace(table.NATIVE["gyro"], sensor="GYRO_OF_THE_FUTURE"))
    problems = sensorcfg.loads("sensors:\n  g: {kind: gyro, element: site:imu}\n", file="f.yaml").check(TERRAIN)
    assert [p.format() for p in problems] == [
        f"f.yaml:2:13: error: sensors.g.kind: this MuJoCo ({mujoco.__version__}) has no gyro sensor "
        "(mjSENS_GYRO_OF_THE_FUTURE); upgrade MuJoCo or use another kind"]


@pytest.mark.skipif(not MUJOCO4, reason="mujoco.batch needs MuJoCo 4")
def test_every_kind_runs_batched_bit_identical_to_single(tmp_path: Path) -> None:
    plain = tmp_path / "plain.xml"
    plain.write_text(_model_text())
    sensors = "\n".join(f"  s{i}: {row}" for i, (row, _) in enumerate(HAND_WRITTEN))
    suite = sensorcfg.loads(f"options: {{control_interval: 4}}\nsensors:\n{sensors}\n")
    assert_batch_equals_single(str(plain), suite, nsim=2, seed=5, steps=25)


SITE_KINDS = [row.kind for row in NATIVE.values() if row.body_site]
UNNAMED_BODY = '<body pos="-1 1 .6"><freejoint/><geom size=".05" mass=".2"/>{site}</body>'


@pytest.mark.parametrize("kind", SITE_KINDS)
def test_a_site_kind_reads_an_unnamed_body(kind: str, tmp_path: Path) -> None:
    """The site a body-attached kind needs is added to the body by id (it has no name to find it by); the
    values are those of the same sensor written on a site at the body's frame."""
    def text(site: str, sensors: str = "") -> str:
        return _model_text(sensors).replace("<worldbody>", "<worldbody>" + UNNAMED_BODY.format(site=site), 1)

    plain = tmp_path / "plain.xml"
    plain.write_text(text(""))
    camera = ' camera="cam"' if kind == "camprojection" else ""
    written = mujoco.MjModel.from_xml_string(text('<site name="s"/>', f'<{kind} site="s"{camera}/>'))
    body = next(i for i in range(written.nbody) if i and not written.body(i).name)
    with_ = ", with: camera:cam" if kind == "camprojection" else ""
    suite = sensorcfg.loads(f"sensors:\n  s: {{kind: {kind}, element: 'body:#{body}'{with_}}}\n"
                            f"  every: {{kind: {kind}, element: 'body:*'{with_}}}\n")
    assert suite.check(str(plain)) == []
    model = suite.compile(str(plain))
    read = suite.build(model)["s"].observation_callable(ours := Physics(model))
    theirs = Physics(written)
    for physics in (ours, theirs):
        physics.data.qvel[-6:] = [0.3, -0.2, 0.1, 0.5, -1.0, 2.0]
    for _ in range(30):
        ours.step()
        theirs.step()
        np.testing.assert_array_equal(np.ravel(read()), theirs.data.sensordata[:written.sensor_dim[0]])


@pytest.mark.parametrize("index", ["1:5", "5:"])
def test_an_index_past_a_sensor_kinds_axis_is_the_mistake_it_is_for_an_attribute(index: str) -> None:
    def problems(kind: str) -> list[str]:
        suite = sensorcfg.loads(f"sensors:\n  v: {{index: '{index}', kind: {kind}, element: site:imu}}\n", file="f.yaml")
        return [p.format() for p in suite.check(TERRAIN)]

    assert problems("velocimeter") == [p.replace("xpos", "velocimeter") for p in problems("xpos")]
    assert problems("velocimeter") == [
        f"f.yaml:2:14: error: sensors.v.index: index '{index}' reaches past axis 0 of velocimeter of one element "
        f"(shape (3,): 3 entries on that axis, 0 to 2); numpy would silently return fewer values: use a range within 0:3"]


def _counting_compiles(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    compile_ = mujoco.MjSpec.compile

    def counted(self: mujoco.MjSpec, *args: object) -> mujoco.MjModel:
        calls.append(1)
        return compile_(self, *args)

    monkeypatch.setattr(mujoco.MjSpec, "compile", counted)
    return calls


def test_what_mujoco_refuses_of_a_sensors_objects_is_said_before_compiling(monkeypatch: pytest.MonkeyPatch) -> None:
    """Joint types, limits and a pair of one object are the table's: 40 such sensors cost no extra compile."""
    compiles = _counting_compiles(monkeypatch)
    bad = {"ballquat": "joint:hip_f", "jointpos": "'joint:*'", "jointlimitpos": "'joint:#0'"}
    sensors = "".join(f"  s{i}: {{kind: {kind}, element: {element}}}\n"
                      for i in range(40) for kind, element in [list(bad.items())[i % 3]])
    sensors += "  d: {kind: geomdist, element: geom:FL, with: geom:FL}\n  ok: {kind: jointpos, element: joint:hip_f}\n"
    problems = sensorcfg.loads(f"sensors:\n{sensors}", file="f.yaml").check(TERRAIN)
    assert len(compiles) == 2  # the robot as written, and once with every sensor planned
    messages = {p.loc: p.message for p in problems}
    assert len(problems) == 41 and "sensors.ok.element" not in messages
    assert messages["sensors.s0.element"] == "a ballquat sensor reads a ball joint; hip_f is a hinge joint"
    assert messages["sensors.s1.element"] == "a jointpos sensor reads a slide or hinge joint; #0 is a free joint"
    assert messages["sensors.s2.element"] == "a jointlimitpos sensor reads a limited joint; #0 has no limits"
    assert messages["sensors.d.with"] == ("a geomdist sensor measures between two objects; 'FL' is both the "
                                          "element and `with:`: name another")


def test_refusals_mujoco_alone_finds_cost_a_bounded_number_of_compiles(monkeypatch: pytest.MonkeyPatch) -> None:
    from sensorcfg.native import compile as native_compile
    from sensorcfg.native import additions

    monkeypatch.setattr(additions, "_refusals", lambda *args: None)  # as if the table did not know: MuJoCo refuses
    compiles = _counting_compiles(monkeypatch)
    sensors = "".join(f"  s{i}: {{kind: ballquat, element: joint:hip_f}}\n" for i in range(30))
    problems = sensorcfg.loads(f"sensors:\n{sensors}", file="f.yaml").check(TERRAIN)
    assert len(compiles) <= native_compile.MAX_REFUSALS + 2
    assert [p.loc for p in problems] == [f"sensors.s{i}.kind" for i in range(30)]  # each at its line
    refused = [p for p in problems if p.message.startswith("MuJoCo refused the ballquat sensor: Error: joint must be ball")]
    assert len(refused) == native_compile.MAX_REFUSALS
    assert all(p.message == native_compile.NOT_COMPILED.format(kind="ballquat", count=native_compile.MAX_REFUSALS)
               for p in problems if p not in refused)


def test_each_unknown_data_field_is_reported_at_its_own_entry() -> None:
    """(Found by position, not by `list.index`: a repeated name is reported where it is, in linear time.)"""
    problems = sensorcfg.loads("sensors:\n  c: {kind: contact, element: geom:FL, data: [forse, found, forse]}\n",
                               file="f.yaml").check(TERRAIN)
    assert [p.loc for p in problems] == ["sensors.c.data.0", "sensors.c.data.2"]


@pytest.mark.parametrize("sensor, key", [
    pytest.param("{kind: framepos, element: body:base, frame: 'body:#4'}", "frame", id="frame"),
    pytest.param("{kind: contact, element: body:base, with: 'body:#4'}", "with", id="with"),
    pytest.param("{kind: framepos, element: 'body:#4'}", "element", id="element"),
])
def test_an_unnamed_element_a_sensor_refers_to_is_a_mistake_at_its_key(sensor: str, key: str) -> None:
    """MuJoCo's sensors name their objects: an unnamed one (a label `#4` is not its name) is said at the key
    that selects it, not compiled in as a name MuJoCo refuses."""
    model = str(MODELS / "menagerie_like.xml")
    problems = sensorcfg.loads(f"sensors:\n  s: {sensor}\n", file="f.yaml").check(model)
    assert [p.loc for p in problems] == [f"sensors.s.{key}"]
    assert "refer to elements by name" in problems[0].message and "name it in the model" in problems[0].message


def test_a_suite_added_to_another_librarys_scene_edits_the_scene_itself() -> None:
    """`Suite._add_to` (the mjlab adapter's `edit_spec`): the suite's sensors and sites are left in the scene's
    MjSpec, which compiles to the model `Suite.compile` gives from a copy; cameras it would add, a refused
    sensor, are said at their lines."""
    suite = sensorcfg.loads(EXAMPLE)
    spec = mujoco.MjSpec.from_file(TERRAIN)
    before = len(spec.sensors)
    model = suite._add_to(spec)
    copied = suite.compile(mujoco.MjSpec.from_file(TERRAIN), batch=True)
    assert len(spec.sensors) > before and spec.compile().nsensordata == model.nsensordata == copied.nsensordata
    names = [model.sensor(i).name for i in range(model.nsensor)]
    assert names == [copied.sensor(i).name for i in range(copied.nsensor)]
    with_cameras = sensorcfg.loads("cameras:\n  eye: {element: body:base, pos: [0, 0, 1]}\n"
                                   "sensors:\n  q: {kind: qpos, element: 'joint:*'}\n")
    with pytest.raises(SuiteError, match=r"<string>:2:3: error: cameras: a suite added to another library's scene "
                                         r"cannot add cameras"):
        with_cameras._add_to(mujoco.MjSpec.from_file(TERRAIN))


WELDED = """<mujoco><worldbody><body name="stand" pos="0 0 1"><geom size=".1"/><site name="fixed"/></body>
<body name="free" pos="1 0 1"><freejoint/><geom size=".1"/><site name="moving"/></body></worldbody></mujoco>"""


@pytest.mark.parametrize("kind", ["accelerometer", "framelinacc"])
def test_an_acceleration_sensor_on_a_welded_body_reads_gravity_or_is_refused(kind: str, tmp_path: Path) -> None:
    """MuJoCo 3.x reads an accelerometer (and framelinacc) on a body welded to the world as 0; MuJoCo 4 reads
    +9.81 up at rest, as table.py says. On 3.x the suite says so at the element; a moving body is read."""
    path = tmp_path / "welded.xml"
    path.write_text(WELDED)
    text = f"sensors:\n  still: {{kind: {kind}, element: site:fixed}}\n  free: {{kind: {kind}, element: body:free}}\n"
    problems = sensorcfg.loads(text, file="f.yaml").check(str(path))
    if MUJOCO4:
        assert problems == []
        env = sensorcfg.Environment(str(path), sensorcfg.loads(text), seed=0)
        np.testing.assert_allclose(env.reset().observation["still"].ravel(), [0, 0, 9.81])
    else:
        lines = [p.format() for p in problems]
        assert len(lines) == 1 and lines[0].startswith("f.yaml:2:"), lines
        assert f"{kind} sensor on a body welded to the world as 0" in lines[0]
        assert "site:fixed" in lines[0] and "MuJoCo >= 4" in lines[0]
