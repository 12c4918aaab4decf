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
from collections.abc import Mapping
from typing import Any

import mujoco

from ..config.models import SensorConfig
from ..errors import SuiteError
from ..selection import split_selector
from .plan import Added, native_row, plan_sensor

__all__ = ["Compiled", "compile_model", "native_names"]

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
        made.append(body.add_site(name=added.name))
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


def compile_model(source: Any, sensors: Mapping[str, SensorConfig]) -> Compiled:
    """`source` (an MJCF path or an MjSpec, which is copied) compiled with the native sensors of `sensors`.

    Raises ValueError when MuJoCo cannot read or compile the file itself.
    """
    spec = _spec(source)
    plain = spec.compile()
    names = native_names(sensors)
    if not names:
        return plain, {}
    made: dict[str, list[Any]] = {}
    for name in names:
        records = plan_sensor(plain, name, sensors[name], lambda path, message: None)
        if records:
            made[name] = [element for added in records for element in _add(spec, added)]
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
