"""What the Warp engine (`WarpEnvironment`) runs: the one home of its refusals, importable without Warp.

- `STAGES`: the noise stage types its kernels run (`warp.sensors` holds each one's kernel code), with
  parameters fixed or drawn per episode (drawn on the host, `warp.episode`);
- `FIELDS`: the mjData fields a sensor may read there: those the installed MuJoCo Warp's `Data` holds as
  (nworld, ...) float32 arrays laid out as mjData's, so a position computed on an MjData addresses the same
  value (`FIELDS_BY_LINE`: per MuJoCo Warp line, 4.x and 3.11, mjlab 1.6's pin; 4.x's where none is installed);
- `RAY_GEOMS`: the geom types MuJoCo Warp's ray caster casts height scans' rays at (`warp/rays.py`);
- `refusals(observable, field, model)`: what the engine does not run of one bound sensor, as (key, message)
  pairs, the key a path inside the sensor's entry of a suite (`kind`, `interval`, `delay`, `noise.<i>.type`,
  ...); a camera's are `camera_support.camera_refusals` (what MuJoCo Warp's renderer does not cover).

`WarpEnvironment` raises them at construction (each a problem at `sensors.<name>.<key>`); `validate
--engine warp` and `Suite.check(model, warp=True)` report them at the suite's lines. What a BatchEnvironment
refuses the Warp engine refuses too, by the batch's rules (`plan.bind.bind`, `checks.batch_problems`): these
are only what it refuses besides. (The one exception: a generic callable with `batched: true`, which only the
Warp engine runs, `warp.generic`.)
"""

from __future__ import annotations

from collections.abc import Mapping
from importlib import metadata
from typing import Any

import mujoco
import numpy as np

from ..heightscan import visible_rgba
from ..plan.bind import per_simulation
from ..plan.noise import step
from ..plan.records import NoiseStep
from .camera_support import camera_refusals

__all__ = ["FIELDS", "FIELDS_BY_LINE", "LINE", "RAY_GEOMS", "STAGES", "Found", "field_refusal", "refusals",
           "stage_refusals", "terrain_refusals"]

Found = list[tuple[tuple[str | int, ...], str]]  # (key path inside the sensor, message), as `checks.Found`

STAGES: tuple[str, ...] = ("gaussian", "uniform", "bias", "scale", "random_walk", "quantize", "clip", "dropout",
                           "outlier", "lowpass", "misalign")

# Generated from MuJoCo Warp 4.0.0's `types.Data` (its dataclass fields' `array(...)` annotations) against
# MuJoCo 4.0.0's mjData extents (`mujoco.introspect`) by `fields_of_mujoco_warp` in
# tests/warp/test_warp_support.py, which checks this table against the installed mujoco_warp (and the values
# against MjData's): a field whose first axis is nworld, whose scalar is float32 (vectors, quaternions and
# matrices of them included), that mjData has with the same axes (MuJoCo Warp's `nactuator`, and 3.11's `nu`, are
# mjData's `nout`: it runs no SO3 transmission nor gain, so one control and one force output per actuator); not
# a sparse matrix (nC, nD, nJten, nJmom, nJfe or nefmK
# values, laid out by each library's own sparsity) nor a factor of one (qLDiagInv, qHDiagInv).
_FIELDS_4: frozenset[str] = frozenset({
    "act", "act_dot", "actuator_force", "actuator_length", "actuator_velocity", "cacc", "cam_xmat", "cam_xpos",
    "cdof", "cdof_dot", "cfrc_ext", "cfrc_int", "cinert", "crb", "ctrl", "cvel", "efm_as", "efm_c", "efm_ca",
    "efm_diag", "efm_ts", "energy", "flexedge_hessian", "flexedge_length", "flexedge_velocity", "flexvert_hessian",
    "flexvert_xpos", "geom_xmat", "geom_xpos", "history", "light_xdir", "light_xpos", "mocap_pos", "mocap_quat",
    "plastic", "qacc", "qacc_smooth", "qacc_warmstart", "qfrc_actuator", "qfrc_adhesion",
    "qfrc_applied", "qfrc_bias", "qfrc_constraint", "qfrc_damper", "qfrc_fluid", "qfrc_gravcomp", "qfrc_inverse",
    "qfrc_passive", "qfrc_smooth", "qfrc_spring", "qpos", "qvel", "sensordata", "site_xmat", "site_xpos",
    "subtree_angmom", "subtree_com", "subtree_linvel", "ten_length", "ten_velocity", "time", "userdata", "wrap_xpos",
    "xanchor", "xaxis", "xfrc_applied", "ximat", "xipos", "xmat", "xpos", "xquat",
})

# What MuJoCo Warp 3.11 (the line mjlab 1.6 pins) does not hold of them, by the same rule
_LACKING_3_11 = frozenset({"efm_as", "efm_c", "efm_ca", "efm_diag", "efm_ts", "flexedge_hessian", "flexvert_hessian",
                           "plastic", "qfrc_adhesion"})
FIELDS_BY_LINE: Mapping[str, frozenset[str]] = {"4": _FIELDS_4, "3.11": _FIELDS_4 - _LACKING_3_11}


def _installed_line() -> str:
    """The installed MuJoCo Warp's line (a key of `FIELDS_BY_LINE`): "3.11" below 4, else (or where none is
    installed) "4". Read from the package's metadata, so that this module stays importable without Warp."""
    try:
        major = int(metadata.version("mujoco-warp").split(".")[0])
    except (metadata.PackageNotFoundError, ValueError):
        return "4"
    return "3.11" if major < 4 else "4"


