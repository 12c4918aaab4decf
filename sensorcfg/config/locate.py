"""Pydantic validation errors -> `Problem`s at the YAML node they are about, with the fix spelled out.

Pydantic reports a `loc` such as `('sensors', 'cam', 'noise', 0, 'gaussian', 'std')`. It is walked along the
plain value that was validated, dropping segments that are not in the file (union tags), so it names a
node whose position the `Doc` recorded. Messages say what was expected, what was found and, for names,
offer "did you mean" from the model's own fields.
"""

from __future__ import annotations

import re
import types
import typing
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

from ..errors import Problem, did_you_mean, quote
from .source import Doc, Path_, dotted

__all__ = ["problems_from", "normalize", "model_at", "problem_at", "too_many"]

# pydantic error type -> what was expected (used as "expected X; got Y")
_EXPECTED = {
    "int_type": "an integer", "int_parsing": "an integer", "int_from_float": "a whole number",
    "float_type": "a number", "float_parsing": "a number", "bool_type": "true or false",
    "bool_parsing": "true or false", "string_type": "a string", "dict_type": "a mapping (key: value lines)",
    "model_type": "a mapping (key: value lines)", "model_attributes_type": "a mapping (key: value lines)",
    "tuple_type": "a list", "list_type": "a list", "none_required": "null",
}
# field name -> the form a string must have (for pattern errors)
_FORMS = {
    "kind": "a kind is a name such as 'qpos', 'sensordata', 'rgb' or 'generic'",
    "within": "within takes a body selector, 'body:name' (for example 'body:forearm')",
    "callable": "a callable is written 'module:function' (for example 'my_pkg.sensors:distance')",
    "[key]": "a {} name starts with a letter or '_' and holds letters, digits, '_', '-' or '/' "
             "(no dots or spaces: names appear in dotted paths)",
}

# field -> other words for its choices (what "did you mean" offers when the spelling is not close)
_SYNONYMS = {"aggregator": {"average": "mean", "avg": "mean", "mean_value": "mean", "maximum": "max",
                            "minimum": "min", "med": "median", "total": "sum", "add": "sum"}}

# key -> what its upper bound means (limits.py holds the numbers)
_AT_MOST = {"buffer": "a buffer keeps at most {:,} samples (the latest delivered ones)"}
_ITEMS = {"sensors": "sensors in a suite"}

# key -> what to write when it is missing
_MISSING = {
    "sensors": ": a suite lists its sensors as 'name: {kind: ..., element: ...}' under 'sensors:'",
    "kind": " (what to read, for example kind: qpos, kind: sensordata or kind: rgb)",
}


