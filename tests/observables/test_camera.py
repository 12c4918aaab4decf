"""Camera observables on the bundled robot: specs, images that show something, shared renderers, EGL."""

from __future__ import annotations

import os
import subprocess
import sys
from typing import Any

import mujoco
import numpy as np
import pytest
from dm_env import specs

import sensorcfg
from sensorcfg import assets

H, W = 48, 64


@pytest.fixture(scope="module")
def robot() -> sensorcfg.Physics:
    physics = sensorcfg.Physics.from_xml_path(str(assets.path("robot.xml")))
    physics.data.qvel[:] = 0.5
    physics.step(10)
    physics.forward()
    return physics


@pytest.mark.parametrize("mode,channels,dtype,low,high", [
    pytest.param("rgb", 3, np.uint8, 0, 255, id="rgb"),
    pytest.param("depth", 1, np.float32, 0.0, np.inf, id="depth"),
    pytest.param("segmentation", 2, np.int32, -1, np.iinfo(np.int32).max, id="segmentation"),
])
@pytest.mark.parametrize("camera", ["overview", "wrist"])
def test_image_spec_and_content(robot: sensorcfg.Physics, camera: str, mode: str, channels: int, dtype: type,
                                low: float, high: float) -> None:
    observable = sensorcfg.Camera(camera, height=H, width=W, mode=mode)
    spec = observable.array_spec
    assert isinstance(spec, specs.BoundedArray)
    assert (spec.shape, spec.dtype) == ((H, W, channels), np.dtype(dtype))
    assert (spec.minimum, spec.maximum) == (low, high)
    image = observable(robot)
    assert image.shape == (H, W, channels) and image.dtype == dtype
    spec.validate(image)
    pixels = image.reshape(-1, channels)
    assert len(np.unique(pixels, axis=0)) > 2, f"{camera} {mode} image is (nearly) uniform"
    if mode == "segmentation":
        geom_ids = pixels[pixels[:, 1] == int(mujoco.mjtObj.mjOBJ_GEOM), 0]
        assert geom_ids.size and geom_ids.max() < robot.model.ngeom  # (id, type) channels, as mujoco gives them


def test_rgb_shows_the_robot(robot: sensorcfg.Physics) -> None:
    """The robot's orange links appear in the overview image: the scene is rendered, not cleared."""
    image = sensorcfg.Camera("camera:overview", height=H, width=W)(robot).astype(int)
    orange = (image[..., 0] > 150) & (image[..., 0] - image[..., 2] > 60)
    assert orange.sum() > 5


