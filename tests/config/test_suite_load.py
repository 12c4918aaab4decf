"""Loading suites: the format's keys, defaults, extends, overrides, units, draws and building observables."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError
from sensorcfg.assets import path as asset_path
from sensorcfg.cli import main
from sensorcfg.config import SuiteConfig, to_steps
from sensorcfg.config.source import compose
from sensorcfg.draws import ChoiceSteps, UniformSteps

from conftest import MODELS

ROBOT = str(asset_path("robot.xml"))
ISSUE_EXAMPLE = """\
version: 1
model: {model}
options:
  pad_with_initial_value: false
  strip_singleton_buffer_dim: false
defaults:
  buffer: 1
sensors:
  joint_pos:
    kind: qpos
    element: "joint:*"
    delay: 2
  hand_vel:
    kind: sensordata
    element: ["sensor:imu_gyro", "sensor:imu_accel"]
    interval: 2ms
    buffer: 4
    aggregator: mean
    noise:
      - {{type: gaussian, std: 0.01}}
  wrist_cam:
    kind: rgb
    element: camera:wrist
    camera: {{width: 64, height: 48}}
    interval: 25Hz
    delay: {{uniform: [1, 3]}}
  target_dist:
    kind: generic
    callable: sensorcfg.assets.demo_sensors:hand_to_target
    enabled: false
