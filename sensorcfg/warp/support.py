"""What the Warp engine (`WarpEnvironment`) runs: the one home of its refusals, importable without Warp.

- `STAGES`: the noise stage types its kernels run (`warp.sensors` holds each one's kernel code);
- `FIELDS`: the mjData fields a sensor may read there: those MuJoCo Warp's `Data` holds as (nworld, ...)
  float32 arrays laid out as mjData's, so a position computed on an MjData addresses the same value;
- `refusals(observable, field, model)`: what the engine does not run of one bound sensor, as (key, message)
  pairs, the key a path inside the sensor's entry of a suite (`kind`, `interval`, `delay`, `noise.<i>.type`,
  ...); a camera's are `camera_support.camera_refusals` (what MuJoCo Warp's renderer does not cover).

`WarpEnvironment` raises them at construction (each a problem at `sensors.<name>.<key>`); `validate
--engine warp` and `Suite.check(model, warp=True)` report them at the suite's lines. What a BatchEnvironment
refuses the Warp engine refuses too, by the batch's rules (`plan.bind.bind`, `checks.batch_problems`): these
are only what it refuses besides.
"""

from __future__ import annotations

from typing import Any

from ..plan.bind import per_simulation
from ..plan.noise import step
from ..plan.records import NoiseStep
from .camera_support import camera_refusals

__all__ = ["FIELDS", "STAGES", "Found", "field_refusal", "refusals", "stage_refusals"]

Found = list[tuple[tuple[str | int, ...], str]]  # (key path inside the sensor, message), as `checks.Found`

STAGES: tuple[str, ...] = ("gaussian", "uniform", "bias", "scale", "random_walk", "quantize", "clip", "dropout",
                           "outlier", "lowpass")

# Generated from MuJoCo Warp 4.0.0's `types.Data` (its dataclass fields' `array(...)` annotations) against
# MuJoCo 4.0.0's mjData extents (`mujoco.introspect`) by `fields_of_mujoco_warp` in
# tests/warp/test_warp_support.py, which checks this table against the installed mujoco_warp (and the values
# against MjData's): a field whose first axis is nworld, whose scalar is float32 (vectors, quaternions and
# matrices of them included), that mjData has with the same axes (MuJoCo Warp's `nactuator` is mjData's
# `nout`: it runs one force output per actuator); not a sparse matrix (nC, nD, nJten, nJmom, nJfe or nefmK
# values, laid out by each library's own sparsity) nor a factor of one (qLDiagInv, qHDiagInv).
FIELDS: frozenset[str] = frozenset({
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

_CPU = "run this suite on the CPU engines"
# mjData fields MuJoCo Warp lacks -> the kind holding the same value that it has
_INSTEAD = {"site_xquat": "xmat", "geom_xquat": "xmat", "xiquat": "ximat"}


def field_refusal(field: str, kind: str | None = None) -> str:
    """Why the Warp engine cannot read mjData field `field` (one not in `FIELDS`), read by kind `kind`."""
    reads = f"kind {kind!r} reads mjData's {field}" if kind and kind != field else f"mjData's {field}"
    instead = f"read {_INSTEAD[field]!r} instead (the same orientation as a matrix)" if field in _INSTEAD else \
        "read another kind"
    return f"{reads}, which MuJoCo Warp's Data does not hold as float32 values; {instead}, or {_CPU}"


def stage_refusals(noise_step: NoiseStep) -> Found:
    """What the Warp engine does not run of one noise stage, at its keys below `noise.<i>`."""
    at = ("noise", noise_step.stream)
    if noise_step.stage not in STAGES:
        return [(at + ("type",), f"a {noise_step.stage} noise stage is not run by the Warp engine yet (it runs "
                 f"{', '.join(STAGES)}); use those, or {_CPU}")]
    return [(at + (name,), f"its {name} is drawn per episode, which the Warp engine does not run yet; give a "
             f"fixed value, or {_CPU}") for name in noise_step.drawn]


def _steps(noise: Any) -> list[NoiseStep]:
    """A sensor's noise pipeline (leveled or not) as the plan's steps; none without noise."""
    if noise is None:
        return []
    shape = tuple(noise.shape)
    return [step(config, i, shape) for i, config in enumerate(noise.configs)]


def refusals(observable: Any, field: str | None, model: Any = None) -> Found:
    """What the Warp engine does not run of an enabled observable that a BatchEnvironment runs: height scans
    (cast per simulation), what MuJoCo Warp's renderer does not cover of a camera and of `model` (the
    compiled MjModel; None: the camera's own settings only, `camera_support.camera_refusals`), drawn
    intervals and delays, noise stages outside `STAGES` or with parameters drawn per episode, and `field`
    (the mjData field it reads; None for none) outside `FIELDS`."""
    if hasattr(observable, "camera_id"):
        return camera_refusals(observable, model)
    if per_simulation(observable):
        return [(("kind",), f"height scans are cast per simulation on the CPU, which the Warp engine does not do "
                 f"yet; remove this sensor, or {_CPU}")]
    found: Found = []
    for key, attr in (("interval", "update_interval"), ("delay", "delay")):
        if callable(getattr(observable, attr, None)):
            found.append(((key,), f"a drawn {key} is not run by the Warp engine yet; give a constant one, or {_CPU}"))
    if field is not None and field not in FIELDS:
        found.append((("kind",), field_refusal(field, getattr(observable, "kind", None))))
    for noise_step in _steps(getattr(observable, "noise", None)):
        found += stage_refusals(noise_step)
    return found
