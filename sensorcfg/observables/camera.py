"""Camera observables: RGB (uint8), depth (float32, metres) and segmentation (int32 object id and type).

Renderers are expensive (an OpenGL context and framebuffers each), so cameras share one
`mujoco.Renderer` per (model, width, height) instead of holding one per observable.

A camera sees the model as its file has it: the sites sensorcfg adds are invisible (`native.compile`), and
what MuJoCo's scene draws for the sensors it adds (`DRAWN_SENSORS`: a rangefinder kind's ray) is left out
of every frame, so adding a sensor to a suite changes no pixel.
"""

from __future__ import annotations

import atexit
import sys
import threading
import warnings
import weakref
from collections.abc import Callable, Mapping
from typing import Any, Literal, cast

import mujoco
import numpy as np
from dm_env import specs

from .. import _gl
from ..errors import SuiteError, UnsupportedError, did_you_mean
from ..physics import raw_structs
from ..selection import added_by_sensorcfg, element_id
from .base import Observable

__all__ = ["Camera", "DRAWN_SENSORS", "MODES", "SCENE_FLAGS", "added_drawn_sensors", "close_renderers"]

# mode -> (channels, dtype, minimum, maximum)
MODES: dict[str, tuple[int, type, float, float]] = {
    "rgb": (3, np.uint8, 0, 255),
    "depth": (1, np.float32, 0.0, np.inf),
    "segmentation": (2, np.int32, -1, np.iinfo(np.int32).max),
}

# Scene flags a camera accepts, by lower-case name without prefix: MuJoCo's render flags (mjtRndFlag, in the
# scene: shadow, reflection, skybox, ...; the ones the image mode sets are not offered) and visualisation
# flags (mjtVisFlag, in MjvOption). name -> (table, index); `_MODE_FLAGS` are the mode's own.
_MODE_FLAGS = ("mjRND_DEPTH", "mjRND_SEGMENT", "mjRND_IDCOLOR")
SCENE_FLAGS: dict[str, tuple[str, int]] = {
    **{name[len("mjRND_"):].lower(): ("render", int(value)) for name, value in mujoco.mjtRndFlag.__members__.items()
       if name.startswith("mjRND_") and name not in _MODE_FLAGS},
    **{name[len("mjVIS_"):].lower(): ("vis", int(value)) for name, value in mujoco.mjtVisFlag.__members__.items()
       if name.startswith("mjVIS_")},
}
_DEFAULT_RENDER_FLAGS = np.array(mujoco.MjvScene().flags, dtype=np.uint8)  # shadow, reflection, skybox... on
# MuJoCo's sensor types whose readings its scene draws (mjvGeoms of objtype mjOBJ_SENSOR) -> the
# visualisation flag that draws them: a rangefinder's ray and a geomfromto's segment (mjVIS_RANGEFINDER, on
# by default), a tactile sensor's triangles (mjVIS_CONTACTPOINT, off)
DRAWN_SENSORS: dict[int, int] = {
    int(getattr(mujoco.mjtSensor, f"mjSENS_{name}")): int(getattr(mujoco.mjtVisFlag, f"mjVIS_{flag}"))
    for name, flag in (("RANGEFINDER", "RANGEFINDER"), ("GEOMFROMTO", "RANGEFINDER"), ("TACTILE", "CONTACTPOINT"))
    if hasattr(mujoco.mjtSensor, f"mjSENS_{name}")}
_SENSOR = int(mujoco.mjtObj.mjOBJ_SENSOR)
DEFAULT_SIZE = (320, 240)  # width, height when neither the suite nor the camera's MJCF `resolution` says
MAX_SIDE = 16384  # pixels a side: what Mesa's software renderer and most GPUs' framebuffers allow


def default_size(model: mujoco.MjModel, cam: int) -> tuple[int, int]:
    """(width, height): the camera's MJCF `resolution` when the model sets one (MuJoCo's default is 1x1),
    else 320x240."""
    width, height = (int(v) for v in model.cam_resolution[cam])
    return (width, height) if (width, height) != (1, 1) else DEFAULT_SIZE


