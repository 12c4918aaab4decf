"""Resolving element selectors (`joint:knee`, `site:finger_*`, lists of them) against an MjModel.

A single `type:name` selects one element and gives the unbatched shape; a list, or a name with glob
characters, gives the batched shape (list order, then model order within a glob). `type:#3` selects by id,
wherever a name is accepted. Unnamed elements are labelled `#<id>`, and a glob matches labels, so
`joint:*` is every joint, named or not (an unnamed free joint included), as dm_control's `find_all` is.
`within="body:leg"` (or a list of bodies) keeps only the elements attached to those bodies' subtrees.
Name look-ups happen here, once; observables keep only the resulting ids.
"""

from __future__ import annotations

import dataclasses
import fnmatch
from collections.abc import Sequence
from typing import Any, cast

import mujoco

from .errors import Problem, SuiteError, did_you_mean
from .kinds import ELEMENT_TYPES

__all__ = ["Selection", "select", "split_selector", "element_names", "element_labels", "keyframe_id", "ID_PREFIX"]

ID_PREFIX = "#"  # `joint:#0`: an element by id; also the label of an unnamed element

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


def element_labels(model: mujoco.MjModel, type_name: str) -> list[str]:
    """Every element's label, by id: its name, or `#<id>` when it has none."""
    return [n or f"{ID_PREFIX}{i}" for i, n in enumerate(element_names(model, type_name))]


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


def select(model: mujoco.MjModel, element: str | Sequence[str],
           within: str | Sequence[str] | None = None) -> Selection:
    """Resolve a selector (or a list of them) to element ids; every mistake is collected."""
    batched = not isinstance(element, str)
    selectors = [element] if isinstance(element, str) else list(element)
    if not selectors:
        raise SuiteError(Problem("an empty element list selects nothing; name at least one element"))
    problems: list[Problem] = []
    types: set[str] = set()
    ids: list[int] = []
    roots: list[int] | None = None
    if within is not None:
        roots = []
        for text in [within] if isinstance(within, str) else list(within):
            try:
                wtype, wname = split_selector(text)
                if wtype != "body":
                    raise SuiteError(Problem(f"'within' takes bodies ('body:name'), got {text!r}"))
                roots.append(_lookup(model, "body", wname))
            except SuiteError as e:
                problems.extend(e.problems)
    bodies = [] if within is None else [w.partition(":")[2] for w in ([within] if isinstance(within, str) else within)]
    scope = f" under {'body' if len(bodies) == 1 else 'bodies'} {', '.join(map(repr, bodies))}" if bodies else ""
    for text in selectors:
        try:
            type_name, pattern = split_selector(text)
            types.add(type_name)
            if _GLOB_CHARS & set(pattern):
                batched = True
                labels = element_labels(model, type_name)
                found = [i for i, label in enumerate(labels)
                         if fnmatch.fnmatchcase(label, pattern) and not (type_name == "body" and i == 0)]
                if roots is not None:
                    found = [i for i in found if _in_any(model, _body_of(model, type_name, i), roots)]
                if not found:
                    known = [n for n in element_names(model, type_name) if n][:12]
                    raise SuiteError(Problem(
                        f"{text!r} matches no {type_name}{scope} in the model; "
                        f"its {_plural(type_name)} are: {', '.join(known) or '(none with names)'}"))
                ids.extend(found)
            else:
                i = _lookup(model, type_name, pattern)
                if roots is not None and not _in_any(model, _body_of(model, type_name, i), roots):
                    raise SuiteError(Problem(f"{text!r} is not in the subtree of {cast(Any, within)!r}"))
                ids.append(i)
        except SuiteError as e:
            problems.extend(e.problems)
    if len(types) > 1:
        problems.append(Problem(f"one sensor reads one element type; this list mixes {', '.join(sorted(types))}"))
    if problems:
        raise SuiteError(problems)
    type_name = types.pop()
    labels = element_labels(model, type_name)
    return Selection(type_name, tuple(ids), tuple(labels[i] for i in ids), batched)


def _in_any(model: mujoco.MjModel, body: int | None, roots: list[int]) -> bool:
    return any(_in_subtree(model, body, root) for root in roots)


_NOUNS = {"key": "keyframe"}  # element types whose suite name is not the word a message uses


def _plural(type_name: str) -> str:
    return {"body": "bodies", "key": "keyframes"}.get(type_name, f"{type_name}s")


def _lookup(model: mujoco.MjModel, type_name: str, name: str) -> int:
    """The id of the element named `name`, or given as `#<id>`."""
    et = ELEMENT_TYPES[type_name]
    if name.startswith(ID_PREFIX):
        count = int(getattr(model, et.count, 0))
        text = name[len(ID_PREFIX):]
        if not text.isdigit() or int(text) >= count:
            raise SuiteError(Problem(f"{type_name}:{name} is not a {type_name} id: the model's {_plural(type_name)} "
                                     f"are #0 to #{count - 1}" if count else f"the model has no {_plural(type_name)}"))
        return int(text)
    i = mujoco.mj_name2id(model, et.obj, name)
    if i < 0:
        names = [n for n in element_names(model, type_name) if n]
        hint = did_you_mean(name, names)
        if not hint:
            hint = f"; its {_plural(type_name)} are: {', '.join(names[:12]) or '(none)'}" + (" ..." if len(names) > 12 else "")
            unnamed = sum(1 for n in element_names(model, type_name) if not n)
            if unnamed:
                hint += f" ({unnamed} unnamed: select them by id, '{type_name}:{ID_PREFIX}<id>', or with a glob)"
        raise SuiteError(Problem(f"the model has no {_NOUNS.get(type_name, type_name)} named {name!r}{hint}"))
    return int(i)


def keyframe_id(model: mujoco.MjModel, keyframe: int | str) -> int:
    """The index of a keyframe given by name (with "did you mean") or index (checked against `nkey`)."""
    if isinstance(keyframe, str):
        return _lookup(model, "key", keyframe)
    if isinstance(keyframe, bool) or not isinstance(keyframe, int) or not 0 <= keyframe < model.nkey:
        count = f"keyframes 0 to {model.nkey - 1}" if model.nkey else "no keyframes"
        raise SuiteError(Problem(f"keyframe {keyframe!r} is out of range: the model has {count}"))
    return int(keyframe)
