"""Which MuJoCo sensors (and sites) a suite's native kinds add to a model: resolved, checked, positioned.

`sensor_additions` resolves one suite sensor against a model (the plain robot, or one that already carries
the suite's sensors: resolution is the same, since only sensors and sites are added) into `Added` records,
one per selected element, reporting every mistake at the key it is about. `sensorcfg.native.compile`
writes the records into an `MjSpec`; `sensorcfg.native.bind` reads them back from the compiled model.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import mujoco

from ..config.models import SensorConfig
from ..errors import SuiteError, did_you_mean
from ..kinds import ELEMENT_TYPES, kinds_of
from ..selection import ADDED_PREFIX, MAX_HINTS, Selection, select, split_selector
from . import gravity
from .table import NATIVE, OBJ, REDUCE, Added, NativeType, available, data_fields

__all__ = ["native_row", "sensor_additions", "sensor_name"]

Report = Callable[[tuple[Any, ...], str], None]  # (path in the suite, message)




def sensor_name(suite_sensor: str, i: int) -> str:
    """The model name of the MuJoCo sensor a suite sensor adds for its i-th element."""
    return f"{ADDED_PREFIX}{suite_sensor}:{i}"


def native_row(kind: str, type_name: str | None) -> NativeType | None:
    """The native type a kind means on an element type; None where the element type has that attribute
    (the element type decides: an actuator's `force` is `actuator_force`) or the kind is not native."""
    row = NATIVE.get(kind)
    if row is None or (type_name is not None and kind in kinds_of(type_name)):
        return None
    return row


def _a(word: str) -> str:
    return "an" if word[0] in "aeiou" else "a"


def _one(model: mujoco.MjModel, text: str, allowed: tuple[str, ...], what: str) -> tuple[str, str]:
    """(element type, name) of a `frame:` / `with:` that names one element of an allowed type."""
    type_name, _ = split_selector(text)
    if type_name not in allowed:
        raise SuiteError(f"{what} takes {' or '.join(t + ':<name>' for t in allowed)}; got {text!r}")
    sel = select(model, text)
    if sel.batched:
        raise SuiteError(f"{what} names one element; {text!r} is a pattern")
    name = _name(model, type_name, sel.ids[0])
    if not name:
        raise SuiteError(f"{text!r} has no name in the model; MuJoCo's sensors refer to elements by name: name it "
                         "in the model")
    return type_name, name


def _mask(kind: str, data: tuple[str, ...], report: Report, here: tuple[Any, ...]) -> int | None:
    fields = data_fields(kind)
    if not fields:
        report(here + ("data",), f"this MuJoCo ({mujoco.__version__}) has no `data` fields for {kind}")
        return None
    bad = [(i, d) for i, d in enumerate(data) if d not in fields]
    for n, (i, d) in enumerate(bad):
        hint = did_you_mean(d, fields) if n < MAX_HINTS else ""
        report(here + ("data", i), f"{kind} has no data field {d!r}{hint}; fields: {', '.join(fields)}")
    if bad:
        return None
    if len(set(data)) != len(data) or list(data) != sorted(data, key=fields.index):
        report(here + ("data",), f"list each data field once, in MuJoCo's order (the order of the values): "
               f"{', '.join(sorted(set(data), key=fields.index))}")
        return None
    return sum(1 << fields.index(d) for d in data)


def _intprm(row: NativeType, cfg: SensorConfig, report: Report, here: tuple[Any, ...]) -> tuple[int, int, int] | None:
    """MuJoCo's intprm from `data`, `reduce`, `num`; a key the type does not take is a problem."""
    ok = True
    for key in ("data", "reduce", "num", "cutoff"):
        if getattr(cfg, key) is not None and key not in row.options:
            takes = f"; {row.kind} takes {', '.join(row.options)}" if row.options else ""
            report(here + (key,), f"{key!r} is not an option of {row.kind}{takes}")
            ok = False
    mask = 0
    if cfg.data is not None:
        found = _mask(row.kind, cfg.data, report, here)
        ok = ok and found is not None
        mask = found or 0
    elif "data" in row.options:
        mask = 1  # MuJoCo's default: the first field (contact: found; rangefinder: dist)
    reduce = REDUCE.get(cfg.reduce or "none")
    if reduce is None:
        report(here + ("reduce",), f"reduce is one of {', '.join(REDUCE)}; got {cfg.reduce!r}"
               f"{did_you_mean(str(cfg.reduce), REDUCE)}")
        ok = False
    if not ok:
        return None
    num = (cfg.num or 1) if row.kind == "contact" else 0
    return (mask, reduce or 0, num)


def _objects(model: mujoco.MjModel, row: NativeType, sel: Selection, name: str) -> list[tuple[str, str, int | None]]:
    """(objtype, objname, id of the body to add a site to) per selected element."""
    out: list[tuple[str, str, int | None]] = []
    for i, (element_id, element_name) in enumerate(zip(sel.ids, sel.names)):
        if sel.type == "body" and row.body_site:  # the site sensorcfg adds has a name, named body or not
            out.append(("SITE", sensor_name(name, i), element_id))
        elif sel.type == "body":
            out.append((row.body_obj, _name(model, "body", element_id), None))
        elif row.kind == "tactile":
            mesh = int(model.geom_dataid[element_id]) if int(model.geom_type[element_id]) == int(
                mujoco.mjtGeom.mjGEOM_MESH) else -1
            if mesh < 0:
                raise SuiteError(f"tactile reads a mesh geom; {element_name!r} is not one")
            if not _name(model, "geom", element_id):
                raise SuiteError(f"MuJoCo's sensors refer to elements by name; geom {element_name} of this selection "
                                 "has none: name it in the model")
            out.append(("MESH", mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MESH, mesh) or "", None))
        else:
            out.append((OBJ[sel.type], _name(model, sel.type, element_id), None))
    unnamed = [sel.names[i] for i, (_, objname, body) in enumerate(out) if body is None and not objname]
    if unnamed:
        raise SuiteError(f"MuJoCo's sensors refer to elements by name; {sel.type} {unnamed[0]} of this selection "
                         "has none: name it in the model")
    return out