# per model: (width, height, thread) -> renderer. A renderer is used by its own thread only; no GL context
# stays current after a frame, so the renderers of threads that have ended are closed from another thread
# (when a new renderer is made) or at exit.
_RENDERERS: weakref.WeakKeyDictionary[mujoco.MjModel, dict[tuple[int, int, threading.Thread], mujoco.Renderer]] = (
    weakref.WeakKeyDictionary())
_LOCK = threading.Lock()  # guards the pools and context creation (EGL initialises its display once)


def _gl_context_module() -> Any:
    """mujoco's module whose `GLContext` its Renderer creates (None when rendering is unavailable)."""
    module = sys.modules.get(getattr(mujoco.Renderer, "__module__", ""))
    found = getattr(module, "gl_context", None)
    return found or sys.modules.get("mujoco.rendering.classic.gl_context") or sys.modules.get("mujoco.gl_context")


def _context_class() -> type:
    return getattr(_gl_context_module(), "GLContext", None) or object


def _follow_backend() -> None:
    """Render with EGL where `_gl.backend()` says so, whatever mujoco picked when it was imported.

    mujoco picks its GL backend once, when imported: with MUJOCO_GL unset it picks GLFW, which cannot open
    a context on a headless machine (the process dies), and so does a mujoco imported before MUJOCO_GL=egl
    was set. mujoco's Renderer looks its context class up at construction, so point it at EGL's.
    """
    gl_context = _gl_context_module()
    current = getattr(gl_context, "GLContext", None)
    if (_gl.backend() == "egl" and current is not None
            and getattr(current, "__module__", "").startswith("mujoco.glfw")):
        from mujoco.egl import GLContext

        gl_context.GLContext = GLContext


def check_size(model: mujoco.MjModel, width: int, height: int) -> str | None:
    """Why a width x height image cannot be rendered with the model's offscreen buffer, or None."""
    if max(width, height) > MAX_SIDE:
        return (f"a {width}x{height} camera image is larger than OpenGL framebuffers allow ({MAX_SIDE} pixels a "
                "side in Mesa and on most GPUs); ask for a smaller image")
    offwidth, offheight = model.vis.global_.offwidth, model.vis.global_.offheight
    if width <= offwidth and height <= offheight:
        return None
    return (f"a {width}x{height} camera image exceeds the model's offscreen buffer ({offwidth}x{offheight}); "
            f"add <visual><global offwidth=\"{max(width, offwidth)}\" offheight=\"{max(height, offheight)}\"/>"
            "</visual> to the model or ask for a smaller image")


def _renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """This thread's renderer for the model and size."""
    key = (width, height, threading.current_thread())
    pool = _RENDERERS.get(model)
    renderer = None if pool is None else pool.get(key)
    if renderer is not None:
        return renderer
    problem = check_size(model, width, height)
    if problem is not None:
        raise SuiteError(problem)
    with _LOCK:
        if _gl.import_failure is not None:
            raise UnsupportedError(_gl.gl_error())
        try:
            _follow_backend()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # GLFW warns before it fails: the error says it all, once
                with _gl.current_restored(_context_class()):
                    renderer = mujoco.Renderer(model, height=height, width=width)
        except Exception as e:  # noqa: BLE001 - no usable GL: ImportError, FatalError, EGLError, no Renderer...
            raise UnsupportedError(_gl.gl_error(e)) from None
        _RENDERERS.setdefault(model, {})[key] = renderer
        ended = [pool.pop(k) for pool in list(_RENDERERS.values()) for k in list(pool) if not k[2].is_alive()]
    _close(ended)
    _close_at_exit()
    return renderer


def _close_at_exit() -> None:
    """Close shared renderers before the GL backend shuts down at exit.

    MuJoCo's EGL backend (and dm_control's) registers `eglTerminate` with atexit when it creates its first
    context; handlers run last-registered first, so (re-)registering after each new renderer keeps them
    from being freed on a terminated display (which prints EGL errors at exit).
    """
    atexit.unregister(close_renderers)
    atexit.register(close_renderers)


