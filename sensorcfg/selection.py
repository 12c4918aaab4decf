"""Resolving element selectors (`joint:knee`, `site:finger_*`, lists of them) against an MjModel.

A single `type:name` selects one element and gives the unbatched shape; a list, or a name with glob
characters, gives the batched shape (list order, then model order within a glob). `type:#3` selects by id,
wherever a name is accepted. Unnamed elements are labelled `#<id>`, and a glob matches labels, so
`joint:*` is every joint, named or not (an unnamed free joint included), as dm_control's `find_all` is.
`within="body:leg"` (or a list of bodies) keeps only the elements attached to those bodies' subtrees.
Name look-ups happen here, once; observables keep only the resulting ids.

The sensors and sites sensorcfg adds to a model (a suite's MuJoCo sensor kinds, a batch's relays and the
sensors that make MuJoCo fill on-demand fields) are named with `ADDED_PREFIX`, and selection does not see
them: globs do not match them, name lists and "did you mean" leave them out, and ids count the model's own
elements only (`site:#3` is the file's fourth site, whatever sites were added), so a suite reads the same
elements whichever sensors it, or a batch, adds. A suite that names one exactly is told the name is reserved
(a batch's helpers exist in a batch only); only sensorcfg's own features (`Feature`) name them.

A list is resolved in one pass: each type's names and labels are read once, and `within`'s bodies looked
up once, so a list of n entries costs O(n) look-ups (did-you-mean hints, each a scan of the model's
names, are given to the first `MAX_HINTS` misses).
"""

from __future__ import annotations

import dataclasses
import fnmatch
from collections.abc import Sequence
from typing import NamedTuple

import mujoco

from .config.tables import GLOB_CHARS
from .errors import Problem, SuiteError, did_you_mean
from .kinds import ELEMENT_TYPES, read_type

__all__ = ["Selection", "Resolved", "select", "resolve", "split_selector", "element_labels", "keyframe_id",
           "element_id", "ascii_id", "within_problems", "added_by_sensorcfg", "ID_PREFIX", "ADDED_PREFIX"]

ID_PREFIX = "#"  # `joint:#0`: an element by id; also the label of an unnamed element
ADDED_PREFIX = "sensorcfg:"  # the start of the name of every element sensorcfg adds to a model
MAX_HINTS = 20  # misses of one resolution that get a "did you mean" (each scans the model's names)


def added_by_sensorcfg(name: str) -> bool:
    """Whether a model element of this name is one sensorcfg added (invisible to selection)."""
    return name.startswith(ADDED_PREFIX)


def ascii_id(text: str) -> int | None:
    """The integer an id written in ASCII digits stands for ('12' -> 12), else None ('²', '-1', '1.0', '')."""
    return int(text) if text.isascii() and text.isdigit() else None


@dataclasses.dataclass(frozen=True)
class Selection:
    type: str
    ids: tuple[int, ...]
    names: tuple[str, ...]  # labels, for messages and element lists: the name, or `#<k>` for an unnamed one
    batched: bool


Where = tuple[str | int, ...]  # a problem's place below the sensor: ("element", 3), ("within",), ...


class Resolved(NamedTuple):
    """A selection, or None with every problem found, each with the key (and list entry) it is about."""

    selection: Selection | None
    problems: list[tuple[Where, Problem]]


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


@dataclasses.dataclass(frozen=True)
class _Elements:
    """The elements of one type that a suite sees: the model's own, in id order (position k is `#k`)."""

    ids: tuple[int, ...]  # the compiled model's ids
    names: tuple[str, ...]  # '' for an unnamed element

    @property
    def labels(self) -> list[str]:
        return [n or f"{ID_PREFIX}{k}" for k, n in enumerate(self.names)]

    @property
    def named(self) -> list[str]:
        return [n for n in self.names if n]


def _elements(model: mujoco.MjModel, type_name: str) -> _Elements:
    et = ELEMENT_TYPES[type_name]
    pairs = [(i, mujoco.mj_id2name(model, et.obj, i) or "") for i in range(int(getattr(model, et.count, 0)))]
    own = [(i, n) for i, n in pairs if not added_by_sensorcfg(n)]
    return _Elements(tuple(i for i, _ in own), tuple(n for _, n in own))


def element_labels(model: mujoco.MjModel, type_name: str) -> dict[int, str]:
    """The label of each of the model's own elements (sensorcfg's left out), keyed by its id in `model`: its
    name, or `#<k>` for the k-th of the model's own when it has none (as a selector names it). Keyed, not
    listed: where sensorcfg added elements, a compiled id is not a position in the model's own list."""
    elements = _elements(model, type_name)
    return dict(zip(elements.ids, elements.labels))


_NOUNS = {"key": "keyframe"}  # element types whose suite name is not the word a message uses


def _plural(type_name: str) -> str:
    return {"body": "bodies", "key": "keyframes"}.get(type_name, f"{type_name}s")


