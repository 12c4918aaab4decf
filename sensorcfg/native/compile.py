"""A model compiled with a suite's native sensors: MJCF (or an MjSpec) -> MjSpec + sensors -> MjModel.

The robot file is not edited: it is read into an `MjSpec`, compiled once as written (to resolve the
suite's selectors), given one MuJoCo sensor per selected element of each native kind (and a site at a
body's frame where the type reads a site), and compiled again. What MuJoCo's compiler requires of a
sensor's objects is checked before (`additions`), so a refusal is rare; one is left out and its message kept
for the suite's line, at most `MAX_REFUSALS` of them found one compile each, then every sensor not yet
compiled is left out too (each compile costs as much as the robot's own): the compiles of one model are
bounded whatever the suite. A sensor whose own options do not resolve is left out (binding reports it).
Every element added is named with `selection.ADDED_PREFIX` (invisible to a suite's selectors), and added
in a fixed order (a batch's enablers by flag, the suite's sensors in its order, then `extra` as given), so
the compiled model is the same in every process.
Sensors and sites change no dynamics: the compiled model steps exactly as the file's own. Nor do they
change what a camera sees: every site is added by `_hidden_site`, in `HIDDEN_GROUP` with alpha 0 (MuJoCo's
scene skips a site whose alpha is 0 whichever groups a viewer shows; MuJoCo Warp's renderer draws no
sites), and the lines MuJoCo's scene draws for some sensors (a rangefinder's ray) are left out of
sensorcfg's CPU cameras for the sensors added here (`observables.camera`).
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
from ..selection import ADDED_PREFIX, split_selector
from .additions import native_row, sensor_additions
from .table import Added

__all__ = ["Compiled", "HIDDEN_GROUP", "add_native", "compile_model", "native_names", "reads_on_demand",
           "MAX_REFUSALS", "NOT_COMPILED"]

Compiled = tuple[mujoco.MjModel, dict[str, str]]  # the model, and the problem of each suite sensor left out
_ELEMENT = re.compile(re.escape(ADDED_PREFIX) + r"([A-Za-z_][A-Za-z0-9_\-/]*):\d+\b")  # `additions.sensor_name`
MAX_REFUSALS = 8  # refusals found one compile each; then the sensors not yet compiled are left out
HIDDEN_GROUP = 5  # the group of the sites sensorcfg adds: MuJoCo's last, which no viewer shows by default
NOT_COMPILED = ("the {kind} sensor was not compiled: MuJoCo refused {count} other sensors of this suite first "
                "(each costs a compile of the model); fix those and validate again")


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


def _bodies(spec: mujoco.MjSpec) -> dict[int, Any]:
    """The spec's bodies by id, read just after a compile (an edit resets the ids): a body with no name is
    found too."""
    return {int(body.id): body for body in spec.bodies}


def _hidden_site(body: Any, name: str, quat: Sequence[float] | None = None) -> Any:
    """A site at `body`'s frame (turned by `quat`) that nothing draws: in `HIDDEN_GROUP`, with alpha 0.
    Every site sensorcfg adds to a model is made here."""
    site = body.add_site(name=name, group=HIDDEN_GROUP, rgba=[0.0, 0.0, 0.0, 0.0])
    if quat is not None:
        site.quat = list(quat)
    return site


def _add(spec: mujoco.MjSpec, added: Added, bodies: dict[int, Any]) -> list[Any]:
    """Write one record into the spec; the elements created (to delete them if MuJoCo refuses)."""
    made = []
    if added.site_body is not None:
        made.append(_hidden_site(bodies[added.site_body], added.name, added.site_quat))
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
    read = {ON_DEMAND[cfg.kind].flag: ON_DEMAND[cfg.kind] for cfg in sensors.values() if cfg.kind in ON_DEMAND}
    for flag in sorted(read):  # (a set's order would change from one process to the next)
        if computed_by_model(plain, read[flag]):
            continue
        sensor_type, objtype = _ENABLERS[flag]
        name = f"{ADDED_PREFIX}on-demand:{flag}"
        objname = "world"
        if objtype == "SITE":
            objname = _hidden_site(spec.worldbody, name).name
        spec.add_sensor(name=name, type=_enum(mujoco.mjtSensor, "mjSENS_", sensor_type),
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
    return add_native(_spec(source), sensors, batch, extra)


def add_native(spec: mujoco.MjSpec, sensors: Mapping[str, SensorConfig], batch: bool = False,
               extra: Sequence[Added] = ()) -> Compiled:
    """`compile_model` on `spec` itself: its additions are left in it (a framework's scene that compiles it
    again, mjlab's), those MuJoCo refused taken out."""
    names = native_names(sensors)
    if extra and not names and not batch:  # nothing to resolve against the model as written: one compile
        for added in extra:
            _add(spec, added, {})
        return spec.compile(), {}
    plain = spec.compile()
    bodies = _bodies(spec)
    enabled = batch and _enable_on_demand(spec, plain, sensors)
    if not names and not enabled and not extra:
        return plain, {}
    made: dict[str, list[Any]] = {}
    for name in names:
        records = sensor_additions(plain, name, sensors[name], lambda path, message: None)
        if records:
            made[name] = [element for added in records for element in _add(spec, added, bodies)]
    for added in extra:
        _add(spec, added, bodies)
    return _compile_refusing(spec, made, {name: sensors[name].kind for name in made})


def _compile_refusing(spec: mujoco.MjSpec, made: dict[str, list[Any]], kinds: Mapping[str, str]) -> Compiled:
    """The spec compiled, leaving out each suite sensor MuJoCo refuses (its elements in `made`, by suite
    sensor) with the message for its line; after `MAX_REFUSALS`, every suite sensor left is left out."""
    refused: dict[str, str] = {}
    while True:
        try:
            return spec.compile(), refused
        except ValueError as e:
            culprit = _ELEMENT.search(str(e))
            if culprit is None or culprit.group(1) not in made:
                raise
            name = culprit.group(1)
            refused[name] = f"MuJoCo refused the {kinds[name]} sensor: {' '.join(str(e).split())}"
            out = [name]
            if len(refused) >= MAX_REFUSALS:
                out += [n for n in made if n != name]
                refused.update({n: NOT_COMPILED.format(kind=kinds[n], count=len(refused)) for n in out[1:]})
            for n in out:
                for element in made.pop(n):
                    spec.delete(element)