def close_renderers() -> None:
    """Release every shared renderer, of every thread (they are recreated on demand)."""
    with _LOCK:
        renderers = [r for pool in list(_RENDERERS.values()) for r in pool.values()]
        for pool in list(_RENDERERS.values()):
            pool.clear()
    _close(renderers)


def _close(renderers: list[mujoco.Renderer]) -> None:
    for renderer in renderers:
        context = renderer._gl_context
        try:
            with _gl.current_restored(type(context)):
                if context is not None:
                    context.make_current()  # MuJoCo 3 frees its GL objects without making it current
                renderer.close()
        except Exception:  # noqa: BLE001 - a context current in a thread that is rendering now: leave it
            continue


def added_drawn_sensors(model: mujoco.MjModel) -> frozenset[int]:
    """The ids of the sensors sensorcfg added to `model` whose readings MuJoCo's scene draws."""
    return frozenset(i for i in range(model.nsensor) if int(model.sensor_type[i]) in DRAWN_SENSORS
                     and added_by_sensorcfg(model.sensor(i).name))


def _leave_out(scene: mujoco.MjvScene, sensors: frozenset[int]) -> None:
    """Make the scene's geoms that draw `sensors` draw nothing: no shape, and no segmentation id (which the
    segmentation and depth passes skip)."""
    for k in range(scene.ngeom):
        geom = scene.geoms[k]
        if geom.objtype == _SENSOR and geom.objid in sensors:
            geom.type = mujoco.mjtGeom.mjGEOM_NONE
            geom.segid = -1


def scene_settings(value: mujoco.MjvOption | Mapping[str, bool] | None) -> tuple[mujoco.MjvOption | None, np.ndarray]:
    """(visualisation option or None, the scene's render flags) for a camera's `scene`."""
    render = _DEFAULT_RENDER_FLAGS.copy()
    if value is None or isinstance(value, mujoco.MjvOption):
        return value, render
    option = mujoco.MjvOption() if any(SCENE_FLAGS.get(k, ("", 0))[0] == "vis" for k in value) else None
    for key, on in value.items():
        if key not in SCENE_FLAGS:
            raise SuiteError(f"unknown scene flag {key!r}{did_you_mean(str(key), SCENE_FLAGS)}; "
                             f"flags: {', '.join(SCENE_FLAGS)}")
        table, index = SCENE_FLAGS[key]
        if table == "vis":
            cast(mujoco.MjvOption, option).flags[index] = bool(on)
        else:
            render[index] = bool(on)
    return option, render