def _name(model: mujoco.MjModel, type_name: str, i: int) -> str:
    """An element's name in the model ('' when it has none; the world body is 'world')."""
    return "world" if type_name == "body" and i == 0 else (
        mujoco.mj_id2name(model, ELEMENT_TYPES[type_name].obj, i) or "")


_JOINT_WORDS = {int(getattr(mujoco.mjtJoint, f"mjJNT_{t}")): t.lower() for t in ("FREE", "BALL", "SLIDE", "HINGE")}


# MuJoCo 3.x computes no acceleration (`cacc`) for a body welded to the world: an accelerometer or framelinacc
# there reads 0, where MuJoCo 4 and MuJoCo Warp read the body's acceleration minus gravity (+9.81 up at rest)
_WELDED_ZERO = frozenset({"accelerometer", "framelinacc"})
_BODY_OF = {"site": "site_bodyid", "geom": "geom_bodyid", "camera": "cam_bodyid"}


def _welded_zero(model: mujoco.MjModel, row: NativeType, sel: Selection) -> str | None:
    """An acceleration sensor on a body welded to the world, on a MuJoCo that reads it as 0."""
    if row.kind not in _WELDED_ZERO or int(mujoco.__version__.split(".")[0]) >= 4:
        return None
    bodies = getattr(model, _BODY_OF[sel.type]) if sel.type in _BODY_OF else None
    welded = [f"{sel.type}:{label}" for i, label in zip(sel.ids, sel.names)
              if model.body_weldid[int(bodies[i]) if bodies is not None else i] == 0]
    if not welded:
        return None
    more = f" (and {len(welded) - 3} more)" if len(welded) > 3 else ""
    return (f"MuJoCo {mujoco.__version__} reads {_a(row.kind)} {row.kind} sensor on a body welded to the world as 0 "
            f"(MuJoCo 4 and MuJoCo Warp read its acceleration minus gravity, +9.81 up at rest): "
            f"{', '.join(welded[:3])}{more}; mount it on a moving body, or use MuJoCo >= 4")