LINE = _installed_line()
FIELDS: frozenset[str] = FIELDS_BY_LINE[LINE]

# MuJoCo Warp 4.0.0's ray caster (`mujoco_warp/_src/ray.py`: `ray_geom`, `ray_mesh`, `ray_hfield`); it reads a
# geom of any other type (an SDF) as a miss
RAY_GEOMS: frozenset[int] = frozenset(int(t) for t in (
    mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_HFIELD, mujoco.mjtGeom.mjGEOM_SPHERE,
    mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_ELLIPSOID, mujoco.mjtGeom.mjGEOM_CYLINDER,
    mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_MESH))

_CPU = "run this suite on the CPU engines"
# mjData fields MuJoCo Warp lacks -> the kind holding the same value that it has
_INSTEAD = {"site_xquat": "xmat", "geom_xquat": "xmat", "xiquat": "ximat"}


def field_refusal(field: str, kind: str | None = None) -> str:
    """Why the Warp engine cannot read mjData field `field` (one not in `FIELDS`), read by kind `kind`."""
    reads = f"kind {kind!r} reads mjData's {field}" if kind and kind != field else f"mjData's {field}"
    if field in _FIELDS_4:  # held by MuJoCo Warp 4, not by the installed line
        return f"{reads}, which MuJoCo Warp {LINE}'s Data does not hold; read another kind, install MuJoCo Warp 4 " \
               f"(sensorcfg[warp]), or {_CPU}"
    instead = f"read {_INSTEAD[field]!r} instead (the same orientation as a matrix)" if field in _INSTEAD else \
        "read another kind"
    return f"{reads}, which MuJoCo Warp's Data does not hold as float32 values; {instead}, or {_CPU}"


def stage_refusals(noise_step: NoiseStep) -> Found:
    """What the Warp engine does not run of one noise stage, at its keys below `noise.<i>`."""
    at = ("noise", noise_step.stream)
    if noise_step.stage not in STAGES:
        return [(at + ("type",), f"a {noise_step.stage} noise stage is not run by the Warp engine yet (it runs "
                 f"{', '.join(STAGES)}); use those, or {_CPU}")]
    return []


def _steps(noise: Any) -> list[NoiseStep]:
    """A sensor's noise pipeline (leveled or not) as the plan's steps; none without noise."""
    if noise is None:
        return []
    shape = tuple(noise.shape)
    return [step(config, i, shape) for i, config in enumerate(noise.configs)]


def terrain_refusals(scan: Any, model: mujoco.MjModel) -> Found:
    """A height scan whose rays would see (`heightscan.terrain_model`'s geoms, visible as mj_ray decides, in
    its geomgroup) a geom type outside `RAY_GEOMS`: MuJoCo Warp would read it as a miss."""
    groups = scan.scan.geomgroup
    found: Found = []
    for g in np.flatnonzero(model.body_weldid[model.geom_bodyid] == 0):
        group = min(5, max(0, int(model.geom_group[g])))  # mj_ray's clamp
        if int(model.geom_type[g]) in RAY_GEOMS or visible_rgba(model, int(g))[3] == 0 or \
                (groups is not None and group not in groups):
            continue
        kind = mujoco.mjtGeom(int(model.geom_type[g])).name.removeprefix("mjGEOM_").lower()
        found.append((("kind",), f"its rays would meet geom {model.geom(int(g)).name or f'#{g}'!r} (type {kind}), "
                      "which MuJoCo Warp's ray caster does not cast (it would read as a miss); leave it out of this "
                      f"scan's geomgroup, or {_CPU}"))
    return found


def refusals(observable: Any, field: str | None, model: mujoco.MjModel | None = None) -> Found:
    """What the Warp engine does not run of an enabled observable that a BatchEnvironment runs: what MuJoCo
    Warp's renderer does not cover of a camera and of `model` (the compiled MjModel it is bound to; None: the
    camera's own settings only, `camera_support.camera_refusals`), height scans that would see a geom its ray
    caster does not cast (with `model`: `terrain_refusals`), noise stages outside `STAGES`, a lowpass whose
    cutoff is drawn per episode on a drawn interval, and `field` (the mjData field it reads; None for none)
    outside `FIELDS`. (Drawn intervals and delays it runs: `warp.drawn`; those a BatchEnvironment refuses, it
    refuses by the batch's rules.)"""
    if hasattr(observable, "camera_id"):
        return camera_refusals(observable, model)
    found: Found = []
    if per_simulation(observable) and model is not None:
        found += terrain_refusals(observable, model)
    if field is not None and field not in FIELDS:
        found.append((("kind",), field_refusal(field, getattr(observable, "kind", None))))
    drawn_interval = callable(getattr(observable, "update_interval", None))
    for noise_step in _steps(getattr(observable, "noise", None)):
        found += stage_refusals(noise_step)
        if drawn_interval and noise_step.stage == "lowpass" and "cutoff" in noise_step.drawn:
            found.append((("noise", noise_step.stream, "cutoff"),
                          "a lowpass whose cutoff is drawn per episode, on a drawn interval, is not run by the Warp "
                          "engine (its coefficient per gap between samples is computed for a fixed cutoff); give a "
                          f"fixed cutoff or a constant interval, or {_CPU}"))
    return found