"""


def write(directory: Path, name: str, text: str) -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture(scope="module")
def robot() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(ROBOT)


def run(observables, model, steps: int = 10, **kwargs):
    physics = sensorcfg.Physics(model)
    updater = sensorcfg.Updater(observables, **kwargs)
    updater.reset(physics, np.random.RandomState(0))
    for _ in range(steps):
        updater.prepare_for_next_control_step()
        for _ in range(updater.physics_steps_per_control_step):
            mujoco.mj_step(physics.model, physics.data)
            updater.update()
    return updater.get_observation(), physics


# -- the format -----------------------------------------------------------------------------------

def test_issue_example_loads_builds_and_runs(robot) -> None:
    suite = sensorcfg.loads(ISSUE_EXAMPLE.format(model=ROBOT))
    assert list(suite.sensors) == ["joint_pos", "hand_vel", "wrist_cam", "target_dist"]
    assert suite.model == ROBOT
    assert suite.options.pad_with_initial_value is False
    observables = suite.build(robot)
    assert list(observables) == list(suite.sensors)
    assert [o.enabled for o in observables.values()] == [True, True, True, False]
    assert isinstance(observables["wrist_cam"], sensorcfg.Camera)
    assert observables["hand_vel"].update_interval == 1  # 2ms at a 2ms timestep
    assert observables["wrist_cam"].update_interval == 20  # 25Hz
    assert observables["wrist_cam"].delay == UniformSteps(1, 3)
    assert observables["hand_vel"].noise is not None
    obs, _ = run(observables, robot, **suite.updater_kwargs(robot))
    assert obs["joint_pos"].shape == (1, robot.nq)
    assert obs["hand_vel"].shape == (6,)
    assert obs["wrist_cam"].shape == (1, 48, 64, 3) and obs["wrist_cam"].dtype == np.uint8
    assert "target_dist" not in obs


def test_feature_values_match_the_simulation(robot) -> None:
    suite = sensorcfg.loads("""
        sensors:
          arm: {kind: qpos, element: [joint:elbow, joint:shoulder]}
          wrist: {kind: qpos, element: joint:wrist, index: "1:3"}
          z: {kind: xpos, element: body:base, index: 2}
          motors: {kind: force, element: "actuator:*"}
        """)
    obs, physics = run(suite.build(robot), robot, strip_singleton_buffer_dim=True)
    data = physics.data
    shoulder, elbow, wrist = (robot.joint(n).qposadr[0] for n in ("shoulder", "elbow", "wrist"))
    np.testing.assert_array_equal(obs["arm"], data.qpos[[elbow, shoulder]])
    np.testing.assert_array_equal(obs["wrist"], data.qpos[wrist + 1:wrist + 3])
    assert obs["z"] == data.xpos[robot.body("base").id, 2]
    np.testing.assert_array_equal(obs["motors"], data.actuator_force)


def test_within_restricts_a_glob_to_a_subtree(robot) -> None:
    suite = sensorcfg.loads("sensors:\n  arm: {kind: qvel, element: 'joint:*', within: body:forearm}\n")
    obs, physics = run(suite.build(robot), robot, strip_singleton_buffer_dim=True)
    # elbow (1 dof), wrist (ball, 3 dofs), finger_slide (1 dof)
    assert obs["arm"].shape == (5,)


def test_defaults_fill_what_a_sensor_leaves_out() -> None:
    suite = sensorcfg.loads("""
        defaults: {interval: 4ms, buffer: 3, noise: [{type: gaussian, std: 0.1}], camera: {width: 32}}
        sensors:
          a: {kind: qpos, element: joint:elbow}
          b: {kind: qpos, element: joint:elbow, buffer: 1, noise: []}
          c: {kind: rgb, element: camera:wrist, camera: {height: 24}}
        """)
    a, b, c = suite.sensors.values()
    assert (a.interval, a.buffer, len(a.noise), a.enabled) == ("4ms", 3, 1, True)
    assert (b.interval, b.buffer, b.noise) == ("4ms", 1, ())
    assert (c.camera.width, c.camera.height) == (32, 24)
    assert a.camera is None  # camera defaults apply to image sensors only


def test_configs_are_frozen_and_round_trip() -> None:
    suite = sensorcfg.loads(ISSUE_EXAMPLE.format(model=ROBOT))
    with pytest.raises(Exception):
        suite.config.version = 2  # type: ignore[misc]
    dumped = suite.config.model_dump(mode="json", exclude_none=True)
    assert dumped["sensors"]["wrist_cam"]["delay"] == {"uniform": [1, 3]}
    assert SuiteConfig.model_validate(dumped) == suite.config


def test_yaml_anchors_and_merge_keys() -> None:
    suite = sensorcfg.loads("""
        sensors:
          a: &fast {kind: qpos, element: joint:elbow, interval: 2, buffer: 2}
          b: {<<: *fast, kind: qvel, buffer: 5}
        """)
    a, b = suite.sensors.values()
    assert (a.interval, a.buffer, b.kind, b.element, b.interval, b.buffer) == (2, 2, "qvel", "joint:elbow", 2, 5)


@pytest.mark.parametrize(("text", "value"), [
    # numbers as YAML 1.2's core schema (and the JSON Schema, yaml-language-server) reads them (issue 24)
    ("1e-3", 0.001), ("1E+2", 100.0), (".5", 0.5), ("-.5e3", -500.0), ("+.5", 0.5), ("1.", 1.0), ("+1", 1),
    ("017", 17), ("-017", -17), ("0o17", 15), ("0x1F", 31), (".inf", math.inf), ("-.Inf", -math.inf),
    ("5e-324", 5e-324), ("!!int 017", 17), ("!!float 1", 1.0),
    # YAML 1.1's other spellings are text in YAML 1.2
    ("1_000", "1_000"), ("0b101", "0b101"), ("1:20", "1:20"), ("+0x1", "+0x1"), ("0o8", "0o8"), ("yes", "yes"),
    ("on", "on"), ("Off", "Off"), ("2001-12-14", "2001-12-14"), ("=", "="),
    # booleans and null in their YAML 1.2 spellings; times stay text
    ("True", True), ("FALSE", False), ("~", None), ("Null", None), ("2ms", "2ms"), ("250Hz", "250Hz"),
    ("1e-3s", "1e-3s"), ("'1e-3'", "1e-3"),
])
def test_plain_scalars_are_read_as_yaml_1_2_reads_them(text: str, value: object) -> None:
    read = compose(text, "x.yaml")
    assert not read.problems and type(read.value) is type(value) and read.value == value
    assert math.isnan(compose(".NaN", "x.yaml").value)


def test_numbers_in_exponent_form_load_in_suites_extends_and_overrides(tmp_path: Path) -> None:
    """`std: 1e-3` was text to PyYAML's YAML 1.1 rules, so a suite an editor accepted failed to load (issue 24)."""
    write(tmp_path, "base.yaml", """
        model: package://sensorcfg/assets/robot.xml
        sensors:
          s: {kind: qpos, element: joint:elbow, noise: [{type: gaussian, std: 1e-3}, {type: quantize, step: 1E-4}]}
        """)
    top = write(tmp_path, "top.yaml", """
        extends: base.yaml
        sensors:
          t: {kind: qvel, element: joint:elbow, noise: [{type: clip, min: -.5e1, max: 5E+0}]}
        """)
    suite = sensorcfg.load(top)
    assert (suite.sensors["s"].noise[0].std, suite.sensors["s"].noise[1].step) == (0.001, 0.0001)
    assert (suite.sensors["t"].noise[0].min, suite.sensors["t"].noise[0].max) == (-5.0, 5.0)
    suite = sensorcfg.load(top, overrides=["sensors.s.noise.0.std=2.5e-3", "sensors.t.noise.0.max=.5"])
    assert (suite.sensors["s"].noise[0].std, suite.sensors["t"].noise[0].max) == (0.0025, 0.5)
    assert main(["validate", str(top), "--set", "sensors.s.noise.0.std=2.5e-3"]) == 0


