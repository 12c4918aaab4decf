"""A model compiled with a suite's native sensors: MJCF (or an MjSpec) -> MjSpec + sensors -> MjModel.

The robot file is not edited: it is read into an `MjSpec`, compiled once as written (to resolve the
suite's selectors), given one MuJoCo sensor per selected element of each native kind (and a site at a
body's frame where the type reads a site), and compiled again. A sensor MuJoCo refuses is left out and its
message kept for the suite's line; so is a sensor whose own options do not resolve (binding reports it).
Sensors and sites change no dynamics: the compiled model steps exactly as the file's own.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco

from ..config.models import SensorConfig
from ..errors import SuiteError
from ..kinds import ON_DEMAND
from ..observables.feature import computed_by_model
from ..selection import split_selector
from .plan import Added, native_row, plan_sensor

__all__ = ["Compiled", "compile_model", "native_names", "reads_on_demand"]

Compiled = tuple[mujoco.MjModel, dict[str, str]]  # the model, and MuJoCo's message per refused suite sensor
_ELEMENT = re.compile(r"sensorcfg:([^:\s']+):\d+")


def native_names(sensors: Mapping[str, SensorConfig]) -> list[str]:
    """The suite sensors whose kind adds a MuJoCo sensor (the element type decides, see `native_row`)."""
    out = []
    for name, cfg in sensors.items():
        first = cfg.element if isinstance(cfg.element, str) else (cfg.element or ("",))[0]
        try:
            type_name: str | None = split_selector(first)[0]
        except SuiteError:
            type_name = None
        if native_row(cfg.kind, type_name) is not None:
            out.append(name)
    return out


def _spec(source: Any) -> mujoco.MjSpec:
    if isinstance(source, mujoco.MjSpec):
        return source.copy()
    path = os.fspath(source)
    if path.lower().endswith(".mjb"):
        raise ValueError("a compiled .mjb model cannot take new sensors; give its MJCF (.xml) file")
    return mujoco.MjSpec.from_file(path)


def _enum(cls: Any, prefix: str, member: str | None) -> int:
    return int(getattr(cls, f"{prefix}{member}")) if member else int(mujoco.mjtObj.mjOBJ_UNKNOWN)


def _add(spec: mujoco.MjSpec, added: Added) -> list[Any]:
    """Write one record into the spec; the elements created (to delete them if MuJoCo refuses)."""
    made = []
    if added.site_body is not None:
        body = spec.worldbody if added.site_body == "world" else spec.body(added.site_body)
        site = body.add_site(name=added.name)
        if added.site_quat is not None:
            site.quat = list(added.site_quat)
        made.append(site)
    sensor = spec.add_sensor()
    sensor.name = added.name
    sensor.type = _enum(mujoco.mjtSensor, "mjSENS_", added.sensor)
    sensor.objtype = _enum(mujoco.mjtObj, "mjOBJ_", added.objtype)
    sensor.objname = added.objname
    sensor.reftype = _enum(mujoco.mjtObj, "mjOBJ_", added.reftype)
    sensor.refname = added.refname or ""
    sensor.intprm = list(added.intprm)
    sensor.cutoff = added.cutoff
    made.append(sensor)
    return made


# the MuJoCo sensor whose presence makes every step fill an on-demand family (`kinds.ON_DEMAND`'s flag)
_ENABLERS = {"flg_rnepost": ("ACCELEROMETER", "SITE"), "flg_subtreevel": ("SUBTREELINVEL", "BODY")}


def reads_on_demand(sensors: Mapping[str, SensorConfig]) -> bool:
    """Whether a suite reads a field MuJoCo computes on demand only (cfrc_ext, cacc, subtree_linvel, ...)."""
    return any(cfg.kind in ON_DEMAND for cfg in sensors.values())


def _enable_on_demand(spec: mujoco.MjSpec, plain: mujoco.MjModel, sensors: Mapping[str, SensorConfig]) -> bool:
    """For a batch, whose rollout cannot call MuJoCo's on-demand functions between substeps: one sensor per
    family the suite reads and the model does not compute (an accelerometer at a world site, a subtree
    velocity of the world), so that every step fills it, as MuJoCo does for a model with such sensors.
    They change no dynamics, and the values equal those the single simulation computes on demand."""
    added = False
    for od in {ON_DEMAND[cfg.kind] for cfg in sensors.values() if cfg.kind in ON_DEMAND}:
        if computed_by_model(plain, od):
            continue
        sensor_type, objtype = _ENABLERS[od.flag]
        objname = "world"
        if objtype == "SITE":
            objname = spec.worldbody.add_site(name=f"sensorcfg-{od.flag}").name
        spec.add_sensor(name=f"sensorcfg-{od.flag}", type=_enum(mujoco.mjtSensor, "mjSENS_", sensor_type),
                        objtype=_enum(mujoco.mjtObj, "mjOBJ_", objtype), objname=objname)
        added = True
    return added


def compile_model(source: Any, sensors: Mapping[str, SensorConfig], batch: bool = False,
                  extra: Sequence[Added] = ()) -> Compiled:
    """`source` (an MJCF path or an MjSpec, which is copied) compiled with the native sensors of `sensors`
    (and, for a batch, the sensors that make MuJoCo fill the on-demand fields the suite reads), then the
    `extra` sensors (a batch's relays, `batch.relay`), last.

    Raises ValueError when MuJoCo cannot read or compile the file itself.
    """
    spec = _spec(source)
    names = native_names(sensors)
    if extra and not names and not batch:  # nothing to resolve against the model as written: one compile
        for added in extra:
            _add(spec, added)
        return spec.compile(), {}
    plain = spec.compile()
    enabled = batch and _enable_on_demand(spec, plain, sensors)
    if not names and not enabled and not extra:
        return plain, {}
    made: dict[str, list[Any]] = {}
    for name in names:
        records = plan_sensor(plain, name, sensors[name], lambda path, message: None)
        if records:
            made[name] = [element for added in records for element in _add(spec, added)]
    for added in extra:
        _add(spec, added)
    refused: dict[str, str] = {}
    while True:
        try:
            return spec.compile(), refused
        except ValueError as e:
            culprit = _ELEMENT.search(str(e))
            if culprit is None or culprit.group(1) not in made:
                raise
            name = culprit.group(1)
            refused[name] = " ".join(str(e).split())
            for element in made.pop(name):
                spec.delete(element)