class Camera(Observable):
    """An image from a model camera ('camera:name', its name, or its id).

    `height` and `width` default to the camera's MJCF `resolution` when the model sets one, else 240x320;
    until then (bound to a model) `array_spec` is None. `scene_option` switches scene flags by name
    (`SCENE_FLAGS`: render flags such as shadow, reflection, skybox, and visualisation flags), or is an
    `MjvOption`.
    """

    def __init__(self, camera: str | int, height: int | None = None, width: int | None = None,
                 update_interval: Any = 1,
                 buffer_size: int | None = None, delay: Any = None, aggregator: Any = None,
                 corruptor: Callable[..., Any] | None = None,
                 mode: Literal["rgb", "depth", "segmentation"] = "rgb",
                 scene_option: mujoco.MjvOption | Mapping[str, bool] | None = None):
        """Check the image settings now; the camera is resolved, and its renderer made, when bound to a model.

        Args:
            camera: The model camera: 'camera:name', its name, or its id (-1: the free camera).
            height: Image height in pixels; None: the camera's MJCF `resolution`, else 240.
            width: Image width in pixels; None: the camera's MJCF `resolution`, else 320.
            update_interval, buffer_size, delay, aggregator, corruptor: The schedule settings of every
                observable (`Observable`).
            mode: "rgb" (uint8 HxWx3), "depth" (float32 distances in the model's units, HxWx1) or
                "segmentation" (int32 object ids and types, HxWx2).
            scene_option: Scene flags switched by name (`SCENE_FLAGS`: shadow, reflection, skybox, ...), or an
                `MjvOption`; None: MuJoCo's defaults.

        Raises:
            SuiteError: An unknown mode, a height or width that is not a positive integer, an unknown scene
                flag, or a setting that is not one an observable takes.
        """
        if mode not in MODES:
            raise SuiteError(f"unknown camera mode {mode!r}{did_you_mean(str(mode), MODES)}; use {', '.join(MODES)}")
        for name, value in (("height", height), ("width", width)):
            if value is not None and (not isinstance(value, int) or isinstance(value, bool) or value < 1):
                raise SuiteError(f"camera {camera!r}: {name} must be a positive integer, got {value!r}")
        self._camera = camera.partition(":")[2] if isinstance(camera, str) and camera.startswith("camera:") else camera
        self._height, self._width, self._mode = height, width, mode
        self._size: tuple[int, int] | None = (width, height) if width is not None and height is not None else None
        self._scene_option, self._render_flags = scene_settings(scene_option)
        super().__init__(update_interval, buffer_size, delay, aggregator, corruptor)

    def __repr__(self) -> str:
        return f"Camera({getattr(self, '_camera', '?')!r}, mode={getattr(self, '_mode', '?')!r})"

    @property
    def height(self) -> int | None:
        """Image height: as given, else the bound camera's (None before binding)."""
        return self._size[1] if self._size else self._height

    @property
    def width(self) -> int | None:
        return self._size[0] if self._size else self._width

    @property
    def mode(self) -> str:
        return self._mode

    @property
    def scene_settings(self) -> tuple[mujoco.MjvOption | None, np.ndarray]:
        """(visualisation option or None, the scene's render flags) its frames are rendered with."""
        return self._scene_option, self._render_flags

    @property
    def array_spec(self) -> specs.BoundedArray | None:
        if self._size is None:
            return None
        channels, dtype, low, high = MODES[self._mode]
        width, height = self._size
        return specs.BoundedArray(shape=(height, width, channels), dtype=dtype, minimum=low, maximum=high)

    def size(self, model: mujoco.MjModel) -> tuple[int, int]:
        """(width, height) on `model`: as given, else the camera's MJCF resolution, else 320x240."""
        cam = self.camera_id(model)
        width, height = default_size(model, cam) if cam >= 0 else DEFAULT_SIZE
        return (self._width or width, self._height or height)

    def camera_id(self, model: mujoco.MjModel) -> int:
        if isinstance(self._camera, int):
            if not -1 <= self._camera < model.ncam:
                raise SuiteError(f"camera id {self._camera} is out of range: the model has {model.ncam} cameras")
            return self._camera
        return element_id(model, "camera", self._camera)  # a name or `#<id>`, as a suite's selector says it

    def _callable(self, physics: Any) -> Callable[[], np.ndarray]:
        model, data = raw_structs(physics)
        cam = self.camera_id(model)
        width, height = self._size = self.size(model)
        _renderer(model, width, height)  # fail at binding, not at the first frame
        depth, segmentation = self._mode == "depth", self._mode == "segmentation"
        option, flags = self._scene_option, self._render_flags
        added = added_drawn_sensors(model)

        def render() -> np.ndarray:
            renderer = _renderer(model, width, height)  # the calling thread's
            if depth:
                renderer.enable_depth_rendering()
            elif segmentation:
                renderer.enable_segmentation_rendering()
            else:
                renderer.disable_depth_rendering()
                renderer.disable_segmentation_rendering()
            renderer.update_scene(data, camera=cam, scene_option=option)
            renderer.scene.flags[:] = flags  # the renderer is shared: every frame sets all of them
            if added:
                _leave_out(renderer.scene, added)
            with _gl.current_restored(type(renderer._gl_context)):
                pixels = renderer.render()
            return pixels[..., None] if depth else pixels

        return render