class _Resolver:
    """One resolution's look-ups: each type's elements read once, hints given to the first misses."""

    def __init__(self, model: mujoco.MjModel, added: bool = False):
        self.model = model
        self.added = added  # whether names sensorcfg adds may be looked up (its own features' selectors)
        self._elements: dict[str, _Elements] = {}
        self._positions: dict[str, dict[int, int]] = {}
        self.hints = MAX_HINTS

    def elements(self, type_name: str) -> _Elements:
        if type_name not in self._elements:
            self._elements[type_name] = _elements(self.model, type_name)
        return self._elements[type_name]

    def label(self, type_name: str, i: int) -> str:
        """The label of compiled id `i`: its name, or `#<its position among the model's own>`."""
        if type_name not in self._positions:
            self._positions[type_name] = {j: k for k, j in enumerate(self.elements(type_name).ids)}
        k = self._positions[type_name].get(i)
        name = mujoco.mj_id2name(self.model, ELEMENT_TYPES[type_name].obj, i) or ""
        return name or (f"{ID_PREFIX}{k}" if k is not None else "")

    def lookup(self, type_name: str, name: str) -> int:
        """The compiled id of the element named `name`, or given as `#<id>`."""
        et = ELEMENT_TYPES[type_name]
        if name.startswith(ID_PREFIX):
            own = self.elements(type_name).ids
            k = ascii_id(name[len(ID_PREFIX):])
            if k is None or k >= len(own):
                raise SuiteError(Problem(
                    f"{type_name}:{name} is not a {_NOUNS.get(type_name, type_name)} id: the model's "
                    f"{_plural(type_name)} are #0 to "
                    f"#{len(own) - 1}" if own else f"the model has no {_plural(type_name)}"))
            return own[k]
        if added_by_sensorcfg(name) and not self.added:
            raise SuiteError(Problem(
                f"names starting with {ADDED_PREFIX!r} are reserved for the {_plural(type_name)} sensorcfg adds to a "
                f"model (a suite's MuJoCo sensor kinds, a batch's helpers), which a suite does not select: read "
                f"the model's own {_plural(type_name)}, or the suite sensor that adds it"))
        i = int(mujoco.mj_name2id(self.model, et.obj, name))
        if i >= 0:
            return i
        elements = self.elements(type_name)
        names = elements.named
        hint = ""
        if self.hints > 0:
            self.hints -= 1
            hint = did_you_mean(name, names)
        if not hint:
            hint = (f"; its {_plural(type_name)} are: {', '.join(names[:12]) or '(none)'}"
                    + (" ..." if len(names) > 12 else ""))
            unnamed = len(elements.names) - len(names)
            if unnamed:
                hint += f" ({unnamed} unnamed: select them by id, '{type_name}:{ID_PREFIX}<id>', or with a glob)"
        raise SuiteError(Problem(f"the model has no {_NOUNS.get(type_name, type_name)} named {name!r}{hint}"))

    def glob(self, type_name: str, pattern: str) -> list[int]:
        elements = self.elements(type_name)
        return [i for i, label in zip(elements.ids, elements.labels)
                if fnmatch.fnmatchcase(label, pattern) and not (type_name == "body" and i == 0)]


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
                   int(mujoco.mjtTrn.mjTRN_JOINTINPARENT): mujoco.mjtObj.mjOBJ_JOINT,
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


_JOINT_TRANSMISSIONS = frozenset({int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)})


def _driven_joints(r: _Resolver, actuators: list[int], kind: str) -> list[int]:
    """The joint each actuator's transmission drives, in the actuators' order (`kinds.read_type`); an
    actuator that drives something else (a tendon, a site, a body) is a mistake naming what it drives."""
    model = r.model
    joints, others = [], []
    for i in actuators:
        if int(model.actuator_trntype[i]) in _JOINT_TRANSMISSIONS:
            joints.append(int(model.actuator_trnid[i, 0]))
        else:
            trn = mujoco.mjtTrn(int(model.actuator_trntype[i])).name.removeprefix("mjTRN_").lower()
            others.append(f"{r.label('actuator', i)!r} drives a {trn}")
    if others:
        raise SuiteError(Problem(
            f"kind {kind!r} on actuators reads the joint each actuator drives, but {', '.join(others[:6])}"
            f"{' ...' if len(others) > 6 else ''}, not a joint: select joints ('joint:<name>') for this kind, "
            "or read the actuators' own attributes (ctrl, force, length, velocity)"))
    return joints


def _in_subtree(model: mujoco.MjModel, body: int | None, roots: frozenset[int]) -> bool:
    """Whether `body` is one of `roots` or below one (the world, 0, is the root of every body)."""
    while body is not None and body > 0:
        if body in roots:
            return True
        body = int(model.body_parentid[body])
    return body is not None and body in roots


def _entries(value: str | Sequence[str], key: str) -> list[tuple[str, Where]]:
    if isinstance(value, str):
        return [(value, (key,))]
    return [(v, (key, i)) for i, v in enumerate(value)]


