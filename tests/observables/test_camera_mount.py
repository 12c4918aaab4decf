"""`cameras:` in a suite: cameras added to a model without one, where they are meant to be, by every path
that compiles the suite's model, and refused at their line when they cannot be added."""

from __future__ import annotations

import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets

from conftest import MODELS

TERRAIN = str(MODELS / "terrain.xml")
ROBOT = str(assets.path("robot.xml"))
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4

SUITE = """\
cameras:
  head: {element: body:base, pos: [0.2, 0, 0.05], xyaxes: [0, -1, 0, 0, 0, 1], fovy: 60, resolution: [64, 48]}
  on_site: {element: site:imu, pos: [0.01, 0.02, 0.1], quat: [0.9, 0.1, 0.3, 0.2]}
  fixed: {element: body:world, pos: [0, -2, 1]}
sensors:
  img: {kind: rgb, element: camera:head}
  depth: {kind: depth, element: camera:on_site, camera: {width: 16, height: 12}}
"""

HAND_WRITTEN = '<camera name="head" pos=".2 0 .05" xyaxes="0 -1 0 0 0 1" fovy="60" resolution="64 48"/>'


def _posed(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:7] = [0.3, -0.2, 0.5, 0.9, 0.2, -0.3, 0.1]
    data.qpos[3:7] /= np.linalg.norm(data.qpos[3:7])
    mujoco.mj_forward(model, data)
    return data


def test_a_camera_on_a_body_is_the_one_written_in_the_file(tmp_path: Path) -> None:
    text = Path(TERRAIN).read_text()
    written = tmp_path / "written.xml"
    written.write_text(text.replace('<site name="imu"', HAND_WRITTEN + '\n      <site name="imu"'))
    reference = mujoco.MjModel.from_xml_path(str(written))
    model = sensorcfg.loads(SUITE).compile(TERRAIN)
    mine, theirs = _posed(model), _posed(reference)
    a, b = model.camera("head").id, reference.camera("head").id
    np.testing.assert_allclose(mine.cam_xpos[a], theirs.cam_xpos[b], rtol=0, atol=1e-12)
    np.testing.assert_allclose(mine.cam_xmat[a], theirs.cam_xmat[b], rtol=0, atol=1e-12)
    assert model.cam_fovy[a] == 60 and list(model.cam_resolution[a]) == [64, 48]


