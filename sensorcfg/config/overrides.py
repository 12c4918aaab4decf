"""Overrides: `dotted.key=value` strings applied to a merged suite before it is validated.

Each value is parsed as YAML, by the rules a suite's files are read with (`source.compose`: YAML 1.2, so
`std=1e-3` is a number), and positioned in the override's own text (`override 'KEY=VALUE':1:COL`), so
its mistakes are reported like a file's. `null` removes a key; an index into a list is written with ASCII
digits (`sensors.arm.noise.0.std=0.01`). A value that cannot be read (invalid YAML, a disallowed tag) is
reported and changes nothing.
"""

from __future__ import annotations

import dataclasses
import json
import math
import numbers
import re
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import ArgumentError, Problem, SuiteError, did_you_mean, quote
from .limits import MAX_DEPTH, MAX_OVERRIDE_BYTES
from .source import Doc, Path_, Pos, compose, dotted

__all__ = ["apply_override", "override_texts", "parse_key", "with_model"]

_INDEX = re.compile(r"-?[0-9]{1,9}")  # ASCII digits only: int() would also read '١' or '²'-like digits
_LABEL_LIMIT = 80


def with_model(overrides: Sequence[str] | None, model: object) -> list[str] | None:
    """The overrides a suite is loaded with when the caller names its model (--model, an environment's
    `model`): the suite's own `model:` line is dropped, not resolved (a `menagerie://` line offline, or a
    file that is not on this machine, would otherwise stop a suite that runs on the model given)."""
    return [*(overrides or ()), "model=null"] if model is not None else (list(overrides) if overrides else None)


def override_texts(overrides: Sequence[str] | Mapping[str, Any]) -> list[str]:
    """Overrides as `dotted.key=value` texts: a list of them as it is, a mapping of dotted keys to Python
    values (`{"defaults.buffer": 2, "sensors.s.delay": {"uniform": [1, 3]}}`) written as YAML that reads back
    as the same values, so their mistakes are reported in the override's text like a written one's.
    ArgumentError for what is neither."""
    if isinstance(overrides, Mapping):
        texts = []
        for key, value in overrides.items():
            if not isinstance(key, str) or not key.strip() or "=" in key:
                raise ArgumentError(f"an overrides mapping's keys are dotted keys such as 'defaults.buffer' (no "
                                    f"'='); got {quote(key)}")
            texts.append(f"{key}={_yaml(value, key, 0)}")
        return texts
    if isinstance(overrides, str) or not isinstance(overrides, Sequence) or not all(isinstance(o, str)
                                                                                    for o in overrides):
        raise ArgumentError("overrides is a list of 'dotted.key=value' strings, for example ['defaults.buffer=2'], "
                            f"or a mapping of dotted keys to values, {{'defaults.buffer': 2}}; got {quote(overrides)}")
    return list(overrides)


def _yaml(value: Any, key: str, depth: int) -> str:
    """`value` as YAML flow text that `compose` reads back as `value` (strings always quoted, so '1e-3' stays
    text); ArgumentError for a value YAML cannot hold."""
    if depth > MAX_DEPTH:
        raise ArgumentError(f"overrides[{quote(key)}] nests more than {MAX_DEPTH} levels deep (or contains itself)")
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a YAML double-quoted scalar
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        number = float(value)
        return (".nan" if math.isnan(number) else ("-.inf" if number < 0 else ".inf") if math.isinf(number)
                else repr(number))
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{_yaml(k, key, depth + 1)}: {_yaml(v, key, depth + 1)}"
                               for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml(v, key, depth + 1) for v in value) + "]"
    raise ArgumentError(f"overrides[{quote(key)}] is of type {type(value).__name__}; an override's value is what "
                        "YAML holds: None, a bool, a number, a str, or a list or dict of them")


def parse_key(key: str) -> Path_:
    """'sensors.arm.noise.0' -> ('sensors', 'arm', 'noise', 0)."""
    return tuple(int(p) if _INDEX.fullmatch(p) else p for p in key.split("."))


def _label(text: str) -> str:
    shown = text if len(text) <= _LABEL_LIMIT else text[:_LABEL_LIMIT] + "..."
    return f"override '{shown}'"


def apply_override(doc: Doc, text: str) -> list[Problem]:
    """Set one `dotted.key=yaml value` in `doc`; the problems it causes point into the override's text."""
    label = _label(text)
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        return [Problem("an override is written key=value, for example sensors.cam.interval=10 or "
                        "defaults.buffer=2", file=label, line=1, col=1)]
    if len(text) > MAX_OVERRIDE_BYTES:
        return [Problem(f"an override may be at most {MAX_OVERRIDE_BYTES:,} characters; this one has {len(text):,}",
                        file=label, line=1, col=1)]
    path = parse_key(key.strip())
    if len(path) > MAX_DEPTH:
        return [Problem(f"the key nests {len(path)} levels deep; a suite nests at most {MAX_DEPTH}",
                        file=label, line=1, col=1)]
    if path[0] == "extends":
        return [Problem("extends cannot be overridden (overrides apply after the files are merged); "
                        "write a suite that extends the other one instead", "extends", label, 1, 1)]
    try:
        value = compose(raw, label, col_offset=len(key) + 1)
    except SuiteError as e:
        return e.problems
    if value.problems:  # a disallowed tag or a duplicate key: say so rather than apply what is left
        return [dataclasses.replace(p, loc=dotted(path) + (f".{p.loc}" if p.loc else "")) for p in value.problems]
    found = _parent(doc, path, label)
    if isinstance(found, list):
        return found
    node, path = found
    last = path[-1]
    doc.drop(path)
    if value.value is None and isinstance(node, dict):
        node.pop(last, None)
        return []
    node[last] = value.value
    doc.graft(value, path)
    doc.keys[path] = Pos(label, 1, 1)
    return []


def _parent(doc: Doc, path: Path_, label: str) -> tuple[Any, Path_] | list[Problem]:
    """The container that holds the last key of `path` (made when missing), and `path` with a list index
    made non-negative; or the problem that prevents it."""
    if not isinstance(doc.value, dict):
        doc.value = {}
    node: Any = doc.value
    for i, part in enumerate(path[:-1]):
        here = path[:i + 1]
        if path[:1] == ("sensors",) and i == 1 and isinstance(node, dict) and part not in node:
            names = list(node)
            return [Problem(f"there is no sensor {quote(part)} to override{did_you_mean(str(part), names)}; "
                            f"sensors: {', '.join(names) or '(none)'}", dotted(here), label, 1, 1)]
        child = node.get(part) if isinstance(node, dict) else (
            node[part] if isinstance(node, list) and isinstance(part, int) and -len(node) <= part < len(node) else None)
        if child is None and isinstance(node, dict) and isinstance(part, str):
            child = node[part] = {}
            doc.keys[here] = doc.values[here] = Pos(label, 1, 1)
        if isinstance(node, list) and child is None:
            return [Problem(f"{dotted(path[:i])} is a list of {len(node)}; use an index 0..{len(node) - 1}",
                            dotted(path), label, 1, 1)]
        if not isinstance(child, (dict, list)):
            return [Problem(f"{dotted(here)} holds {quote(child)}, which has no key {quote(path[i + 1])}",
                            dotted(path), label, 1, 1)]
        node = child
    last = path[-1]
    if isinstance(node, list):
        if not isinstance(last, int) or not -len(node) <= last < len(node):
            return [Problem(f"{dotted(path[:-1])} is a list of {len(node)}; use an index 0..{len(node) - 1}",
                            dotted(path), label, 1, 1)]
        path = path[:-1] + (last % len(node),)
    return node, path
