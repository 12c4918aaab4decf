"""Overrides: `dotted.key=value` strings applied to a merged suite before it is validated.

Each value is parsed as YAML, by the rules a suite's files are read with (`source.compose`: YAML 1.2, so
`std=1e-3` is a number), and positioned in the override's own text (`override 'KEY=VALUE':1:COL`), so
its mistakes are reported like a file's. `null` removes a key; an index into a list is written with ASCII
digits (`sensors.arm.noise.0.std=0.01`). A value that cannot be read (invalid YAML, a disallowed tag) is
reported and changes nothing.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from typing import Any

from ..errors import Problem, SuiteError, did_you_mean, quote
from .limits import MAX_DEPTH, MAX_OVERRIDE_BYTES
from .source import Doc, Path_, Pos, compose, dotted

__all__ = ["apply_override", "parse_key", "with_model"]

_INDEX = re.compile(r"-?[0-9]{1,9}")  # ASCII digits only: int() would also read '١' or '²'-like digits
_LABEL_LIMIT = 80


def with_model(overrides: Sequence[str] | None, model: object) -> list[str] | None:
    """The overrides a suite is loaded with when the caller names its model (--model, an environment's
    `model`): the suite's own `model:` line is dropped, not resolved (a `menagerie://` line offline, or a
    file that is not on this machine, would otherwise stop a suite that runs on the model given)."""
    return [*(overrides or ()), "model=null"] if model is not None else (list(overrides) if overrides else None)


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
