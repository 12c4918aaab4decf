"""What the Warp engine's cameras (`warp.cameras`, MuJoCo Warp's batch ray tracer) render of a camera sensor
and a model, and what they refuse: importable without Warp (`support.refusals` calls it for `validate
--engine warp`).

MuJoCo Warp 4.0.0's renderer (`mujoco_warp.render`) casts one ray per pixel centre against the model's geoms
in groups 0-2 (planes, spheres, capsules, ellipsoids, cylinders, boxes, meshes, height fields) and its flexes,
lit by the model's lights and headlight; a height field is its surface only. The CPU camera draws more by
default, through OpenGL: sites and spatial tendons in groups 0-2, skins, the rays of rangefinder and
geomfromto sensors (`observables.camera.DRAWN_SENSORS`), a height field's side walls and base, and
translucent geoms blended with what is behind them. A model with any of these is refused at the camera's
`element`, as are scene flags the renderer has no counterpart for and noise on an image. What sensorcfg adds
to a model is none of these: its sites are invisible, and its sensors' rays are left out of the CPU camera's
frames.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from ..observables.camera import DRAWN_SENSORS, added_drawn_sensors
from ..selection import element_labels

__all__ = ["HONOURED", "IGNORED", "Found", "camera_refusals", "model_refusal", "settings"]

Found = list[tuple[tuple[str | int, ...], str]]

_CPU = "run this suite on the CPU engines"
# scene flags the renderer follows: flag -> what it sets (`cameras.Camera`)
HONOURED = ("shadow", "skybox", "texture")
# scene flags of effects OpenGL draws in rgb images and the ray tracer never does: accepted either way
IGNORED = ("reflection", "haze")
_VISIBLE_GROUPS = 3  # MjvOption's default geom, site and tendon groups: 0, 1, 2


def _alpha(rgba: np.ndarray, matid: np.ndarray, mat_rgba: np.ndarray) -> np.ndarray:
    """Each element's alpha (its material's where it has one)."""
    out = np.array(rgba[:, 3], np.float64)
    has = matid >= 0
    out[has] = mat_rgba[matid[has], 3]
    return out


def _drawn_sensors(model: mujoco.MjModel) -> list[int]:
    """The model's own sensors whose readings the CPU camera draws by default (a rangefinder's ray); those
    sensorcfg adds are left out of its frames (`observables.camera`)."""
    added, shown = added_drawn_sensors(model), mujoco.MjvOption().flags
    return [i for i in range(model.nsensor) if i not in added
            and (flag := DRAWN_SENSORS.get(int(model.sensor_type[i]))) is not None and shown[flag]]


def _listed(model: mujoco.MjModel, type_name: str, mask: np.ndarray) -> str:
    """The labels of the first three elements in `mask` (as a selector names them: `#<k>` for the k-th of
    the model's own when unnamed), and ', ...' when there are more."""
    labels = element_labels(model, type_name)
    ids = np.flatnonzero(mask)
    shown = [labels.get(int(i)) or getattr(model, type_name)(int(i)).name for i in ids[:3]]  # (or one added)
    return ", ".join(shown) + (", ..." if len(ids) > 3 else "")


def model_refusal(model: mujoco.MjModel) -> str | None:
    """What of `model` the CPU camera draws and MuJoCo Warp's renderer does not (None: nothing); never what
    sensorcfg added (see the module's docstring)."""
    found = []
    site = (model.site_group < _VISIBLE_GROUPS) & (_alpha(model.site_rgba, model.site_matid, model.mat_rgba) > 0)
    if site.any():
        found.append(f"visible sites ({_listed(model, 'site', site)}; give them group=\"3\" or higher, or rgba "
                     "alpha 0)")
    spatial = np.array([any(model.wrap_type[a:a + n] != mujoco.mjtWrap.mjWRAP_JOINT)
                        for a, n in zip(model.tendon_adr, model.tendon_num)], bool)
    tendon = spatial & (model.tendon_group < _VISIBLE_GROUPS) & (model.tendon_width > 0) & (
        _alpha(model.tendon_rgba, model.tendon_matid, model.mat_rgba) > 0) if model.ntendon else np.zeros(0, bool)
    if tendon.any():
        found.append("visible spatial tendons (give them group=\"3\" or higher, or rgba alpha 0)")
    if model.nskin:
        found.append("skins")
    if model.nflex:
        found.append("flexes (not checked against the CPU camera yet)")
    drawn = sorted({mujoco.mjtSensor(int(model.sensor_type[i])).name.removeprefix("mjSENS_").lower()
                    for i in _drawn_sensors(model)})
    if drawn:
        found.append(f"{' and '.join(drawn)} sensors (the CPU camera draws their rays)")
    alpha = _alpha(model.geom_rgba, model.geom_matid, model.mat_rgba)
    shown = (model.geom_group < _VISIBLE_GROUPS) & (alpha > 0)
    terrain = shown & (model.geom_type == mujoco.mjtGeom.mjGEOM_HFIELD)
    if terrain.any():
        found.append(f"height fields ({_listed(model, 'geom', terrain)}; MuJoCo Warp 4.0.0's renderer draws their "
                     "surface only, not the side walls and base the CPU camera draws)")
    clear = shown & (alpha < 1)
    if clear.any():
        found.append(f"translucent geoms ({_listed(model, 'geom', clear)}; OpenGL blends them with what is behind; "
                     "make them opaque, or invisible with alpha 0)")
    if not found:
        return None
    return (f"the model has {'; '.join(found)}, which the CPU camera draws and MuJoCo Warp's renderer does not; "
            f"change the model so, or {_CPU}")


def _projection_refusal(observable: Any, model: mujoco.MjModel) -> str | None:
    """A camera given by its sensor (`sensorsize`, `focal`) whose image has another aspect than the sensor:
    MuJoCo Warp 4.0.0 fits such an image to the sensor otherwise than MuJoCo's OpenGL camera does (checked:
    the same aspect gives the same pixels)."""
    cam = observable.camera_id(model)
    if cam < 0 or model.cam_sensorsize[cam][1] <= 0:
        return None
    width, height = observable.size(model)
    sensor_w, sensor_h = (float(v) for v in model.cam_sensorsize[cam])
    if math.isclose(width * sensor_h, height * sensor_w, rel_tol=1e-6):  # (the model holds float32 sizes)
        return None
    return (f"the camera's sensor is {sensor_w:g} x {sensor_h:g} and its image {width} x {height} pixels, another "
            "aspect, which MuJoCo Warp's renderer fits to the sensor otherwise than the CPU camera; ask for an "
            f"image of the sensor's aspect (width / height = {sensor_w / sensor_h:g}), or {_CPU}")


def settings(observable: Any) -> dict[str, bool]:
    """The renderer's settings for a camera observable's scene flags: use_shadows, render_skybox,
    use_textures (MuJoCo's defaults where the suite says nothing: all on)."""
    option, flags = observable.scene_settings
    out = {"use_shadows": bool(flags[mujoco.mjtRndFlag.mjRND_SHADOW]),
           "render_skybox": bool(flags[mujoco.mjtRndFlag.mjRND_SKYBOX]),
           "use_textures": True}
    if option is not None:
        out["use_textures"] = bool(option.flags[mujoco.mjtVisFlag.mjVIS_TEXTURE])
    return out


def _scene_refusals(observable: Any) -> Found:
    """Scene flags that differ from MuJoCo's defaults and that the renderer neither follows nor leaves out
    of rgb images by design."""
    from ..observables.camera import SCENE_FLAGS, scene_settings

    option, flags = observable.scene_settings
    default_option, default_flags = mujoco.MjvOption(), scene_settings(None)[1]
    found: Found = []
    for name, (table, index) in SCENE_FLAGS.items():
        if name in HONOURED or name in IGNORED:
            continue
        changed = (table == "render" and flags[index] != default_flags[index]) or (
            table == "vis" and option is not None and option.flags[index] != default_option.flags[index])
        if changed:
            found.append((("camera", "scene", name), f"scene flag {name!r} is not followed by MuJoCo Warp's "
                          f"renderer (the Warp engine follows {', '.join(HONOURED)}); remove it, or {_CPU}"))
    if option is not None and any(
            not np.array_equal(getattr(option, group), getattr(default_option, group))
            for group in ("geomgroup", "sitegroup", "tendongroup", "flexgroup", "skingroup")):
        found.append((("camera", "scene"), f"a visualisation option with other element groups than MuJoCo's "
                      f"default (0, 1, 2) is not followed by MuJoCo Warp's renderer; use the default, or {_CPU}"))
    return found


def camera_refusals(observable: Any, model: mujoco.MjModel | None) -> Found:
    """What the Warp engine does not run of a camera observable (on `model`, when given)."""
    found: Found = []
    if model is not None:
        if observable.camera_id(model) < 0:
            found.append((("element",), f"the free camera (-1) is not rendered by the Warp engine; select a model "
                          f"camera, or {_CPU}"))
        problem = _projection_refusal(observable, model)
        if problem is not None:
            found.append((("element",), problem))
        problem = model_refusal(model)
        if problem is not None:
            found.append((("element",), problem))
    found += _scene_refusals(observable)
    if observable.noise is not None:
        found.append((("noise",), f"noise on a camera image is not run by the Warp engine yet; remove it, or {_CPU}"))
    return found
