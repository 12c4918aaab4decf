"""Cameras on the Warp engine (`sensorcfg.warp.cameras`, MuJoCo Warp's batch ray tracer) on Warp's CPU device:
the CPU camera's shapes and dtypes, depth and segmentation against OpenGL's (`mujoco.Renderer`, the CPU
camera's own renderer) on the same states, one image per world, the schedule's frames (intervals, delays,
buffers, substeps), and the refusals of what the renderer does not cover."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from cpu_batch import cpu_batch  # noqa: E402
from conftest import MODELS, warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import SuiteError  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.observables.camera import Camera  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.warp.cameras import background_depth, render_substeps  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402

SCENE = str(MODELS / "camera_scene.xml")
W, H = 32, 24
NWORLD = 2
# depth where both renderers see the same geom away from its outline: OpenGL draws spheres and capsules as
# polygons (`vis.quality.numslices`), the ray tracer intersects the exact surface; 1 % covers the facets
DEPTH_RTOL = 1e-2


def cameras(**kwargs) -> dict[str, Camera]:
    out = {mode: Camera("eye", height=H, width=W, mode=mode, **kwargs) for mode in ("rgb", "depth", "segmentation")}
    for obs in out.values():
        obs.enabled = True
    return out


def actions(step: int) -> np.ndarray:
    """World 0 turns the stick one way, world 1 the other (the same at every step: a trajectory does not
    depend on how its steps are grouped in control steps)."""
    return np.array([[1.0], [-1.0]], np.float32)


@pytest.fixture(scope="module")
def run() -> tuple[WarpEnvironment, list[dict[str, np.ndarray]], list[dict[str, np.ndarray]]]:
    """Ten control steps of two worlds: each step's observations and the world states the last frames show."""
    env = WarpEnvironment(SCENE, cameras(), NWORLD, device="cpu", physics_steps_per_control_step=2)
    seen = [{k: v.numpy().copy() for k, v in env.reset().observation.items()}]
    states = []
    for c in range(10):
        step = env.step(actions(c))
        seen.append({k: v.numpy().copy() for k, v in step.observation.items()})
        states.append({f: getattr(env.data, f).numpy().copy()
                       for f in ("qpos", "geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir")})
    return env, seen, states


def opengl(state: dict[str, np.ndarray], w: int, mode: str) -> np.ndarray:
    """The CPU camera's frame of world w's positions (those MuJoCo Warp rendered from)."""
    model = mujoco.MjModel.from_xml_path(SCENE)
    physics = Physics(model)
    data = physics.data
    data.qpos[:] = state["qpos"][w]
    mujoco.mj_forward(model, data)
    for field in ("geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat", "light_xpos", "light_xdir"):
        getattr(data, field).flat[:] = state[field][w].ravel()
    return Camera("eye", height=H, width=W, mode=mode).observation_callable(physics)()


def interior(seg: np.ndarray) -> np.ndarray:
    """Pixels whose four neighbours see the same object (not on an outline)."""
    ids = seg[..., 0]
    out = np.zeros(ids.shape, bool)
    out[1:-1, 1:-1] = ((ids[1:-1, 1:-1] == ids[:-2, 1:-1]) & (ids[1:-1, 1:-1] == ids[2:, 1:-1])
                       & (ids[1:-1, 1:-1] == ids[1:-1, :-2]) & (ids[1:-1, 1:-1] == ids[1:-1, 2:]))
    return out


def test_shapes_and_dtypes_are_the_cpu_cameras(run) -> None:
    env, seen, _ = run
    cpu = cpu_batch(SCENE, cameras, NWORLD, physics_steps_per_control_step=2)
    cpu_spec, cpu_obs = cpu.observation_spec(), cpu.reset().observation
    spec = env.observation_spec()
    for name in ("rgb", "depth", "segmentation"):
        assert spec[name].shape == cpu_spec[name].shape == (NWORLD, 1, H, W, {"rgb": 3, "depth": 1}.get(name, 2))
        assert spec[name].dtype == cpu_spec[name].dtype == cpu_obs[name].dtype
        assert seen[-1][name].shape == cpu_obs[name].shape and seen[-1][name].dtype == cpu_obs[name].dtype
        array = env.step(actions(0)).observation[name]
        assert isinstance(array, wp.array) and array.shape == spec[name].shape[:-1]  # vectors of the channels