def test_python_tags_are_never_constructed(tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    text = f"sensors:\n  s: !!python/object/apply:os.system ['touch {marker}']\n"
    with pytest.raises(SuiteError, match="the tag '!!python/object/apply:os.system' is not allowed"):
        sensorcfg.loads(text)
    assert not marker.exists()


# -- extends --------------------------------------------------------------------------------------

def test_extends_chains_and_overrides_field_by_field(tmp_path: Path) -> None:
    write(tmp_path, "base.yaml", f"""
        model: package://sensorcfg/assets/robot.xml
        options: {{strip_singleton_buffer_dim: true}}
        sensors:
          a: {{kind: qpos, element: joint:elbow, interval: 2, buffer: 3}}
          b: {{kind: qvel, element: joint:elbow}}
          c: {{kind: xpos, element: body:hand}}
        """)
    (tmp_path / "mid").mkdir()
    write(tmp_path / "mid", "mid.yaml", """
        extends: ../base.yaml
        sensors:
          a: {interval: 4}
          c: null
        """)
    top = write(tmp_path, "top.yaml", """
        extends: mid/mid.yaml
        options: {pad_with_initial_value: true}
        sensors:
          b: {delay: 1}
          d: {kind: qpos, element: joint:shoulder}
        """)
    suite = sensorcfg.load(top)
    assert list(suite.sensors) == ["a", "b", "d"]
    assert (suite.sensors["a"].interval, suite.sensors["a"].buffer) == (4, 3)
    assert suite.sensors["b"].delay == 1
    assert suite.options.strip_singleton_buffer_dim and suite.options.pad_with_initial_value
    assert suite.model == ROBOT


def test_a_mistake_in_a_parent_points_into_the_parent(tmp_path: Path) -> None:
    write(tmp_path, "base.yaml", "sensors:\n  a: {kind: qpos, element: joint:elbow, buffer: 0}\n")
    top = write(tmp_path, "top.yaml", "extends: base.yaml\nsensors:\n  a: {interval: 2}\n")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(top)
    [problem] = info.value.problems
    assert (Path(problem.file).name, problem.line, problem.col, problem.loc) == ("base.yaml", 2, 49, "sensors.a.buffer")


def test_extends_cycle_is_an_error(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    write(tmp_path, "a.yaml", "extends: b.yaml\nsensors: {}\n")
    write(tmp_path, "b.yaml", "sensors: {}\nextends: a.yaml\n")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load("a.yaml")
    assert str(info.value) == ("b.yaml:2:10: error: extends: extends makes a cycle: a.yaml -> b.yaml -> a.yaml; "
                               "remove one of these extends")


def test_model_path_is_relative_to_the_file_that_names_it(tmp_path: Path) -> None:
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "robot.xml").write_text(Path(ROBOT).read_text())
    write(tmp_path / "models", "base.yaml", "model: robot.xml\nsensors:\n  a: {kind: qpos, element: joint:elbow}\n")
    top = write(tmp_path, "top.yaml", "extends: models/base.yaml\nsensors: {}\n")
    suite = sensorcfg.load(top)
    assert Path(suite.model) == (tmp_path / "models" / "robot.xml").resolve()
    assert list(suite.build()) == ["a"]


def test_package_model_scheme() -> None:
    suite = sensorcfg.loads("model: package://sensorcfg/assets/robot.xml\nsensors: {}\n")
    assert Path(suite.model) == Path(ROBOT)


# -- overrides ------------------------------------------------------------------------------------

def test_overrides_are_validated_like_the_file() -> None:
    text = ISSUE_EXAMPLE.format(model=ROBOT)
    suite = sensorcfg.loads(text, overrides=["sensors.wrist_cam.interval=10", "defaults.buffer=2",
                                             "sensors.hand_vel.noise.0.std=0.5", "sensors.target_dist=null",
                                             "sensors.extra={kind: qvel, element: 'joint:elbow'}"])
    assert suite.sensors["wrist_cam"].interval == 10
    assert suite.sensors["joint_pos"].buffer == 2
    assert suite.sensors["hand_vel"].noise[0].std == 0.5
    assert list(suite.sensors) == ["joint_pos", "hand_vel", "wrist_cam", "extra"]


def test_overrides_given_as_a_mapping_of_dotted_keys_to_values() -> None:
    """`load(overrides={...})` takes Python values by dotted key, as the strings take YAML text: the same
    suite, and text stays text (a str that YAML would read as a number is not one)."""
    text = ISSUE_EXAMPLE.format(model=ROBOT)
    written = sensorcfg.loads(text, overrides=["sensors.wrist_cam.interval=10", "defaults.buffer=2",
                                               "sensors.hand_vel.noise.0.std=0.5", "sensors.target_dist=null",
                                               "sensors.extra={kind: qvel, element: 'joint:elbow', delay: "
                                               "{uniform: [1, 3]}}"])
    mapped = sensorcfg.loads(text, overrides={
        "sensors.wrist_cam.interval": np.int64(10), "defaults.buffer": 2, "sensors.hand_vel.noise.0.std": 0.5,
        "sensors.target_dist": None, "sensors.extra": {"kind": "qvel", "element": "joint:elbow",
                                                       "delay": {"uniform": (1, 3)}}})
    assert mapped.sensors == written.sensors
    with pytest.raises(SuiteError) as info:
        sensorcfg.loads(text, overrides={"defaults.buffer": "2", "sensors.wrist_cam.delay": float("inf")})
    assert str(info.value).splitlines() == [
        "override 'defaults.buffer=\"2\"':1:17: error: defaults.buffer: expected an integer; got the text '2'",
        "override 'sensors.wrist_cam.delay=.inf':1:25: error: sensors.wrist_cam.delay: expected integer physics "
        "steps, a duration like '4ms', or {uniform: [lo, hi]} / {choice: [...], p: [...]}; got inf"]


@pytest.mark.parametrize(("overrides", "expected"), [
    pytest.param({"defaults.buffer=2": 1}, "an overrides mapping's keys are dotted keys such as 'defaults.buffer' "
                 "(no '='); got 'defaults.buffer=2'", id="key-with-equals"),
    pytest.param({3: 1}, "an overrides mapping's keys are dotted keys such as 'defaults.buffer' (no '='); got 3",
                 id="key-not-text"),
    pytest.param({"defaults.buffer": object()}, "overrides['defaults.buffer'] is of type object; an override's "
                 "value is what YAML holds: None, a bool, a number, a str, or a list or dict of them", id="value"),
    pytest.param("defaults.buffer=2", "overrides is a list of 'dotted.key=value' strings, for example "
                 "['defaults.buffer=2'], or a mapping of dotted keys to values, {'defaults.buffer': 2}; got "
                 "'defaults.buffer=2'", id="one-string"),
])
def test_overrides_that_are_neither_form_are_argument_errors(overrides: object, expected: str) -> None:
    with pytest.raises(sensorcfg.ArgumentError) as info:
        sensorcfg.loads(ISSUE_EXAMPLE.format(model=ROBOT), overrides=overrides)  # type: ignore[arg-type]
    assert str(info.value) == expected


@pytest.mark.parametrize(("override", "expected"), [
    pytest.param("sensors.wrist_cam.interval=7mss",
                 "override 'sensors.wrist_cam.interval=7mss':1:28: error: sensors.wrist_cam.interval: "
                 "unknown time unit 'mss' in '7mss'; use one of s, ms, us, µs, ns, Hz, kHz", id="value"),
    pytest.param("sensors.wrist_cm.interval=10",
                 "override 'sensors.wrist_cm.interval=10':1:1: error: sensors.wrist_cm: there is no sensor "
                 "'wrist_cm' to override (did you mean 'wrist_cam'?); sensors: joint_pos, hand_vel, wrist_cam, "
                 "target_dist", id="sensor-name"),
    pytest.param("defaults.bufer=2",
                 "override 'defaults.bufer=2':1:1: error: defaults.bufer: unknown key 'bufer' (did you mean "
                 "'buffer'?); allowed keys: interval, delay, buffer, aggregator, enabled, noise, twin, camera", id="key"),
    pytest.param("sensors.wrist_cam.delay={uniform: [1, 3}",
                 "override 'sensors.wrist_cam.delay={uniform: [1, 3}':1:40: error: invalid YAML: expected ',' or "
                 "']', but got '}' (while parsing a flow sequence)", id="yaml"),
    pytest.param("sensors.wrist_cam.delay={uniform: [1, 3",
                 "override 'sensors.wrist_cam.delay={uniform: [1, 3':1:35: error: invalid YAML: this '[' is never "
                 "closed; add ']' after its last item", id="yaml-unclosed"),
    pytest.param("buffer 2",
                 "override 'buffer 2':1:1: error: an override is written key=value, for example "
                 "sensors.cam.interval=10 or defaults.buffer=2", id="form"),
    pytest.param("extends=base.yaml",
                 "override 'extends=base.yaml':1:1: error: extends: extends cannot be overridden (overrides apply "
                 "after the files are merged); write a suite that extends the other one instead", id="extends"),
    pytest.param("sensors.hand_vel.noise.3.std=1",
                 "override 'sensors.hand_vel.noise.3.std=1':1:1: error: sensors.hand_vel.noise.3.std: "
                 "sensors.hand_vel.noise is a list of 1; use an index 0..0", id="index"),
])
def test_override_mistakes_name_the_override(override: str, expected: str) -> None:
    with pytest.raises(SuiteError) as info:
        sensorcfg.loads(ISSUE_EXAMPLE.format(model=ROBOT), overrides=[override])
    assert str(info.value) == expected


# -- units and draws ------------------------------------------------------------------------------

@pytest.mark.parametrize(("value", "minimum", "steps"), [
    (3, 1, 3), ("4ms", 1, 2), ("0.02s", 1, 10), ("2000us", 0, 1), ("50Hz", 1, 10), ("0.5kHz", 1, 1),
    ("0ms", 0, 0), ("3e-3 s", 1, None), ("7ms", 1, None), ("1kHz", 1, None),
])
def test_to_steps(value, minimum, steps) -> None:
    if steps is None:
        with pytest.raises(ValueError, match="; use "):
            to_steps(value, 0.002, minimum=minimum)
    else:
        assert to_steps(value, 0.002, minimum=minimum) == steps


def _suggestions(message: str) -> list[int | str]:
    """The values a to_steps message offers ('...; use 250Hz or 6ms'), as a suite would write them."""
    offered = message.rpartition("; use ")[2].removesuffix(" (an integer is physics steps)")
    return [int(text) if text.isdigit() else text for text in offered.split(" or ")]


_TIMESTEPS = (0.002, 0.001, 0.0005, 0.004, 0.01, 0.0025, 1 / 60, 1 / 3000, 0.00033, 0.0013, 7e-5)
_TIMES = [f"{n}Hz" for n in (1, 3, 7, 33, 45, 60, 120, 200, 240, 300, 333, 500, 700, 999, 1500)] + [
    f"{n}ms" for n in (0.3, 1, 1.5, 3, 4.4, 7, 9.1, 25, 33.3)] + ["0.7kHz", "2.5kHz", "0.05s", "123us"]


@pytest.mark.parametrize("timestep", _TIMESTEPS, ids=lambda t: f"{t:.6g}s")
def test_every_suggested_time_is_accepted_when_substituted(timestep: float) -> None:
    """Issue 30: 200Hz on 2ms steps suggested 166.667Hz, which is then rejected (1/(166.667 * 2ms) is not 3)."""
    refused = 0
    for value in _TIMES:
        for minimum in (0, 1) if not value.endswith("Hz") else (1,):
            try:
                to_steps(value, timestep, minimum=minimum)
                continue
            except ValueError as e:
                if "; use " not in str(e):
                    continue  # past the largest schedule: no suggestion
                offered = _suggestions(str(e))
            refused += 1
            assert offered, value
            for suggestion in offered:
                assert to_steps(suggestion, timestep, minimum=minimum) >= minimum, (value, timestep, str(e))
    assert refused > len(_TIMES) // 2


def test_a_rate_between_whole_steps_suggests_what_validates() -> None:
    with pytest.raises(ValueError) as info:
        to_steps("200Hz", 0.002, minimum=1)
    assert str(info.value) == "200Hz is not a whole number of 2ms physics steps (2.5 steps); use 250Hz or 6ms"
    with pytest.raises(ValueError) as info:
        to_steps("1.5ms", 1 / 3000, minimum=1)  # no decimal duration is 4 or 5 of these steps in six digits
    assert str(info.value).endswith("; use 4 or 5 (an integer is physics steps)")


def test_uniform_and_choice_draws_are_seeded_and_inclusive() -> None:
    rs = np.random.RandomState(1)
    draws = np.array([UniformSteps(1, 3)(random_state=rs) for _ in range(3000)])
    assert set(draws) == {1, 2, 3}
    assert abs((draws == 2).mean() - 1 / 3) < 0.04  # ~4.6 sigma for n=3000
    rng = np.random.default_rng(2)
    picks = np.array([ChoiceSteps((5, 10), (0.8, 0.2))(random_state=rng) for _ in range(3000)])
    assert set(picks) == {5, 10} and abs((picks == 5).mean() - 0.8) < 0.03
    first, second = (UniformSteps(0, 99)(random_state=np.random.RandomState(7)) for _ in range(2))
    assert first == second


def test_random_delay_is_drawn_per_sample_in_the_updater(robot) -> None:
    """A delayed time stamp lags by 1..3 steps, and every lag occurs."""
    suite = sensorcfg.loads("sensors:\n  t: {kind: qpos, element: joint:finger_slide, delay: {uniform: [1, 3]}}\n")
    observables = suite.build(robot)
    physics = sensorcfg.Physics(robot)
    updater = sensorcfg.Updater(observables, strip_singleton_buffer_dim=True)
    updater.reset(physics, np.random.RandomState(0))
    lags = set()
    for step in range(1, 300):
        physics.data.qpos[robot.joint("finger_slide").qposadr[0]] = step  # a clock the sensor reads
        updater.prepare_for_next_control_step()
        updater.update()
        lags.add(step - float(updater.get_observation()["t"][0]))
    assert {1.0, 2.0, 3.0} <= lags <= {1.0, 2.0, 3.0, 4.0, 5.0}


# -- check and build ------------------------------------------------------------------------------

def test_check_lists_every_problem_and_never_raises(robot) -> None:
    suite = sensorcfg.loads("""
        sensors:
          a: {kind: qpos, element: joint:elbo}
          b: {kind: xpos, element: site:toe_*}
          c: {kind: qvel, element: joint:elbow, interval: 3ms}
          d: {kind: qpos, element: joint:elbow}
        """)
    problems = suite.check(robot)
    assert [p.loc for p in problems] == ["sensors.a.element", "sensors.b.element", "sensors.c.interval"]
    assert suite.check("/no/such/model.xml")[0].message.startswith("cannot load the model '/no/such/model.xml'")
    assert suite.check()[0].message.startswith("no model to check against")


def test_check_does_not_import_generic_callables(tmp_path: Path, monkeypatch, robot) -> None:
    (tmp_path / "probe_sensors.py").write_text(
        "import numpy as np\nIMPORTED = True\ndef read(physics):\n    return np.zeros(2)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    suite = sensorcfg.loads("sensors:\n  g: {kind: generic, callable: 'probe_sensors:read', "
                            "noise: [{type: gaussian, std: 1}]}\n")
    assert suite.check(robot) == []
    assert "probe_sensors" not in sys.modules
    assert suite.check(robot, import_callables=True) == []
    assert "probe_sensors" in sys.modules
    observables = suite.build(robot)
    obs, _ = run(observables, robot, strip_singleton_buffer_dim=True)
    assert obs["g"].shape == (2,) and np.all(obs["g"] != 0)  # the noise applied
    monkeypatch.delitem(sys.modules, "probe_sensors")


def test_check_with_imported_callables_finds_what_building_refuses(tmp_path: Path, monkeypatch, robot) -> None:
    """Issue 30: check(import_callables=True) passed suites the environment then refused (or, for an aggregator
    with no buffer axis, ran with the value's own axis reduced)."""
    (tmp_path / "three_sensors.py").write_text(
        "import numpy as np\nCALLS = []\ndef read(physics):\n    CALLS.append(1)\n    return np.zeros(3)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    no_axis = sensorcfg.loads("options: {strip_singleton_buffer_dim: true}\nsensors:\n  g: {kind: generic, "
                              "callable: 'three_sensors:read', buffer: 1, aggregator: mean}\n", file="s.yaml")
    expected = ("s.yaml:3:77: error: sensors.g.aggregator: with options.strip_singleton_buffer_dim and a buffer of 1 "
                "there is no buffer axis, so 'mean' would reduce the value's own first axis{}; remove the "
                "aggregator, or use a buffer of 2 or more")
    assert [p.format() for p in no_axis.check(robot)] == [expected.format("")]  # decided without the callable
    assert "three_sensors" not in sys.modules
    found = no_axis.check(robot, import_callables=True)
    assert [p.format() for p in found] == [expected.format(" (shape (3,))")]
    with pytest.raises(SuiteError) as info:
        no_axis.build(robot)
    assert info.value.problems == found
    noisy = sensorcfg.loads("sensors:\n  g: {kind: generic, callable: 'three_sensors:read', "
                            "noise: [{type: clip, min: [0, 0], max: 1}]}\n", file="s.yaml")
    assert noisy.check(robot) == []  # (the shape is not known without the callable)
    found = noisy.check(robot, import_callables=True)
    assert [p.format() for p in found] == ["s.yaml:2:80: error: sensors.g.noise.0.min: 2 entries do not fit the "
                                           "observation's shape (3,): give a number or 3 (one per value)"]
    with pytest.raises(SuiteError) as info:
        noisy.build(robot)
    assert info.value.problems == found
    calls = sys.modules["three_sensors"].CALLS
    assert len(calls) == 4  # once per check (imported) or build that needed the shape, on a fresh state
    monkeypatch.delitem(sys.modules, "three_sensors")


def test_a_missing_generic_callable_is_reported_when_imported(robot) -> None:
    suite = sensorcfg.loads("sensors:\n  g: {kind: generic, callable: 'sensorcfg.assets.demo_sensors:hand_to_targt'}\n",
                            file="suite.yaml")
    assert suite.check(robot) == []
    [problem] = suite.check(robot, import_callables=True)
    assert problem.format() == ("suite.yaml:2:32: error: sensors.g.callable: module 'sensorcfg.assets.demo_sensors' "
                                "has no 'hand_to_targt' (did you mean 'hand_to_target'?)")


def test_updater_kwargs_convert_the_control_interval(robot) -> None:
    suite = sensorcfg.loads("options: {control_interval: 50Hz, pad_with_initial_value: true}\nsensors: {}\n")
    assert suite.updater_kwargs(robot) == {"physics_steps_per_control_step": 10, "pad_with_initial_value": True,
                                           "strip_singleton_buffer_dim": False}


def test_config_layer_does_not_import_mujoco() -> None:
    """Load a suite with the config layer alone (the package __init__, which imports mujoco, bypassed)."""
    code = textwrap.dedent(f"""
        import sys, types, importlib
        package = types.ModuleType("sensorcfg")
        package.__path__ = [{str(Path(sensorcfg.__file__).parent)!r}]
        sys.modules["sensorcfg"] = package
        config = importlib.import_module("sensorcfg.config")
        suite = config.load_text("sensors:\\n  a: {{kind: qpos, element: 'joint:*', aggregator: mean}}\\n")
        config.json_schema()
        assert list(suite.sensors) == ["a"]
        bad = [name for name in sys.modules if name == "mujoco" or name.startswith("mujoco.")]
        assert not bad, bad
        print("ok")
    """)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.stdout.strip() == "ok", result.stderr


def test_config_tables_agree_with_the_runtime_tables() -> None:
    from sensorcfg.config.tables import IMAGE_KINDS, aggregator_names
    from sensorcfg.observables.camera import MODES

    assert IMAGE_KINDS == tuple(MODES)
    assert aggregator_names() == tuple(sensorcfg.AGGREGATORS)


def test_names_with_slashes_and_subtrees_on_an_attached_model() -> None:
    model = mujoco.MjModel.from_xml_path(str(MODELS / "prefixed.xml"))
    suite = sensorcfg.loads("""
        sensors:
          left/swing: {kind: qpos, element: "joint:left/*"}
          tips: {kind: xpos, element: "site:*", within: "body:right/base"}
          angle: {kind: sensordata, element: "sensor:left/angle"}
        """)
    obs, physics = run(suite.build(model), model, strip_singleton_buffer_dim=True)
    assert obs["left/swing"].shape == (1,)
    np.testing.assert_array_equal(obs["tips"], physics.data.site_xpos[[model.site("right/tip").id]])
    assert obs["angle"].shape == (1,)
    [problem] = sensorcfg.loads("sensors:\n  a: {kind: qpos, element: 'joint:left/swig'}\n").check(model)
    assert problem.message == "the model has no joint named 'left/swig' (did you mean 'left/swing' or 'right/swing'?)"


def test_alias_bombs_are_cut_short() -> None:
    lists = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    lists += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 9)]  # 10**9 values
    with pytest.raises(SuiteError, match="expands to more than 100,000 values"):
        sensorcfg.loads("defaults:\n  x:\n" + "".join(f"    {line}\n" for line in lists) + "sensors: {}\n")


def test_runtime_layer_does_not_import_mujoco() -> None:
    """The scheduling runtime is numpy only (STYLE.md): import it with the package __init__ bypassed."""
    code = textwrap.dedent(f"""
        import sys, types, importlib
        package = types.ModuleType("sensorcfg")
        package.__path__ = [{str(Path(sensorcfg.__file__).parent)!r}]
        sys.modules["sensorcfg"] = package
        importlib.import_module("sensorcfg.runtime.updater")
        importlib.import_module("sensorcfg.runtime.bank")
        bad = [name for name in sys.modules if name == "mujoco" or name.startswith("mujoco.")]
        assert not bad, bad
        print("ok")
    """)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.stdout.strip() == "ok", result.stderr


NO_MODEL = "sensors:\n  q: {kind: qpos, element: 'joint:*'}\n"


def test_environments_given_no_model_run_on_the_suite_model_line(tmp_path: Path) -> None:
    """`Environment(None, suite)` and `BatchEnvironment(None, suite, n)` use the suite's `model:` as
    `make_env` does, for a Suite or a suite path."""
    path = tmp_path / "s.yaml"
    path.write_text("model: package://sensorcfg/assets/robot.xml\n" + NO_MODEL)
    nq = mujoco.MjModel.from_xml_path(ROBOT).nq
    assert sensorcfg.Environment(None, sensorcfg.load(path)).reset().observation["q"].shape == (1, nq)
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("BatchEnvironment needs MuJoCo 4")
    for suite in (sensorcfg.load(path), str(path)):
        batch = sensorcfg.BatchEnvironment(None, suite, 3)
        assert batch.reset().observation["q"].shape == (3, 1, nq)


def test_an_environment_with_no_model_anywhere_says_where_to_give_one(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(NO_MODEL)
    message = (f"{sensorcfg.load(path).file}: error: model: the suite names no model: add 'model: "
               "path/to/robot.xml' to the suite, or pass the model (an MjModel, an MjSpec or a path) as the first "
               "argument")
    makers = [lambda: sensorcfg.make_env(path), lambda: sensorcfg.Environment(None, sensorcfg.load(path))]
    if int(mujoco.__version__.split(".")[0]) >= 4:
        makers.append(lambda: sensorcfg.BatchEnvironment(None, sensorcfg.load(path), 2))
    for make in makers:
        with pytest.raises(SuiteError) as e:
            make()
        assert str(e.value) == message
    with pytest.raises(sensorcfg.ArgumentError, match=r"^model is None, and a dict of observables names no model: "
                       r"pass an MjModel, an MjSpec or a model path$"):
        sensorcfg.Environment(None, {})
