"""What sensorcfg adds to a model (sites, sensors) draws nothing and is seen by no check about the user's model.

A body's IMU kinds and `gravity` add sites, a rangefinder or geomfromto kind adds a sensor whose ray MuJoCo's
scene draws, a batch adds on-demand enablers and relays: with all of them, a CPU camera's rgb, depth and
segmentation frames are those of the model as written, to the bit; the Warp engine's camera check finds
nothing to refuse in them; and every element added, whatever adds it, is named as sensorcfg's, is a site or a
sensor, and a site is in a group no viewer shows by default with alpha 0 (so a viewer showing every group
does not draw it either).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS
from sensorcfg.kinds import ELEMENT_TYPES, ON_DEMAND
from sensorcfg.native import NATIVE
from sensorcfg.observables import Camera
from sensorcfg.physics import Physics
from sensorcfg.selection import added_by_sensorcfg, select
from sensorcfg.warp.camera_support import model_refusal

SCENE = str(MODELS / "imu_scene.xml")
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4
CAMERAS = "".join(f"  {mode}: {{kind: {mode}, element: camera:eye, camera: {{width: 96, height: 96}}}}\n"
                  for mode in ("rgb", "depth", "segmentation"))
# every kind of sensor that adds something the CPU camera drew, each where the camera sees what it added
ADDING = """\
  gyro: {kind: gyro, element: body:base}
  gravity: {kind: gravity, element: body:base}
  range: {kind: rangefinder, element: body:probe}
  fromto: {kind: geomfromto, element: geom:probe, with: geom:base}
"""


def _suite(sensors: str) -> sensorcfg.Suite:
    return sensorcfg.loads(f"options: {{strip_singleton_buffer_dim: true}}\nsensors:\n{sensors}", file="s.yaml")


def _frames(sensors: str, steps: int = 3) -> list[dict[str, np.ndarray]]:
    env = sensorcfg.Environment(SCENE, _suite(sensors), seed=0)
    out = [env.reset().observation]
    out += [env.step(np.zeros(0)).observation for _ in range(steps)]
    return [{mode: frame[mode] for mode in ("rgb", "depth", "segmentation")} for frame in out]


def test_a_cameras_frames_are_the_same_with_the_sensors_that_add_to_the_model() -> None:
    plain, added = _frames(CAMERAS), _frames(CAMERAS + ADDING)
    model = _suite(CAMERAS + ADDING).compile(SCENE)
    assert model.nsite == 3 and model.nsensor == 4  # what the suite added, all in the camera's view
    for step, (a, b) in enumerate(zip(plain, added)):
        for mode in a:
            np.testing.assert_array_equal(b[mode], a[mode], err_msg=f"{mode} at step {step}")


def test_the_warp_cameras_check_sees_nothing_sensorcfg_added() -> None:
    suite = _suite(CAMERAS.splitlines(keepends=True)[0] + ADDING)
    assert model_refusal(suite.compile(SCENE)) is None
    assert suite.check(SCENE, warp=True) == []
    # the model's own rangefinder is still a refusal: the CPU camera draws its ray and MuJoCo Warp's renderer not
    spec = mujoco.MjSpec.from_file(SCENE)
    spec.body("probe").add_site(name="down", group=3)
    spec.add_sensor(name="own", type=mujoco.mjtSensor.mjSENS_RANGEFINDER, objtype=mujoco.mjtObj.mjOBJ_SITE,
                    objname="down", intprm=[1, 0, 0])
    problems = suite.check(spec, warp=True)
    assert [p.loc for p in problems] == ["sensors.rgb.element"]
    assert "the model has rangefinder sensors (the CPU camera draws their rays)" in problems[0].message
    assert "sensorcfg:" not in problems[0].message


def test_the_warp_cameras_check_names_an_unnamed_site_as_a_selector_does() -> None:
    """The file's only site, unnamed, is `site:#0`, though the sites the suite adds come first in the compiled
    model."""
    spec = mujoco.MjSpec.from_file(SCENE)
    spec.body("probe").add_site(pos=[0, 0, -0.1], size=[0.02, 0, 0])
    model = _suite(CAMERAS.splitlines(keepends=True)[0] + ADDING.split("  range:")[0]).compile(spec)
    assert [model.site(i).name for i in range(model.nsite)] == ["sensorcfg:gravity:0", "sensorcfg:gyro:0", ""]
    assert "the model has visible sites (#0; give them" in (model_refusal(model) or "")
    assert select(model, "site:#0").ids == (2,)


# --- every element sensorcfg adds, whatever adds it --------------------------------------------------------

def _every_adding_kind() -> str:
    """A suite with every MuJoCo sensor kind (body kinds on a body too), and the on-demand fields a batch
    adds sensors for, on tests/observables/test_native.py's model."""
    from test_native import HAND_WRITTEN

    rows = [row for row, _ in HAND_WRITTEN]
    rows += ["{kind: %s, element: body:base%s}" % (row.kind, ", with: camera:cam" if row.with_required else "")
             for row in NATIVE.values() if row.body_site]
    rows += [f"{{kind: {kind}, element: body:front}}" for kind in sorted(ON_DEMAND)]
    return "".join(f"  s{i}: {row}\n" for i, row in enumerate(rows))


