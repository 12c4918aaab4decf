"""Resolving element selectors (`joint:knee`, `site:finger_*`, lists of them) against an MjModel.

A single `type:name` selects one element and gives the unbatched shape; a list, or a name with glob
characters, gives the batched shape (list order, then model order within a glob). `within="body:leg"`
keeps only the elements attached to that body's subtree. Name look-ups happen here, once; observables keep
only the resulting ids.
"""

from __future__ import annotations

import dataclasses
import fnmatch
from collections.abc import Sequence
from typing import cast

import mujoco

from .errors import Problem, SuiteError, did_you_mean
from .kinds import ELEMENT_TYPES

__all__ = ["Selection", "select", "split_selector", "element_names"]

_GLOB_CHARS = frozenset("*?[")


@dataclasses.dataclass(frozen=True)
class Selection:
    type: str
    ids: tuple[int, ...]
    names: tuple[str, ...]
    batched: bool


def split_selector(text: object) -> tuple[str, str]:
    """'joint:knee' -> ('joint', 'knee'); raises SuiteError with a hint on malformed input."""
    if not isinstance(text, str) or ":" not in text:
        raise SuiteError(Problem(
            f"element {text!r} must be written 'type:name' (for example 'joint:knee' or 'site:finger_*'); "
            f"types: {', '.join(ELEMENT_TYPES)}"))
    type_name, _, name = text.partition(":")
    type_name = type_name.strip()
    if type_name not in ELEMENT_TYPES:
        raise SuiteError(Problem(
            f"unknown element type {type_name!r}{did_you_mean(type_name, ELEMENT_TYPES)}; "
            f"types: {', '.join(ELEMENT_TYPES)}"))
    if not name:
        raise SuiteError(Problem(f"element {text!r} has no name after '{type_name}:'"))
    return type_name, name


def element_names(model: mujoco.MjModel, type_name: str) -> list[str]:
    """Names of every element of a type, by id ('' for unnamed ones)."""
    et = ELEMENT_TYPES[type_name]
    count = int(getattr(model, et.count, 0))
    return [mujoco.mj_id2name(model, et.obj, i) or "" for i in range(count)]


def _body_of(model: mujoco.MjModel, type_name: str, i: int) -> int | None:
    table = {"joint": "jnt_bodyid", "geom": "geom_bodyid", "site": "site_bodyid",
             "camera": "cam_bodyid", "light": "light_bodyid"}
    if type_name == "body":
        return i
    if type_name in table:
        return int(getattr(model, table[type_name])[i])
    if type_name == "sensor":
        return _object_body(model, int(model.sensor_objtype[i]), int(model.sensor_objid[i]))
    if type_name == "actuator":
        trn = int(model.actuator_trntype[i])
        target = int(model.actuator_trnid[i, 0])
        objtype = {int(mujoco.mjtTrn.mjTRN_JOINT): mujoco.mjtObj.mjOBJ_JOINT,
                   int(mujoco.mjtTrn.mjTRN_SITE): mujoco.mjtObj.mjOBJ_SITE,
                   int(mujoco.mjtTrn.mjTRN_BODY): mujoco.mjtObj.mjOBJ_BODY}.get(trn)
        return None if objtype is None else _object_body(model, int(objtype), target)
    return None


def _object_body(model: mujoco.MjModel, objtype: int, objid: int) -> int | None:
    columns = {int(mujoco.mjtObj.mjOBJ_BODY): None, int(mujoco.mjtObj.mjOBJ_XBODY): None,
               int(mujoco.mjtObj.mjOBJ_JOINT): "jnt_bodyid", int(mujoco.mjtObj.mjOBJ_GEOM): "geom_bodyid",
               int(mujoco.mjtObj.mjOBJ_SITE): "site_bodyid", int(mujoco.mjtObj.mjOBJ_CAMERA): "cam_bodyid"}
    if objtype not in columns or objid < 0:
        return None
    column = columns[objtype]
    return objid if column is None else int(getattr(model, column)[objid])


def _in_subtree(model: mujoco.MjModel, body: int | None, root: int) -> bool:
    while body is not None and body > 0:
        if body == root:
            return True
        body = int(model.body_parentid[body])
    return body == root


def select(model: mujoco.MjModel, element: str | Sequence[str], within: str | None = None) -> Selection:
    """Resolve a selector (or a list of them) to element ids; every mistake is collected."""
    batched = not isinstance(element, str)
    selectors = [element] if isinstance(element, str) else list(element)
    if not selectors:
        raise SuiteError(Problem("an empty element list selects nothing; name at least one element"))
    problems: list[Problem] = []
    types: set[str] = set()
    ids: list[int] = []
    root = None
    if within is not None:
        try:
            wtype, wname = split_selector(within)
            if wtype != "body":
                raise SuiteError(Problem(f"'within' takes a body ('body:name'), got {within!r}"))
            root = _lookup(model, "body", wname)
        except SuiteError as e:
            problems.extend(e.problems)
    for text in selectors:
        try:
            type_name, pattern = split_selector(text)
            types.add(type_name)
            if _GLOB_CHARS & set(pattern):
                batched = True
                names = element_names(model, type_name)
                found = [i for i, n in enumerate(names)
                         if n and fnmatch.fnmatchcase(n, pattern) and not (type_name == "body" and i == 0)]
                if root is not None:
                    found = [i for i in found if _in_subtree(model, _body_of(model, type_name, i), root)]
                if not found:
                    scope = f" under body {cast(str, within).partition(':')[2]!r}" if root is not None else ""
                    known = [n for n in names if n][:12]
                    raise SuiteError(Problem(
                        f"{text!r} matches no {type_name}{scope} in the model; "
                        f"its {_plural(type_name)} are: {', '.join(known) or '(none with names)'}"))
                ids.extend(found)
            else:
                i = _lookup(model, type_name, pattern)
                if root is not None and not _in_subtree(model, _body_of(model, type_name, i), root):
                    raise SuiteError(Problem(f"{text!r} is not in the subtree of {within!r}"))
                ids.append(i)
        except SuiteError as e:
            problems.extend(e.problems)
    if len(types) > 1:
        problems.append(Problem(f"one sensor reads one element type; this list mixes {', '.join(sorted(types))}"))
    if problems:
        raise SuiteError(problems)
    type_name = types.pop()
    chosen = tuple(mujoco.mj_id2name(model, ELEMENT_TYPES[type_name].obj, i) or "" for i in ids)
    return Selection(type_name, tuple(ids), chosen, batched)


def _plural(type_name: str) -> str:
    return "bodies" if type_name == "body" else f"{type_name}s"


def _lookup(model: mujoco.MjModel, type_name: str, name: str) -> int:
    i = mujoco.mj_name2id(model, ELEMENT_TYPES[type_name].obj, name)
    if i < 0:
        names = [n for n in element_names(model, type_name) if n]
        hint = did_you_mean(name, names)
        if not hint:
            hint = f"; its {_plural(type_name)} are: {', '.join(names[:12]) or '(none)'}" + (" ..." if len(names) > 12 else "")
        raise SuiteError(Problem(f"the model has no {type_name} named {name!r}{hint}"))
    return int(i)