def test_depth_and_segmentation_are_opengls_away_from_outlines(run) -> None:
    _, seen, states = run
    model = mujoco.MjModel.from_xml_path(SCENE)
    far = background_depth(model, 0)
    for w in range(NWORLD):
        depth, seg = seen[-1]["depth"][w, 0, ..., 0], seen[-1]["segmentation"][w, 0]
        gl_depth, gl_seg = opengl(states[-1], w, "depth")[..., 0], opengl(states[-1], w, "segmentation")
        inside = interior(gl_seg)
        assert inside.sum() > 0.4 * inside.size
        np.testing.assert_array_equal(seg[inside], gl_seg[inside])
        hit = inside & (gl_seg[..., 0] >= 0)
        np.testing.assert_allclose(depth[hit], gl_depth[hit], rtol=DEPTH_RTOL)
        assert {mujoco.mjtGeom(model.geom_type[g]).name[7:] for g in gl_seg[hit][:, 0]} == {
            "PLANE", "SPHERE", "CAPSULE", "ELLIPSOID", "CYLINDER", "BOX", "MESH"}
        nothing = (gl_seg[..., 0] < 0) & (seg[..., 0] < 0)  # the far plane's value, as the CPU camera's
        assert nothing.any() and (depth[nothing] == far).all() and (gl_depth[nothing] == far).all()
        assert set(np.unique(seg[..., 1])) <= {-1, int(mujoco.mjtObj.mjOBJ_GEOM)}


def test_rgb_is_an_image_of_the_same_scene_in_the_geoms_colours(run) -> None:
    """Not OpenGL's pixels (docs/warp.md): each geom's pixels lean to its own colour."""
    _, seen, _ = run
    model = mujoco.MjModel.from_xml_path(SCENE)
    for w in range(NWORLD):
        rgb, seg = seen[-1]["rgb"][w, 0].astype(float), seen[-1]["segmentation"][w, 0]
        for geom in ("block", "ball", "stick"):
            mine = seg[..., 0] == model.geom(geom).id
            colour = model.geom(geom).rgba[:3]
            assert mine.any() and np.argmax(rgb[mine].mean(axis=0)) == np.argmax(colour), geom


def test_worlds_in_different_states_give_different_images(run) -> None:
    _, seen, states = run
    assert not np.allclose(states[-1]["qpos"][0], states[-1]["qpos"][1])
    for name in ("rgb", "depth", "segmentation"):
        np.testing.assert_array_equal(seen[0][name][0], seen[0][name][1])  # the same reset state
        assert (seen[-1][name][0] != seen[-1][name][1]).any(), name
        assert (seen[-1][name][0] != seen[0][name][0]).any(), name


def frames(env: WarpEnvironment, steps: int, name: str) -> list[np.ndarray]:
    out = [env.reset().observation[name].numpy().copy()]
    for c in range(steps):
        out.append(env.step(actions(c)).observation[name].numpy().copy())
    return out