def test_modes_share_one_renderer_without_leaking_state(robot: sensorcfg.Physics,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    from sensorcfg.observables import camera as camera_module

    camera_module.close_renderers()
    made = []
    real = mujoco.Renderer

    def counting(model: mujoco.MjModel, height: int, width: int) -> mujoco.Renderer:
        made.append((id(model), width, height))
        return real(model, height=height, width=width)

    monkeypatch.setattr(mujoco, "Renderer", counting)
    rgb = sensorcfg.Camera("overview", H, W).observation_callable(robot)
    depth = sensorcfg.Camera("wrist", H, W, mode="depth").observation_callable(robot)
    seg = sensorcfg.Camera("overview", H, W, mode="segmentation").observation_callable(robot)
    other_size = sensorcfg.Camera("overview", 32, 40).observation_callable(robot)
    first = rgb()
    assert depth().dtype == np.float32 and seg().dtype == np.int32
    np.testing.assert_array_equal(rgb(), first)  # depth / segmentation modes were switched back off
    assert other_size().shape == (32, 40, 3)
    assert sorted(made) == sorted([(id(robot.model), W, H), (id(robot.model), 40, 32)])
    other_model = sensorcfg.Physics.from_xml_path(str(assets.path("robot.xml")))
    sensorcfg.Camera("overview", H, W).observation_callable(other_model)
    assert len(made) == 3  # a renderer per (model, width, height)


def test_camera_in_the_updater_renders_once_per_control_step(robot: sensorcfg.Physics) -> None:
    camera = sensorcfg.Camera("wrist", H, W, update_interval=1, buffer_size=1)
    camera.enabled = True
    updater = sensorcfg.Updater({"wrist": camera}, physics_steps_per_control_step=10,
                                strip_singleton_buffer_dim=True)
    updater.reset(robot, np.random.RandomState(0))
    direct = sensorcfg.Camera("wrist", H, W).observation_callable(robot)
    for _ in range(5):
        updater.prepare_for_next_control_step()
        for _ in range(10):
            robot.step()
            updater.update()
        np.testing.assert_array_equal(updater.get_observation()["wrist"], direct())
    assert updater.samples_taken() == {"wrist": 1 + 5}
    spec = updater.observation_spec()["wrist"]
    assert isinstance(spec, specs.BoundedArray) and spec.shape == (H, W, 3) and spec.name == "wrist"


def test_bad_camera_input(robot: sensorcfg.Physics) -> None:
    with pytest.raises(sensorcfg.SuiteError, match=r"the model has no camera named 'wirst' \(did you mean 'wrist'\?\)"):
        sensorcfg.Camera("wirst", H, W)(robot)
    with pytest.raises(sensorcfg.SuiteError, match=r"unknown camera mode 'dept' \(did you mean 'depth'\?\)"):
        sensorcfg.Camera("wrist", mode="dept")
    with pytest.raises(sensorcfg.SuiteError, match=r"camera 'wrist': height must be a positive integer, got 0"):
        sensorcfg.Camera("wrist", height=0)
    with pytest.raises(sensorcfg.SuiteError, match=r"exceeds the model's offscreen buffer \(640x480\)"):
        sensorcfg.Camera("wrist", height=481, width=64)(robot)


def test_egl_is_chosen_without_a_display() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY",
                                                            "PYOPENGL_PLATFORM")}
    script = (
        "import os, sensorcfg\n"
        "from sensorcfg import assets\n"
        "from sensorcfg import _gl\n"
        "from sensorcfg.observables import camera\n"
        "assert 'MUJOCO_GL' not in os.environ, os.environ.get('MUJOCO_GL')  # the import changes no setting\n"
        "p = sensorcfg.Physics.from_xml_path(str(assets.path('robot.xml')))\n"
        "p.forward()\n"
        "image = sensorcfg.Camera('overview', 24, 32)(p)\n"
        "assert image.shape == (24, 32, 3) and image.max() > 0\n"
        "(renderer,) = camera._RENDERERS[p.model].values()\n"
        "print('ok', _gl._kind(type(renderer._gl_context)), 'MUJOCO_GL' in os.environ)\n"
    )
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok egl False"  # rendered with EGL; MUJOCO_GL is still unset


def test_egl_even_when_mujoco_was_imported_first() -> None:
    """mujoco picks its GL backend at import; imported before sensorcfg it picked GLFW, which aborts the
    process on a headless machine. The camera renders with EGL anyway."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY",
                                                            "PYOPENGL_PLATFORM")}
    script = (
        "import mujoco\n"
        "import sensorcfg\n"
        "from sensorcfg import assets\n"
        "p = sensorcfg.Physics.from_xml_path(str(assets.path('robot.xml')))\n"
        "p.forward()\n"
        "print('ok', sensorcfg.Camera('overview', 24, 32)(p).max() > 0)\n"
    )
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip() == "ok True"


def test_a_user_choice_of_backend_is_kept() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "osmesa"
    result = subprocess.run([sys.executable, "-c", "import os, sensorcfg; print(os.environ['MUJOCO_GL'])"],
                            env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "osmesa"


@pytest.mark.parametrize("mode", ["rgb", "segmentation"])
def test_pixels_match_dm_control(oracle: Any, mode: str) -> None:
    """RGB and segmentation are pixel-identical to dm_control's MJCFCamera on the same physics.

    (Depth is mujoco.Renderer's, linearised for MuJoCo's reverse-Z depth buffer; dm_control 1.0.50 still
    applies the standard-Z formula, so its depths differ by about 1% and at silhouettes.)
    """
    from sensorcfg.observables import camera as camera_module

    camera_module.close_renderers()  # ours are made after dm_control's display: closed first at exit
    root = oracle.mjcf.from_path(str(assets.path("robot.xml")))
    physics = oracle.mjcf.Physics.from_mjcf_model(root)
    try:
        physics.data.qvel[:] = 0.5
        for _ in range(10):
            physics.step()
        for camera in ("overview", "wrist"):
            theirs = oracle.observable.MJCFCamera(root.find("camera", camera), H, W,
                                                  segmentation=mode == "segmentation")(physics)
            ours = sensorcfg.Camera(camera, H, W, mode=mode)(physics)
            assert ours.dtype == theirs.dtype and np.array_equal(ours, theirs), f"{camera} {mode}"
    finally:
        physics.free()  # dm_control's own GL contexts, before MuJoCo's EGL display goes away at exit