def _refusals(model: mujoco.MjModel, row: NativeType, sel: Selection) -> str | None:
    """What MuJoCo's compiler would refuse about the selected joints or tendons (`NativeType.joint_types`,
    `limited`), or what this MuJoCo would read wrong (`_welded_zero`), said for the suite: None when nothing."""
    welded = _welded_zero(model, row, sel)
    if welded:
        return welded
    bad: list[str] = []
    need = ""
    if sel.type == "joint" and row.joint_types:
        allowed = {int(getattr(mujoco.mjtJoint, f"mjJNT_{t}")) for t in row.joint_types}
        need = " or ".join(t.lower() for t in row.joint_types) + " joint"
        bad = [f"{label} is a {_JOINT_WORDS.get(int(model.jnt_type[i]), '?')} joint"
               for i, label in zip(sel.ids, sel.names) if int(model.jnt_type[i]) not in allowed]
    if not bad and row.limited and sel.type in ("joint", "tendon"):
        limited = model.jnt_limited if sel.type == "joint" else model.tendon_limited
        need = f"limited {sel.type}"
        bad = [f"{label} has no limits" for i, label in zip(sel.ids, sel.names) if not limited[i]]
    if not bad:
        return None
    more = f" (and {len(bad) - 3} more)" if len(bad) > 3 else ""
    return f"{_a(row.kind)} {row.kind} sensor reads {_a(need)} {need}; {', '.join(bad[:3])}{more}"


def sensor_additions(model: mujoco.MjModel, name: str, cfg: SensorConfig, report: Report) -> list[Added] | None:
    """The sensors suite sensor `name` adds, or None after reporting why it cannot."""
    here: tuple[Any, ...] = ("sensors", name)
    first = cfg.element if isinstance(cfg.element, str) else (cfg.element or ("",))[0]
    try:
        type_name = split_selector(first)[0]
    except SuiteError as e:
        for p in e.problems:
            report(here + ("element",), p.message)
        return None
    row = NATIVE[cfg.kind]
    if not available(row):
        report(here + ("kind",), f"this MuJoCo ({mujoco.__version__}) has no {cfg.kind} sensor "
               f"(mjSENS_{row.sensor}); upgrade MuJoCo or use another kind")
        return None
    if type_name not in row.objects:
        report(here + ("element",), f"{_a(cfg.kind)} {cfg.kind} sensor reads "
               f"{' or '.join(t + ':<name>' for t in row.objects)}; got {first!r}")
        return None
    ok = True
    ref: tuple[str | None, str | None] = (None, None)
    for key, allowed, required in (("frame", (row.frame and ("body", "geom", "site", "camera")) or (), False),
                                   ("with_", row.with_, row.with_required)):
        value = getattr(cfg, key)
        label = key.rstrip("_")
        if value is None:
            if required:
                report(here + ("kind",), f"{_a(cfg.kind)} {cfg.kind} sensor needs `{label}:`, one of "
                       f"{' or '.join(t + ':<name>' for t in allowed)}")
                ok = False
            continue
        if not allowed:
            report(here + (label,), f"{_a(cfg.kind)} {cfg.kind} sensor takes no `{label}:`")
            ok = False
            continue
        try:
            ref_type, ref_name = _one(model, value, cast(tuple[str, ...], allowed), label)
        except SuiteError as e:
            for p in e.problems:
                report(here + (label,), p.message)
            ok = False
            continue
        body_ref = "BODY" if row.kind in ("contact", "geomdist", "geomnormal", "geomfromto") else "XBODY"
        ref = (body_ref if ref_type == "body" else OBJ[ref_type], ref_name)
    intprm = _intprm(row, cfg, report, here)
    try:
        sel = select(model, cast("str | tuple[str, ...]", cfg.element), cfg.within)
        refusal = _refusals(model, row, sel)
        if refusal is not None:
            raise SuiteError(refusal)
        objects = _objects(model, row, sel, name)
    except SuiteError as e:
        for p in e.problems:
            report(here + ("element",), p.message)
        return None
    same = [sel.names[i] for i, (objtype, objname, _) in enumerate(objects) if (objtype, objname) == ref]
    if same and row.with_required and "geom" in row.with_:
        report(here + ("with",), f"{_a(row.kind)} {row.kind} sensor measures between two objects; "
               f"{same[0]!r} is both the element and `with:`: name another")
        return None
    if not ok or intprm is None:
        return None
    cutoff = float(cfg.cutoff) if cfg.cutoff is not None else (10.0 if "cutoff" in row.options else 0.0)
    refs = [("GEOM", _name(model, "geom", i)) if row.kind == "tactile" else ref for i in sel.ids]
    records = [Added(sensor_name(name, i), row.sensor, objtype, objname, refs[i][0], refs[i][1], intprm, cutoff, body)
               for i, (objtype, objname, body) in enumerate(objects)]
    return gravity.along_gravity(model, records, report, here) if row.kind == gravity.KIND else records