def test_intervals_delays_buffers_and_substeps_show_the_frames_of_their_steps() -> None:
    # every step's frame (one physics step per control step), against schedules that sample between reads
    every = {"now": Camera("eye", height=H, width=W, mode="depth")}
    every["now"].enabled = True
    truth = frames(WarpEnvironment(SCENE, every, NWORLD, device="cpu", physics_steps_per_control_step=1), 24, "now")
    scheduled = {"late": Camera("eye", height=H, width=W, mode="depth", update_interval=3, delay=2),
                 "window": Camera("eye", height=H, width=W, mode="depth", update_interval=3, buffer_size=2)}
    for obs in scheduled.values():
        obs.enabled = True
    env = WarpEnvironment(SCENE, scheduled, NWORLD, device="cpu", physics_steps_per_control_step=2)
    late, window = frames(env, 12, "late"), frames(env, 12, "window")  # the same trajectory, read every 2 steps
    pad = np.zeros_like(truth[0][:, 0])
    for c in range(13):
        step = 2 * c
        k = (step - 2) // 3
        np.testing.assert_array_equal(late[c][:, 0], truth[3 * k][:, 0] if k >= 0 else pad, err_msg=f"step {step}")
        newest = step // 3
        for b, sample in enumerate((newest - 1, newest)):
            np.testing.assert_array_equal(window[c][:, b], truth[3 * sample][:, 0] if sample >= 0 else pad)
    assert len({frame.tobytes() for frame in truth}) > 10  # the frames do change from step to step


def test_render_substeps_are_those_at_which_some_world_samples() -> None:
    assert render_substeps(np.array([True, False, False]), 2) == [1, 2]  # interval 3, reads every 2 steps
    assert render_substeps(np.array([True, False, False, False]), 2) == [2]  # interval 4: at reads only
    assert render_substeps(np.array([True]), 3) == [1, 2, 3]
    assert render_substeps(np.array([True, False, False, False, False, False]), 3) == [3]


# -- refusals ---------------------------------------------------------------------------------------

SUITE = """model: scene.xml
sensors:
  eye:
    kind: depth
    element: camera:eye
    camera: {width: 32, height: 24, scene: {shadow: false, fog: true}}
    noise: [{type: gaussian, std: 0.01}]
  fine: {kind: rgb, element: camera:eye, camera: {width: 32, height: 24, scene: {reflection: false}}}
"""


def suite_at(tmp_path: Path, model: str) -> sensorcfg.Suite:
    (tmp_path / "scene.xml").write_text(model)
    (tmp_path / "s.yaml").write_text(SUITE)
    return sensorcfg.load(tmp_path / "s.yaml")


def test_a_noisy_camera_and_a_scene_flag_the_renderer_does_not_follow_are_refused_at_their_lines(
        tmp_path: Path) -> None:
    suite = suite_at(tmp_path, Path(SCENE).read_text())
    reported = suite.check(warp=True)
    assert [(p.line, p.loc) for p in reported] == [(6, "sensors.eye.camera.scene.fog"), (7, "sensors.eye.noise")]
    assert "scene flag 'fog' is not followed by MuJoCo Warp's renderer" in reported[0].message
    with pytest.raises(SuiteError) as refused:
        WarpEnvironment(None, suite, NWORLD, device="cpu")
    assert [(p.loc, p.message) for p in refused.value.problems] == [(p.loc, p.message) for p in reported]


@pytest.mark.parametrize("change, what", [
    ('<site name="mark" pos="0 0 1" size=".02"/>', "visible sites (mark;"),
    ('<geom name="glass" type="box" pos="0 .5 .1" size=".1 .1 .1" rgba="1 1 1 .5"/>', "translucent geoms (glass;"),
    ('<geom name="bumps" type="hfield" hfield="bumps" pos=".3 .2 .01" rgba=".3 .6 .3 1"/>', "height fields (bumps;"),
])
def test_what_the_cpu_camera_draws_and_the_renderer_does_not_is_refused_at_the_cameras_element(
        tmp_path: Path, change: str, what: str) -> None:
    model = Path(SCENE).read_text().replace('<geom name="floor"', change + '\n    <geom name="floor"').replace(
        "</asset>", '<hfield name="bumps" nrow="3" ncol="3" size=".15 .15 .04 .01"/></asset>')
    (tmp_path / "scene.xml").write_text(model)
    (tmp_path / "s.yaml").write_text(SUITE.replace(", fog: true", "").replace(
        "    noise: [{type: gaussian, std: 0.01}]\n", ""))
    reported = sensorcfg.load(tmp_path / "s.yaml").check(warp=True)
    assert [(p.line, p.loc) for p in reported] == [(5, "sensors.eye.element"), (7, "sensors.fine.element")]
    assert what in reported[0].message and "MuJoCo Warp's renderer does not" in reported[0].message
    # invisible ones are not drawn by either: a site in group 3, a geom of alpha 0
    hidden = model.replace('size=".02"/>', 'size=".02" group="3"/>').replace('rgba="1 1 1 .5"', 'rgba="1 1 1 0"') \
        .replace('rgba=".3 .6 .3 1"', 'rgba=".3 .6 .3 1" group="3"')
    (tmp_path / "scene.xml").write_text(hidden)
    assert sensorcfg.load(tmp_path / "s.yaml").check(warp=True) == []