def _relayed(tmp_path: Path) -> tuple[mujoco.MjModel, mujoco.MjModel]:
    """(the model as written, the model a batch compiled with relays) of tests/batch's relay test."""
    from test_batch_relay import MODEL, relay_sensors, suite

    from sensorcfg.batch import BatchEnvironment

    path = tmp_path / "relayed.xml"
    path.write_text(MODEL.format(integrator="Euler"))
    env = BatchEnvironment(str(path), suite(str(path)), 2, physics_steps_per_control_step=3, seed=0)
    assert relay_sensors(env._model)
    return mujoco.MjModel.from_xml_path(str(path)), env._model


def _added(plain: mujoco.MjModel, model: mujoco.MjModel) -> dict[str, list[int]]:
    """The ids of the elements of each type `model` has beyond `plain`, each checked to be named as sensorcfg's."""
    out = {}
    for type_name, et in ELEMENT_TYPES.items():
        count = int(getattr(model, et.count, 0))
        ids = [i for i in range(count) if added_by_sensorcfg(mujoco.mj_id2name(model, et.obj, i) or "")]
        assert count - int(getattr(plain, et.count, 0)) == len(ids), f"an unnamed {type_name} was added"
        if ids:
            out[type_name] = ids
    return out


def _assert_invisible(plain: mujoco.MjModel, model: mujoco.MjModel) -> dict[str, list[int]]:
    added = _added(plain, model)
    # a new type of element must be made invisible as sites are, and checked here
    assert set(added) <= {"site", "sensor"}, f"sensorcfg added {sorted(added)}"
    for i in added.get("site", []):
        name = model.site(i).name
        assert model.site_group[i] >= 3, f"{name} is in group {model.site_group[i]}, which viewers show by default"
        assert model.site_rgba[i][3] == 0 and model.site_matid[i] == -1, f"{name} has a visible colour"
    return added


def _every(tmp_path: Path) -> tuple[mujoco.MjModel, mujoco.MjModel]:
    """(test_native.py's model as written, compiled for a batch with every adding kind)."""
    from test_native import _model_text

    path = tmp_path / "every.xml"
    path.write_text(_model_text())
    return mujoco.MjModel.from_xml_path(str(path)), _suite(_every_adding_kind()).compile(str(path), batch=True)


def test_every_element_sensorcfg_adds_is_an_invisible_site_or_a_sensor(tmp_path: Path) -> None:
    plain, model = _every(tmp_path)
    added = _assert_invisible(plain, model)
    sites = [model.site(i).name for i in added["site"]]
    assert len(sites) == sum(row.body_site for row in NATIVE.values()) + 2  # the body kinds', gravity's, a batch's
    assert "sensorcfg:on-demand:flg_rnepost" in sites
    if MUJOCO4:  # (mujoco.batch)
        assert _assert_invisible(*_relayed(tmp_path)).keys() == {"sensor"}


def _every_group() -> mujoco.MjvOption:
    option = mujoco.MjvOption()
    for group in ("geomgroup", "sitegroup", "jointgroup", "tendongroup", "actuatorgroup", "flexgroup", "skingroup"):
        getattr(option, group)[:] = 1
    return option


def _render(model: mujoco.MjModel, renderer: str, mode: str) -> np.ndarray:
    """A frame of camera `eye` after a few steps, by sensorcfg's camera or by MuJoCo's own Renderer (a user's
    viewer), with every element group shown."""
    physics = Physics(model)
    for _ in range(3):
        physics.step()
    if renderer == "sensorcfg":
        return Camera("eye", 96, 96, mode=mode, scene_option=_every_group()).observation_callable(physics)()
    with mujoco.Renderer(model, 96, 96) as mine:
        if mode == "depth":
            mine.enable_depth_rendering()
        elif mode == "segmentation":
            mine.enable_segmentation_rendering()
        mine.update_scene(physics.data, camera="eye", scene_option=_every_group())
        return mine.render()


# MuJoCo's own renderer draws the rays of the sensors it is given (mjVIS_RANGEFINDER): sensorcfg's camera leaves
# out those of the sensors sensorcfg adds, a user's viewer shows them; the sites are invisible to both
@pytest.mark.parametrize("renderer, sensors", [pytest.param("sensorcfg", ADDING, id="sensorcfg"),
                                               pytest.param("mujoco", ADDING.split("  range:")[0], id="mujoco")])
@pytest.mark.parametrize("mode", ["rgb", "depth", "segmentation"])
def test_a_camera_showing_every_group_sees_none_of_it(renderer: str, sensors: str, mode: str) -> None:
    """With every element group shown (sensorcfg's sites are in group 5), and a batch's on-demand enabler (a
    site at the world's origin) too."""
    plain = mujoco.MjModel.from_xml_path(SCENE)
    model = _suite(sensors + "\n  acc: {kind: cacc, element: body:base}\n").compile(SCENE, batch=True)
    assert model.nsite > plain.nsite
    np.testing.assert_array_equal(_render(model, renderer, mode), _render(plain, renderer, mode))