def _roots(r: _Resolver,
           within: str | Sequence[str] | None) -> tuple[frozenset[int] | None, list[tuple[Where, Problem]]]:
    """The bodies `within` names (None without one), and its problems."""
    if within is None:
        return None, []
    found: set[int] = set()
    problems: list[tuple[Where, Problem]] = []
    for text, where in _entries(within, "within"):
        try:
            wtype, wname = split_selector(text)
            if wtype != "body":
                raise SuiteError(Problem(f"'within' takes bodies ('body:name'), got {text!r}"))
            found.add(r.lookup("body", wname))
        except SuiteError as e:
            problems += [(where, p) for p in e.problems]
    return frozenset(found), problems


def within_problems(model: mujoco.MjModel, within: str | Sequence[str] | None) -> list[tuple[Where, Problem]]:
    """The mistakes of a `within` alone, each at its entry (`("within", i)`)."""
    return _roots(_Resolver(model), within)[1]


def resolve(model: mujoco.MjModel, element: str | Sequence[str],
            within: str | Sequence[str] | None = None, *, added: bool = False, kind: str | None = None) -> Resolved:
    """Resolve a selector (or a list of them) to element ids, with every mistake at the entry it is about
    (`("element", i)`, `("within", i)`; `("element",)` for one selector or the whole list). A mistake in
    `within` is reported alone (its elements are not looked at). With `added`, names sensorcfg adds may be
    named exactly (its own features). With the `kind` read, actuators selected for a joint attribute are
    the joints they drive (`kinds.read_type`): the selection's type is then `joint`, in actuator order."""
    r = _Resolver(model, added)
    roots, problems = _roots(r, within)
    if problems:
        return Resolved(None, problems)
    entries = _entries(element, "element")
    if not entries:
        return Resolved(None, [(("element",),
                                Problem("an empty element list selects nothing; name at least one element"))])
    bodies = [] if within is None else [text.partition(":")[2] for text, _ in _entries(within, "within")]
    scope = f" under {'body' if len(bodies) == 1 else 'bodies'} {', '.join(map(repr, bodies))}" if bodies else ""
    batched = not isinstance(element, str)
    types: set[str] = set()
    ids: list[int] = []
    labels: list[str] = []
    for text, where in entries:
        try:
            type_name, pattern = split_selector(text)
            types.add(type_name if kind is None else read_type(type_name, kind))
            if GLOB_CHARS & set(pattern):
                batched = True
                matched = r.glob(type_name, pattern)
                if roots is not None:
                    matched = [i for i in matched if _in_subtree(model, _body_of(model, type_name, i), roots)]
                if not matched:
                    own = r.elements(type_name)
                    known = ", ".join(own.named[:12]) or ("(none with names)" if own.ids else "(none)")
                    raise SuiteError(Problem(f"{text!r} matches no {type_name}{scope} in the model; "
                                             f"its {_plural(type_name)} are: {known}"))
            else:
                matched = [r.lookup(type_name, pattern)]
                if roots is not None and not _in_subtree(model, _body_of(model, type_name, matched[0]), roots):
                    shown = within if isinstance(within, str) else list(within or ())
                    raise SuiteError(Problem(f"{text!r} is not in the subtree of {shown!r}"))
            read = type_name if kind is None else read_type(type_name, kind)
            if read != type_name:
                matched = _driven_joints(r, matched, kind or "")
            ids += matched
            labels += [r.label(read, i) for i in matched]
        except SuiteError as e:
            problems += [(where, p) for p in e.problems]
    if len(types) > 1:
        problems.append((("element",), Problem(
            f"one sensor reads one element type; this list mixes {', '.join(sorted(types))}")))
    if problems:
        return Resolved(None, problems)
    return Resolved(Selection(types.pop(), tuple(ids), tuple(labels), batched), [])


def select(model: mujoco.MjModel, element: str | Sequence[str],
           within: str | Sequence[str] | None = None, *, added: bool = False, kind: str | None = None) -> Selection:
    """Resolve a selector (or a list of them) to element ids; raises SuiteError listing every mistake."""
    resolved = resolve(model, element, within, added=added, kind=kind)
    if resolved.selection is None:
        raise SuiteError([p for _, p in resolved.problems])
    return resolved.selection


def element_id(model: mujoco.MjModel, type_name: str, name: str) -> int:
    """The compiled id of one element given by name or `#<id>` (as in a selector), or SuiteError."""
    return _Resolver(model).lookup(type_name, name)


def keyframe_id(model: mujoco.MjModel, keyframe: int | str) -> int:
    """The index of a keyframe given by name (with "did you mean") or index (checked against `nkey`)."""
    if isinstance(keyframe, str):
        return element_id(model, "key", keyframe)
    if isinstance(keyframe, bool) or not isinstance(keyframe, int) or not 0 <= keyframe < model.nkey:
        count = f"keyframes 0 to {model.nkey - 1}" if model.nkey else "no keyframes"
        raise SuiteError(Problem(f"keyframe {keyframe!r} is out of range: the model has {count}"))
    return int(keyframe)