def test_a_camera_on_a_site_moves_with_the_site() -> None:
    model = sensorcfg.loads(SUITE).compile(TERRAIN)
    data = _posed(model)
    site, camera = model.site("imu").id, model.camera("on_site").id
    quat = np.array([0.9, 0.1, 0.3, 0.2]) / np.linalg.norm([0.9, 0.1, 0.3, 0.2])
    turn = np.zeros(9)
    mujoco.mju_quat2Mat(turn, quat)
    rotation = data.site_xmat[site].reshape(3, 3)
    np.testing.assert_allclose(data.cam_xpos[camera], data.site_xpos[site] + rotation @ [0.01, 0.02, 0.1],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(data.cam_xmat[camera].reshape(3, 3), rotation @ turn.reshape(3, 3), rtol=0, atol=1e-12)
    np.testing.assert_allclose(data.cam_xpos[model.camera("fixed").id], [0, -2, 1], rtol=0, atol=0)


def test_every_path_that_compiles_the_suite_sees_its_cameras() -> None:
    suite = sensorcfg.loads(SUITE)
    assert suite.check(TERRAIN) == []
    assert set(suite.build(TERRAIN)) == {"img", "depth"}
    assert set(suite.build(mujoco.MjSpec.from_file(TERRAIN))) == {"img", "depth"}
    assert set(suite.build(suite.compile(TERRAIN))) == {"img", "depth"}  # an MjModel that carries them
    env = sensorcfg.Environment(TERRAIN, suite)
    obs = env.reset().observation
    assert obs["img"].shape == (1, 48, 64, 3) and obs["img"].any()  # the camera's own resolution
    assert obs["depth"].shape == (1, 12, 16, 1)
    if MUJOCO4:
        from sensorcfg.batch import BatchEnvironment

        batch = BatchEnvironment(TERRAIN, suite, 2, seed=0)
        np.testing.assert_array_equal(batch.reset().observation["img"][0], obs["img"])


def test_the_cli_validates_runs_and_specs_a_suite_with_cameras(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                                               ) -> None:
    from sensorcfg.cli import main

    shutil.copy(TERRAIN, tmp_path / "terrain.xml")  # a suite's model lies in its folder tree
    (tmp_path / "s.yaml").write_text(f"model: terrain.xml\n{SUITE}")
    assert main(["validate", str(tmp_path / "s.yaml")]) == 0
    assert main(["spec", str(tmp_path / "s.yaml")]) == 0
    assert "(1, 48, 64, 3)" in capsys.readouterr().out
    assert main(["run", str(tmp_path / "s.yaml"), "--steps", "2"]) == 0


@pytest.mark.parametrize("cameras, expected", [
    pytest.param("wrist: {element: body:base}",
                 "2:3: error: cameras.wrist: the model already has a camera named 'wrist'; give the suite's camera "
                 "another name, or read the model's own as 'camera:wrist' without adding one", id="name-taken"),
    pytest.param("c: {element: body:bsae}",
                 "2:16: error: cameras.c.element: the model has no body named 'bsae' (did you mean 'base'?)",
                 id="no-body"),
    pytest.param("c: {element: geom:floor}",
                 "2:16: error: cameras.c.element: a camera is mounted in one frame, 'body:<name>' or 'site:<name>'; "
                 "got 'geom:floor'", id="not-a-frame"),
    pytest.param("c: {element: 'body:*'}",
                 "2:16: error: cameras.c.element: a camera is mounted in one frame, 'body:<name>' or 'site:<name>'; "
                 "got 'body:*'", id="many"),
])
def test_a_camera_that_cannot_be_added_is_a_problem_at_its_line(cameras: str, expected: str) -> None:
    suite = sensorcfg.loads(f"cameras:\n  {cameras}\nsensors: {{}}\n", file="f.yaml")
    assert [p.format() for p in suite.check(ROBOT)] == ["f.yaml:" + expected]
    with pytest.raises(sensorcfg.SuiteError):
        sensorcfg.Environment(ROBOT, suite)


@pytest.mark.parametrize("camera, expected", [
    pytest.param("{element: body:base, quat: [1, 0, 0, 0], xyaxes: [1, 0, 0, 0, 1, 0]}",
                 "give its orientation once: `quat` or `xyaxes`, not both", id="two-orientations"),
    pytest.param("{element: body:base, xyaxes: [1, 0, 0, 2, 0, 0]}",
                 "cameras.c.xyaxes: xyaxes [1.0, 0.0, 0.0, 2.0, 0.0, 0.0] has a zero or parallel x and y axis",
                 id="parallel"),
    pytest.param("{element: body:base, quat: [0, 0, 0, 0]}", "cameras.c.quat: quat (0, 0, 0, 0) is no rotation",
                 id="zero-quat"),
    pytest.param("{element: body:base, fovy: 180}", "cameras.c.fovy: expected a value < 180", id="fovy"),
    pytest.param("{element: body:base, pos: [0, .nan, 0]}", "cameras.c.pos.1", id="nan"),
])
def test_a_malformed_camera_is_a_problem_at_its_line(camera: str, expected: str) -> None:
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(f"cameras:\n  c: {camera}\nsensors: {{}}\n", file="f.yaml")
    assert len(info.value.problems) == 1 and expected in str(info.value), str(info.value)


@pytest.mark.parametrize("bad", ["c: {element: body:base, quat: [0, 0, 0, 0]}", "c.x: {element: body:base}"],
                         ids=["malformed", "bad-name"])
def test_a_malformed_camera_is_its_only_problem(bad: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Found by review: a schema mistake in one camera dropped every camera of the suite, so validate also told
    each sensor that read one (a valid one too) that the model has no camera of that name."""
    from sensorcfg.cli import main

    name = bad.partition(":")[0]
    shutil.copy(ROBOT, tmp_path / "robot.xml")
    (tmp_path / "s.yaml").write_text(
        f"model: robot.xml\ncameras:\n  {bad}\n  good: {{element: body:base}}\nsensors:\n"
        f"  a: {{kind: rgb, element: 'camera:{name}'}}\n  b: {{kind: rgb, element: camera:good, camera: {{width: 9999}}}}\n")
    assert main(["validate", str(tmp_path / "s.yaml")]) == 1
    errors = [line for line in capsys.readouterr().out.splitlines() if ": error: " in line]
    assert [line.split(": ")[2] for line in errors] == [f"cameras.{name}" + (".quat" if "quat" in bad else ""),
                                                        "sensors.b.camera.width"], errors
    assert "offscreen buffer" in errors[1]  # the valid camera is mounted: its sensor is judged
    assert "quat" in bad or "a camera name starts with" in errors[0]  # not "a sensor name"


_SCENE_TYPO = ("8:70: error: sensors.scene.camera.scene.shadw: unknown scene flag 'shadw' (did you mean 'shadow'?); "
               "flags: ...")


@pytest.mark.parametrize("camera, expected", [
    pytest.param("{element: 'body:bsae', resolution: [64, 48]}",
                 ["3:24: error: cameras.wrist_cam.element: the model has no body named 'bsae' (did you mean 'base'?)",
                  _SCENE_TYPO], id="misspelt-mount"),
    pytest.param("{element: 'body:*'}",
                 ["3:24: error: cameras.wrist_cam.element: a camera is mounted in one frame, 'body:<name>' or "
                  "'site:<name>'; got 'body:*'", _SCENE_TYPO], id="not-one-frame"),
    pytest.param("{element: 'body:base', resolution: [0, 48]}",  # (the sensors reading it are not judged)
                 ["3:50: error: cameras.wrist_cam.resolution.0: expected a value >= 1; got 0"], id="bad-resolution"),
])
def test_a_camera_with_a_mistake_still_names_a_camera_for_its_sensors(camera: str, expected: list[str],
                                                                      tmp_path: Path) -> None:
    """Issue 30: a misspelt mount hid a second typo, in a sensor's camera name; with a bad `resolution` the
    sensor's error read "its cameras are: (none)". Both are reported, and the camera with a mistake is still
    one the suite defines: the sensors reading it are judged on their own mistakes only."""
    from sensorcfg.cli import main

    shutil.copy(TERRAIN, tmp_path / "terrain.xml")  # (a model without cameras of its own)
    (tmp_path / "s.yaml").write_text(
        f"model: terrain.xml\ncameras:\n  wrist_cam: {camera}\nsensors:\n"
        "  typo: {kind: rgb, element: 'camera:wrist_cm'}\n  reads: {kind: rgb, element: 'camera:wrist_cam'}\n"
        "  other: {kind: qpos, element: 'joint:*'}\n"
        "  scene: {kind: depth, element: 'camera:wrist_cam', camera: {scene: {shadw: false}}}\n")
    expected = [expected[0], "5:30: error: sensors.typo.element: the model has no camera named 'wrist_cm' (did you "
                "mean 'wrist_cam'?)", *expected[1:]]
    found = check(tmp_path / "s.yaml")
    assert len(found) == len(expected), found
    for got, want in zip(found, expected):
        assert got == want or (want.endswith(" ...") and got.startswith(want[:-4])), got
    assert main(["validate", str(tmp_path / "s.yaml")]) == 1
    if "resolution: [0" not in camera:
        with pytest.raises(sensorcfg.SuiteError) as info:
            sensorcfg.load(tmp_path / "s.yaml").compile()
        assert [p.loc for p in info.value.problems] == ["cameras.wrist_cam.element"]


def check(path: Path) -> list[str]:
    """Every problem `validate` finds in the suite at `path`, as 'line:col: error: ...'."""
    from sensorcfg.cli.validate import check_file

    return [p.format().removeprefix(f"{path}:") for p in check_file(path, None, [], False).problems]


def test_a_camera_larger_than_the_models_offscreen_buffer_renders_at_its_resolution() -> None:
    """Found by review: a suite camera with `resolution: [1280, 720]` on a model whose offscreen buffer is
    640x480 was refused at the sensor, with a hint to edit the robot file that `cameras:` exists to spare."""
    suite = sensorcfg.loads("cameras:\n  big: {element: body:base, resolution: [1280, 720]}\n"
                            "sensors:\n  img: {kind: depth, element: camera:big}\n", file="f.yaml")
    assert suite.check(ROBOT) == []
    model = suite.compile(ROBOT)
    assert (model.vis.global_.offwidth, model.vis.global_.offheight) == (1280, 720)
    assert sensorcfg.Environment(ROBOT, suite).observation_spec()["img"].shape == (1, 720, 1280, 1)


@pytest.mark.parametrize("sensor", ["{kind: rgb, element: 'camera:#1'}", "{kind: xpos, element: [camera:wrist, 'camera:#0']}",
                                    "{kind: framepos, element: site:imu, frame: 'camera:#1'}"],
                         ids=["element", "list-entry", "frame"])
def test_a_camera_id_in_a_suite_that_adds_cameras_is_a_problem_at_its_line(sensor: str) -> None:
    """Found by review: MuJoCo numbers the suite's cameras with the model's own by their place in the body
    tree, so `camera:#1` (the robot's wrist camera) read a camera a child suite mounted on the world."""
    cameras = "cameras:\n  front: {element: 'body:#0', pos: [0, -1, 0.3]}\n"
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(f"{cameras}sensors:\n  s: {sensor}\n", file="f.yaml")
    problems = info.value.problems
    assert len(problems) == 1 and problems[0].line == 4 and "selects a camera by id" in problems[0].message, problems
    mounted = sensorcfg.loads(f"{cameras}sensors: {{}}\n").compile(ROBOT)
    assert mujoco.MjModel.from_xml_path(ROBOT).camera(1).name != mounted.camera(1).name  # why


def test_an_mjmodel_without_the_cameras_is_refused_at_the_camera() -> None:
    suite = sensorcfg.loads("cameras:\n  head: {element: body:base}\nsensors:\n  img: {kind: rgb, element: "
                            "camera:head}\n", file="f.yaml")
    problems = suite.check(mujoco.MjModel.from_xml_path(TERRAIN))
    assert [p.format() for p in problems] == [
        "f.yaml:2:3: error: cameras.head: the suite adds camera 'head' when it compiles its model, and this MjModel "
        "was compiled without it: pass the model's file or MjSpec, or the MjModel Suite.compile returns"]
