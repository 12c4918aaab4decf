"""Camera sizes from the model's own `resolution`, scene flags by name, and sizes OpenGL cannot render."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError

MODEL = """
<mujoco>
  <visual><global offwidth="400" offheight="300"/></visual>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1=".4 .6 .8" rgb2="0 0 0" width="32" height="32"/>
    <texture name="grid" type="2d" builtin="checker" rgb1=".1 .2 .3" rgb2=".2 .3 .4" width="64" height="64"/>
    <material name="floor" texture="grid" texrepeat="4 4" reflectance="0.5"/>
  </asset>
  <worldbody>
    <light name="sun" pos="0 0 3" dir="0 0 -1" castshadow="true"/>
    <geom name="floor" type="plane" size="2 2 .1" material="floor"/>
    <body name="ball" pos="0 0 .5"><freejoint/><geom size=".2" rgba=".9 .4 .1 1"/></body>
    <camera name="sized" pos="0 -2 1.5" xyaxes="1 0 0 0 .6 .8" resolution="64 48"/>
    <camera name="plain" pos="0 -2 1.5" xyaxes="1 0 0 0 .6 .8"/>
    <camera name="huge" pos="0 -2 1.5" xyaxes="1 0 0 0 .6 .8" resolution="800 600"/>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def model_path(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("scene") / "scene.xml"
    path.write_text(MODEL)
    return str(path)


def suite(model_path: str, sensors: str) -> sensorcfg.Suite:
    return sensorcfg.loads(f"model: {model_path}\nsensors:\n{sensors}", file="s.yaml",
                           base_dir=Path(model_path).parent)  # a suite's model lies in its folder tree


def test_the_cameras_own_resolution_is_the_default_size(model_path: str) -> None:
    s = suite(model_path, """\
  sized: {kind: rgb, element: camera:sized}
  plain: {kind: depth, element: camera:plain}
  narrower: {kind: rgb, element: camera:sized, camera: {width: 32}}
""")
    env = sensorcfg.Environment(model_path, s, seed=0)
    spec = env.observation_spec()
    assert spec["sized"].shape == (1, 48, 64, 3)  # resolution="64 48"
    assert spec["plain"].shape == (1, 240, 320, 1)  # no resolution: 320x240
    assert spec["narrower"].shape == (1, 48, 32, 3)  # the suite's width, the camera's height
    obs = env.reset().observation
    assert obs["sized"].shape == (1, 48, 64, 3) and obs["plain"].shape == (1, 240, 320, 1)


def test_the_python_camera_defaults_to_the_resolution_too(model_path: str) -> None:
    physics = sensorcfg.Physics.from_xml_path(model_path)
    physics.forward()
    camera = sensorcfg.Camera("sized")
    assert camera.array_spec is None  # unknown before it is bound to a model
    assert camera(physics).shape == (48, 64, 3)
    assert camera.array_spec.shape == (48, 64, 3) and (camera.width, camera.height) == (64, 48)


def test_a_resolution_beyond_the_offscreen_buffer_is_a_problem_at_the_element(model_path: str) -> None:
    width, height = suite(model_path, "  big: {kind: rgb, element: camera:huge}\n").check()
    assert width.format() == (
        "s.yaml:3:29: error: sensors.big.element: the camera's resolution width of 800 exceeds the model's offscreen "
        "buffer (400); set camera: {width: 400} (or less) or add <visual><global offwidth=\"800\"/></visual> to "
        "the model")
    assert height.message.startswith("the camera's resolution height of 600 exceeds the model's offscreen buffer (300)")


@pytest.mark.parametrize("camera,message", [
    pytest.param("{width: 20000, height: 10}", "3:57: error: sensors.c.camera.width: a width of 20000 is larger than "
                 "OpenGL framebuffers allow (16384 pixels a side in Mesa and on most GPUs); ask for a smaller image",
                 id="over-gl-limit"),
    pytest.param("{width: 64, height: 48, scene: {flag: true}}", "3:81: error: sensors.c.camera.scene.flag: unknown "
                 "scene flag 'flag'; flags: shadow, wireframe, reflection", id="unknown-flag"),
    pytest.param("{width: 64, height: 48, scene: {shadows: false}}", "3:81: error: sensors.c.camera.scene.shadows: "
                 "unknown scene flag 'shadows' (did you mean 'shadow'?)", id="did-you-mean"),
])
def test_camera_mistakes_are_problems_at_their_line(model_path: str, camera: str, message: str) -> None:
    problems = suite(model_path, f"  c: {{kind: rgb, element: camera:sized, camera: {camera}}}\n").check()
    assert len(problems) == 1 and problems[0].format().startswith("s.yaml:" + message), problems


def test_an_unknown_flag_from_python_is_a_suite_error() -> None:
    with pytest.raises(SuiteError, match=r"unknown scene flag 'flag'"):
        sensorcfg.Camera("sized", 48, 64, scene_option={"flag": True})


def _frames(model_path: str, scene: str) -> dict[str, np.ndarray]:
    s = suite(model_path, f"""\
  flagged: {{kind: rgb, element: camera:sized, camera: {{scene: {scene}}}}}
  default: {{kind: rgb, element: camera:sized}}
""")
    env = sensorcfg.Environment(model_path, s, seed=0)
    return {k: v[0] for k, v in env.reset().observation.items()}


@pytest.mark.parametrize("scene", ["{shadow: false}", "{reflection: false}", "{skybox: false}",
                                   "{shadow: false, reflection: false, skybox: false}"])
def test_scene_flags_change_the_image_and_do_not_leak(model_path: str, scene: str) -> None:
    frames = _frames(model_path, scene)
    assert not np.array_equal(frames["flagged"], frames["default"])  # the flag took effect
    alone = suite(model_path, "  default: {kind: rgb, element: camera:sized}\n")
    reference = sensorcfg.Environment(model_path, alone, seed=0).reset().observation["default"][0]
    np.testing.assert_array_equal(frames["default"], reference)  # the shared renderer's flags were set back


def test_a_flag_turned_on_takes_effect(model_path: str) -> None:
    frames = _frames(model_path, "{wireframe: true}")
    assert not np.array_equal(frames["flagged"], frames["default"])


def test_costly_default_rendering_is_a_note_where_the_fix_goes(model_path: str, tmp_path, capsys) -> None:
    """MuJoCo's default flags draw shadows and reflections (dm_control's look, kept by default); on a model
    with lights that cast shadows or reflective materials, validate and spec say so as a note at the
    sensor (its `scene` when it has one), with the flags that turn them off, and the suite stays valid."""
    from sensorcfg.cli import main

    s = suite(model_path, """\
  plain: {kind: rgb, element: camera:sized}
  half: {kind: depth, element: camera:sized, camera: {scene: {shadow: false}}}
  cheap: {kind: rgb, element: camera:sized, camera: {scene: {shadow: false, reflection: false}}}
  labels: {kind: segmentation, element: camera:sized}
""")
    assert s.check() == []
    assert [p.format("note") for p in s.notes()] == [
        "s.yaml:3:3: note: sensors.plain: this camera renders shadows (of light 'sun') and reflections (in material "
        "'floor'), MuJoCo's default look, which can make a frame many times slower (Menagerie ALOHA's overhead camera "
        "at 640x480: 3.2 s against 0.27 s without them, software EGL); camera: {scene: {shadow: false, reflection: "
        "false}} turns them off, for a different image",
        "s.yaml:4:62: note: sensors.half.camera.scene: this camera renders reflections (in material 'floor'), "
        "MuJoCo's default look, which can make a frame many times slower (Menagerie ALOHA's overhead camera at "
        "640x480: 3.2 s against 0.27 s without them, software EGL); camera: {scene: {reflection: false}} turns them "
        "off, for a different image"]
    path = tmp_path / "s.yaml"
    (tmp_path / "scene.xml").write_text(MODEL)  # a suite's model lies in its folder tree
    path.write_text("model: scene.xml\nsensors:\n  plain: {kind: rgb, element: camera:sized}\n")
    assert main(["validate", str(path)]) == 0
    out = capsys.readouterr().out
    assert "s.yaml:3:3: note: sensors.plain: this camera renders shadows" in out and "1 suite valid" in out
    assert main(["validate", str(path), "--format", "json"]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert [(n["severity"], n["loc"], n["line"]) for n in notes] == [("note", "sensors.plain", 3)]
    assert main(["spec", str(path)]) == 0
    assert "note: sensors.plain: this camera renders shadows" in capsys.readouterr().out
    assert main(["run", str(path), "--steps", "1"]) == 0
    assert "note: sensors.plain: this camera renders shadows" in capsys.readouterr().out


def test_a_model_without_shadows_or_reflections_gets_no_note(tmp_path) -> None:
    plain = tmp_path / "plain.xml"
    plain.write_text(MODEL.replace('castshadow="true"', 'castshadow="false"').replace('reflectance="0.5"', ""))
    s = suite(str(plain), "  c: {kind: rgb, element: camera:sized}\n")
    assert s.check() == [] and s.notes() == []


@pytest.mark.skipif(int(__import__("mujoco").__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
def test_scene_flags_reach_the_batchs_renders(model_path: str) -> None:
    from sensorcfg.batch import BatchEnvironment

    s = suite(model_path, "  c: {kind: rgb, element: camera:sized, camera: {scene: {shadow: false}}}\n")
    single = sensorcfg.Environment(model_path, s, seed=0).reset().observation["c"]
    batch = BatchEnvironment(model_path, s, 2, seed=0).reset().observation["c"]
    np.testing.assert_array_equal(batch[0], single)
    shadowed = sensorcfg.Environment(model_path, suite(model_path, "  c: {kind: rgb, element: camera:sized}\n"),
                                     seed=0).reset().observation["c"]
    assert not np.array_equal(shadowed, single)