def normalize(loc: tuple[Any, ...], value: Any) -> tuple[Path_, bool]:
    """The path of the node `loc` is about, and whether it is about a mapping key."""
    out: list[str | int] = []
    node = value
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        if part == "[key]":
            return tuple(out), True
        if isinstance(node, dict):
            if part in node:
                out.append(part)
                node = node[part]
            elif last:
                out.append(part)
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            out.append(part)
            node = node[part]
    return tuple(out), False


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """BaseModel classes inside an annotation (through Optional, Annotated, tuple, dict, unions)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    found: list[type[BaseModel]] = []
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is typing.Annotated:
        args = args[:1]
    if origin in (dict,):
        args = args[1:]
    for arg in args:
        found.extend(_models_in(arg))
    return found


def model_at(root: type[BaseModel], path: Path_, value: Any) -> type[BaseModel] | None:
    """The config class that validates the mapping at `path` (None when it is not a config)."""
    models: list[type[BaseModel]] = [root]
    node = value
    in_container = False  # the previous field was a dict or tuple: this segment is a key or an index
    for part in path:
        if in_container:
            in_container = False
        else:
            model = _pick(models, node)
            if model is None:
                return None
            names = {f.alias or n: n for n, f in model.model_fields.items()}
            if part not in names:
                return None
            annotation = model.model_fields[names[part]].annotation
            models = _models_in(annotation)
            in_container = _is_container(annotation)
            if not models:
                return None
        node = _child(node, part)
    return None if in_container else _pick(models, node)


def _child(node: Any, part: str | int) -> Any:
    if isinstance(node, dict):
        return node.get(part)
    if isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
        return node[part]
    return None


def _is_container(annotation: Any) -> bool:
    """Whether the field holds models inside a dict or a tuple/list (not a model directly)."""
    origin = typing.get_origin(annotation)
    if origin in (dict, tuple, list):
        return True
    args = typing.get_args(annotation)
    if origin is typing.Annotated:
        return _is_container(args[0])
    if origin in (typing.Union, types.UnionType):
        return any(_is_container(a) for a in args)
    return False


def _pick(models: list[type[BaseModel]], node: Any) -> type[BaseModel] | None:
    """Of several candidate configs (a tagged union), the one whose `type` matches the node."""
    if len(models) == 1:
        return models[0]
    if isinstance(node, dict):
        for model in models:
            field = model.model_fields.get("type")
            if field is not None and node.get("type") in typing.get_args(field.annotation):
                return model
    return None


def problem_at(doc: Doc, path: Path_, message: str, *, key: bool = False, fallback_file: str | None = None) -> Problem:
    pos = doc.pos(path, key=key)
    if pos is None:
        return Problem(message, dotted(path), fallback_file)
    return pos.problem(message, dotted(path))


def _message(error: ErrorDetails, path: Path_, root: type[BaseModel], value: Any) -> str:
    kind = error["type"]
    ctx = error.get("ctx") or {}
    given = error.get("input")
    name = path[-1] if path else ""
    if _fixed_length(error):
        return _wrong_length(root, path, value)
    if kind == "missing":
        return f"missing required key {quote(name)}{_MISSING.get(str(name), '')}"
    if kind == "extra_forbidden":
        model = model_at(root, path[:-1], value)
        fields = [f.alias or n for n, f in model.model_fields.items()] if model else []
        allowed = f"; allowed keys: {', '.join(fields)}" if fields else ""
        return f"unknown key {quote(name)}{did_you_mean(str(name), fields)}{allowed}"
    if kind == "value_error":
        return str(ctx.get("error", error["msg"]))
    if kind == "literal_error":
        choices = re.findall(r"'([^']*)'", str(ctx.get("expected", ""))) or re.findall(r"\d+", str(ctx.get("expected")))
        label = {"aggregator": "aggregator", "version": "version"}.get(str(name), "value")
        synonym = _SYNONYMS.get(str(name), {}).get(str(given).strip().lower())
        hint = f" (did you mean {quote(synonym)}?)" if synonym in choices else did_you_mean(str(given), choices)
        return f"unknown {label} {quote(given)}{hint}; use one of: {', '.join(choices)}"
    if kind == "string_pattern_mismatch":
        form = _FORMS.get(str(name), f"expected text matching {ctx.get('pattern')!r}")
        return f"{form}; got {quote(given)}"
    if kind == "too_long":
        count = len(given) if isinstance(given, (dict, list)) else ctx.get("actual_length")
        return too_many(str(name), ctx.get("max_length"), count)
    if kind == "less_than_equal" and str(name) in _AT_MOST:
        return f"{_AT_MOST[str(name)].format(next(iter(ctx.values()), '?'))}; got {quote(given)}"
    if kind in ("greater_than_equal", "greater_than", "less_than_equal", "less_than"):
        op = {"greater_than_equal": ">=", "greater_than": ">", "less_than_equal": "<=", "less_than": "<"}[kind]
        bound = next(iter(ctx.values()), "?")
        return f"expected a value {op} {bound}; got {quote(given)}"
    if kind in _EXPECTED:
        return f"expected {_EXPECTED[kind]}; got {describe(given)}"
    if str(error["msg"]).startswith("Input should"):
        return f"{error['msg']}; got {describe(given)}"
    return str(error["msg"])  # a custom error (noise stages) already says what it found


def too_many(name: str, most: Any, count: Any) -> str:
    """The problem of a mapping or list `name` with `count` entries, past its `most`."""
    return f"at most {most} {_ITEMS.get(name, 'entries')}; got {count}"


def _fixed_length(error: ErrorDetails) -> bool:
    """Whether `error` is about a fixed-length list (a tuple field) with too few or too many entries."""
    loc = error["loc"]
    return (error["type"] == "missing" and bool(loc) and isinstance(loc[-1], int)) or (
        error["type"] == "too_long" and (error.get("ctx") or {}).get("field_type") == "Tuple")


def _wrong_length(root: type[BaseModel], path: Path_, value: Any) -> str:
    """A fixed-length list with too few or too many entries: how many it takes, of what, and what it has."""
    model = model_at(root, path[:-1], value)
    field = model.model_fields.get(str(path[-1])) if model and path else None
    items = typing.get_args(field.annotation) if field else ()
    if items and items[-1] is Ellipsis:
        items = ()
    items = tuple(typing.get_args(a)[0] if typing.get_origin(a) is typing.Annotated else a for a in items)
    what = "numbers" if items and all(a in (int, float) for a in items) else "values"
    found = _child(_at(value, path[:-1]), path[-1]) if path else None
    count = f"{len(found)}" if isinstance(found, list) else describe(found)
    name = path[-1] if path else "the list"
    return (f"{name} takes {len(items) or 'more'} {what}; got {count}"
            f"{f': {quote(found, 60)}' if isinstance(found, list) else ''}")


def describe(value: Any) -> str:
    """A found value, as messages name it."""
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return f"the text {quote(value)}"
    if value is None:
        return "null (an empty value)"
    return repr(value)


def problems_from(error: ValidationError, doc: Doc, root: type[BaseModel], prefix: Path_ = ()) -> list[Problem]:
    """One Problem per pydantic error, positioned at its node in `doc` (whose value sits at `prefix`).

    Unknown keys and bad sensor names point at the key; a missing key points at the key of the mapping
    that lacks it; everything else points at the value.
    """
    out = []
    value = _at(doc.value, prefix)
    for e in error.errors(include_url=False):
        path, is_key = normalize(tuple(e["loc"]), value)
        if is_key:
            named = "camera" if (prefix + path)[:1] == ("cameras",) else "sensor"  # the mapping the key names
            message = f"{_FORMS['[key]'].format(named)}; got {quote(path[-1])}" if path else e["msg"]
            out.append(problem_at(doc, prefix + path, message, key=True))
            continue
        message = _message(e, path, root, value)
        if _fixed_length(e):  # at the list; `size: []` misses two entries but is one mistake
            if not out or out[-1].message != message or out[-1].loc != dotted(prefix + path):
                out.append(problem_at(doc, prefix + path, message))
        elif e["type"] == "missing":
            pos = doc.pos(prefix + path[:-1], key=True)
            out.append(Problem(message, dotted(prefix + path), *((pos.file, pos.line, pos.col) if pos else ())))
        else:
            out.append(problem_at(doc, prefix + path, message, key=e["type"] == "extra_forbidden"))
    return out


def _at(value: Any, path: Path_) -> Any:
    for part in path:
        value = value[part]
    return value