def test_noise_on_a_camera_is_refused_by_the_environment() -> None:
    obs = cameras()
    obs["depth"].noise = build_noise([{"type": "gaussian", "std": 0.01}], (H, W, 1), np.float32, 0.01)
    with pytest.raises(SuiteError, match=r"sensors\.depth\.noise: noise on a camera image"):
        WarpEnvironment(SCENE, obs, NWORLD, device="cpu")


def test_a_restarted_world_shows_its_reset_frame_and_the_others_go_on() -> None:
    obs = {"depth": Camera("eye", height=H, width=W, mode="depth")}
    obs["depth"].enabled = True
    env = WarpEnvironment(SCENE, obs, NWORLD, device="cpu", physics_steps_per_control_step=2)
    seen = frames(env, 6, "depth")
    again = env.reset([1]).observation["depth"].numpy()
    np.testing.assert_array_equal(again[1], seen[0][1])  # world 1 from its reset state again
    np.testing.assert_array_equal(again[0], seen[-1][0])  # world 0's read is unchanged
    assert (seen[-1][1] != seen[0][1]).any()
    moved = env.step(actions(0)).observation["depth"].numpy()
    assert (moved[1] != seen[0][1]).any() and (moved[0] != seen[-1][0]).any()


def test_a_camera_given_by_its_sensor_needs_an_image_of_the_sensors_aspect(tmp_path: Path) -> None:
    sensor = Path(SCENE).read_text().replace('fovy="40"', 'sensorsize=".006 .004" focal=".004 .004"')
    reported = suite_at(tmp_path, sensor).check(warp=True)
    assert [p.loc for p in reported] == ["sensors.eye.element", "sensors.eye.camera.scene.fog", "sensors.eye.noise",
                                         "sensors.fine.element"]
    assert "its image 32 x 24 pixels, another aspect" in reported[0].message
    (tmp_path / "scene.xml").write_text(sensor.replace('sensorsize=".006 .004"', 'sensorsize=".008 .006"'))
    assert [p.loc for p in sensorcfg.load(tmp_path / "s.yaml").check(warp=True)] == [
        "sensors.eye.camera.scene.fog", "sensors.eye.noise"]


def test_the_sites_a_suite_adds_are_no_refusal_and_change_no_frame() -> None:
    """A body's gyro and `gravity` add sites (in the camera's view) that neither renderer draws: the engine
    takes the camera, and its frames are those without them."""
    model = str(MODELS / "imu_scene.xml")
    cams = "".join(f"  {m}: {{kind: {m}, element: camera:eye, camera: {{width: {W}, height: {H}}}}}\n"
                   for m in ("rgb", "depth", "segmentation"))
    imu = "  gyro: {kind: gyro, element: body:base}\n  gravity: {kind: gravity, element: body:base}\n"
    seen = []
    for sensors in (cams, cams + imu):
        env = WarpEnvironment(model, sensorcfg.loads(f"sensors:\n{sensors}"), NWORLD, device="cpu")
        seen.append([{k: v.numpy().copy() for k, v in env.reset().observation.items()}])
        seen[-1] += [{k: v.numpy().copy() for k, v in env.step(np.zeros((NWORLD, 0), np.float32)).observation.items()}]
    for plain, added in zip(*seen):
        for mode in ("rgb", "depth", "segmentation"):
            np.testing.assert_array_equal(added[mode], plain[mode], err_msg=mode)
