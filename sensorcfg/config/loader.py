"""Files -> one validated suite config: `extends` chains, overrides, validation, `defaults`.

The steps, in order: read and compose the file (positions kept), merge the chain of `extends` (the child
wins key by key; `null` removes an inherited key), apply overrides (`sensors.cam.interval=10`, each value
parsed as YAML and positioned in the override's own text), validate with pydantic, then apply `defaults`
and the cross-field rules (which keys belong to which kinds). Problems are collected, not raised one at a
time. No mujoco here.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

from pydantic import ValidationError

from ..errors import Problem, SuiteError, did_you_mean
from .locate import describe, problem_at, problems_from
from .models import CameraConfig, ScanConfig, SensorConfig, SuiteConfig
from .source import Doc, Path_, Pos, compose, dotted
from .tables import GENERIC_KIND, HEIGHTSCAN_KIND, IMAGE_KINDS, NATIVE_KINDS
from .twins import with_twins

__all__ = ["LoadedSuite", "load_path", "load_text", "resolve_model_path", "PACKAGE_SCHEME"]

PACKAGE_SCHEME = "package://"


@dataclasses.dataclass(frozen=True)
class LoadedSuite:
    """A validated suite: the config as written (merged), the effective sensors, and node positions."""

    config: SuiteConfig
    sensors: dict[str, SensorConfig]  # defaults applied, file order
    doc: Doc
    file: str
    model: str | None  # resolved default model path
    twins: dict[str, str] = dataclasses.field(default_factory=dict)  # twin name -> the sensor it mirrors


# -- reading and `extends` ------------------------------------------------------------------------

def _read(path: Path, label: str, at: Pos | None, loc: str = "") -> str:
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        reason = getattr(e, "strerror", None) or str(e)
        message = f"cannot read {label!r} (resolved to {path}): {reason}"
        if loc == "extends":
            message += "; extends paths are relative to the file that names them"
        raise SuiteError(at.problem(message, loc) if at else Problem(message, file=str(path))) from None


def _display(path: Path) -> str:
    """How a file is named in messages: relative to the working directory when it is below it."""
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _with_parents(doc: Doc, base_dir: Path, chain: tuple[Path, ...]) -> Doc:
    """`doc` merged over the suites it extends (recursively); cycles and bad paths are problems."""
    if not isinstance(doc.value, dict) or "extends" not in doc.value:
        return doc
    target = doc.value.pop("extends")
    at = cast(Pos, doc.pos(("extends",)))  # the key was read from YAML, so it has a position
    if target is None:
        return doc
    if not isinstance(target, str) or not target.strip():
        raise SuiteError(at.problem(f"extends takes a path to another suite, relative to this file; got {target!r}",
                                    "extends"))
    path = (base_dir / target).resolve()
    if path in chain:
        cycle = " -> ".join(_display(p) for p in chain + (path,))
        raise SuiteError(at.problem(f"extends makes a cycle: {cycle}; remove one of these extends", "extends"))
    parent = _with_parents(compose(_read(path, target, at, "extends"), _display(path)), path.parent,
                           chain + (path,))
    if parent.value is not None and not isinstance(parent.value, dict):
        raise SuiteError(at.problem(f"{target!r} is not a suite (its top level is not a mapping)", "extends"))
    return merge(parent, doc)


def merge(parent: Doc, child: Doc) -> Doc:
    """Child over parent: mappings merge key by key, anything else replaces, `null` deletes the key."""
    out = Doc(parent.value, dict(parent.values), dict(parent.keys), parent.problems + child.problems)
    if child.value is None:
        return out
    out.value = _merge_into(out, parent.value, child, child.value, ())
    return out


def _merge_into(out: Doc, old: Any, child: Doc, new: Any, path: Path_) -> Any:
    if isinstance(old, dict) and isinstance(new, dict):
        merged = dict(old)
        for key, value in new.items():
            sub = path + (key,)
            if value is None:
                merged.pop(key, None)
                out.drop(sub)
                out.values.pop(sub, None)
                out.keys.pop(sub, None)
                continue
            merged[key] = _merge_into(out, old.get(key), child, value, sub)
            out.keys[sub] = child.keys[sub]
        if path in child.values and path not in out.values:
            out.values[path] = child.values[path]
        return merged
    out.drop(path)
    for table, source in ((out.values, child.values), (out.keys, child.keys)):
        n = len(path)
        for p, pos in source.items():
            if p[:n] == path and (len(p) > n or table is out.values):
                table[p] = pos
    return new


# -- overrides ------------------------------------------------------------------------------------

def _parse_key(key: str) -> Path_:
    return tuple(int(p) if p.lstrip("-").isdigit() else p for p in key.split("."))


def apply_override(doc: Doc, text: str) -> list[Problem]:
    """Set one `dotted.key=yaml value` in `doc`; the problems it causes point into the override's text."""
    label = f"override '{text}'"
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        return [Problem("an override is written key=value, for example sensors.cam.interval=10 or "
                        "defaults.buffer=2", file=label, line=1, col=1)]
    path = _parse_key(key.strip())
    if path[0] == "extends":
        return [Problem("extends cannot be overridden (overrides apply after the files are merged); "
                        "write a suite that extends the other one instead", "extends", label, 1, 1)]
    try:
        value = compose(raw, label, col_offset=len(key) + 1)
    except SuiteError as e:
        return e.problems
    if not isinstance(doc.value, dict):
        doc.value = {}
    node: Any = doc.value
    for i, part in enumerate(path[:-1]):
        here = path[:i + 1]
        if path[:1] == ("sensors",) and i == 1 and isinstance(node, dict) and part not in node:
            names = list(node)
            return [Problem(f"there is no sensor {part!r} to override{did_you_mean(str(part), names)}; "
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
            return [Problem(f"{dotted(here)} holds {child!r}, which has no key {path[i + 1]!r}",
                            dotted(path), label, 1, 1)]
        node = child
    last = path[-1]
    if isinstance(node, list):
        if not isinstance(last, int) or not -len(node) <= last < len(node):
            return [Problem(f"{dotted(path[:-1])} is a list of {len(node)}; use an index 0..{len(node) - 1}",
                            dotted(path), label, 1, 1)]
        last = last % len(node)
        path = path[:-1] + (last,)
    doc.drop(path)
    if value.value is None and isinstance(node, dict):
        node.pop(last, None)
        return []
    node[last] = value.value
    doc.graft(value, path)
    doc.problems.extend(value.problems)
    doc.keys[path] = Pos(label, 1, 1)
    return []


# -- validation, defaults and the rules between keys -------------------------------------------------

def _is_feature(kind: str) -> bool:
    return kind not in IMAGE_KINDS and kind not in (GENERIC_KIND, HEIGHTSCAN_KIND)


def _is_native(kind: str) -> bool:
    return kind in NATIVE_KINDS


_NATIVE_ONLY = "MuJoCo sensor kinds (velocimeter, framepos, contact, ...)"


# key -> (which kinds may have it, what to call them in a message)
_ONLY_FOR = {
    "element": (lambda k: k != GENERIC_KIND, "sensors that read model elements, not 'generic' ones"),
    "within": (_is_feature, "sensors that read an attribute of model elements"),
    "index": (_is_feature, "sensors that read an attribute of model elements"),
    "camera": (lambda k: k in IMAGE_KINDS, "image sensors (kind rgb, depth or segmentation)"),
    "callable": (lambda k: k == GENERIC_KIND, "kind 'generic'"),
    "frame": (_is_native, _NATIVE_ONLY),
    "with_": (_is_native, _NATIVE_ONLY),
    "data": (_is_native, _NATIVE_ONLY),
    "reduce": (_is_native, _NATIVE_ONLY),
    "num": (_is_native, _NATIVE_ONLY),
    "cutoff": (_is_native, _NATIVE_ONLY),
    "scan": (lambda k: k == HEIGHTSCAN_KIND, f"kind {HEIGHTSCAN_KIND!r}"),
}
# key -> (which kinds need it, an example)
_NEEDS = {
    "element": (lambda k: k != GENERIC_KIND, "element: 'joint:*'"),
    "callable": (lambda k: k == GENERIC_KIND, "callable: 'my_pkg.sensors:distance'"),
}
_IMAGE_EXAMPLE = "element: 'camera:wrist'"


def _effective(name: str, sensor: SensorConfig, config: SuiteConfig, doc: Doc) -> tuple[SensorConfig, list[Problem]]:
    """A sensor with `defaults` filled in, and the problems of keys that do not fit its kind."""
    problems = []
    here = ("sensors", name)
    for key, (allowed, who) in _ONLY_FOR.items():
        if getattr(sensor, key) is not None and not allowed(sensor.kind):
            label = key.rstrip("_")
            problems.append(problem_at(doc, here + (label,), f"{label!r} is only for {who}; this sensor's kind "
                                       f"is {sensor.kind!r}: remove it or change the kind", key=True))
    for key, (needed, example) in _NEEDS.items():
        if getattr(sensor, key) is None and needed(sensor.kind):
            example = _IMAGE_EXAMPLE if sensor.kind in IMAGE_KINDS and key == "element" else example
            problems.append(Problem(f"a sensor of kind {sensor.kind!r} needs {key!r}, for example {example}",
                                    dotted(here + (key,)), *_key_where(doc, here)))
    defaults = config.defaults
    update: dict[str, Any] = {}
    for field in ("interval", "delay", "buffer", "aggregator", "enabled", "noise", "twin"):
        if getattr(sensor, field) is None and getattr(defaults, field) is not None:
            update[field] = getattr(defaults, field)
    if sensor.kind in IMAGE_KINDS:
        update["camera"] = _merge_camera(defaults.camera, sensor.camera)
    if sensor.kind == HEIGHTSCAN_KIND and sensor.scan is None:
        update["scan"] = ScanConfig.model_validate({})
    if update.get("enabled", sensor.enabled) is None:
        update["enabled"] = True
    if update.get("noise", sensor.noise) is None:
        update["noise"] = ()
    return sensor.model_copy(update=update), problems


def _key_where(doc: Doc, path: Path_) -> tuple[str | None, int | None, int | None]:
    pos = doc.pos(path, key=True)
    return (pos.file, pos.line, pos.col) if pos else (None, None, None)


def _merge_camera(default: CameraConfig | None, own: CameraConfig | None) -> CameraConfig:
    """Camera settings field by field: the sensor's own, then `defaults.camera`, then the built-ins."""
    fields: dict[str, Any] = {}
    for source in (default, own):
        if source is not None:
            fields.update({f: getattr(source, f) for f in source.model_fields_set})
    return CameraConfig.model_validate(fields)


def resolve_model_path(value: str, base_dir: Path) -> str:
    """A suite's `model:` as a path: relative to the suite, or inside an installed package."""
    if value.startswith(PACKAGE_SCHEME):
        package, _, inner = value[len(PACKAGE_SCHEME):].partition("/")
        spec = importlib.util.find_spec(package) if package and "." not in package else None
        if spec is None or not spec.submodule_search_locations:
            raise ValueError(f"no installed package {package!r} for {value!r}; write "
                             f"'package://<package>/<path inside it>' or a path relative to this suite")
        return str(Path(list(spec.submodule_search_locations)[0]) / inner)
    return str((base_dir / value).resolve())


def _finish(doc: Doc, file: str, dirs: dict[str, Path], problems: list[Problem]) -> LoadedSuite:
    if doc.value is None:  # an empty file: an empty suite, whose problems are at its start
        doc.value = {}
    value = doc.value
    doc.values.setdefault((), Pos(file, 1, 1))
    if not isinstance(value, dict):
        problems.append(problem_at(doc, (), "a suite is a mapping with keys such as version, model, options, "
                                   f"defaults and sensors; got {describe(value)}", fallback_file=file))
        raise SuiteError(problems)
    problems[:0] = doc.problems
    try:
        config = SuiteConfig.model_validate(value)
    except ValidationError as e:
        found = {(p.file, p.line, p.col) for p in doc.problems}  # a removed node: report it once
        later = [p for p in problems_from(e, doc, SuiteConfig) if (p.file, p.line, p.col) not in found]
        partial = _without_invalid(value, e)
        rest: list[Problem] = []
        loaded = None
        if partial is not None:  # the sensors that passed: their own problems, and a suite to bind them
            try:
                loaded = _finish_valid(SuiteConfig.model_validate(partial), doc, file, dirs, rest)
            except ValidationError:
                loaded = None
            if loaded is not None:  # bind only the sensors with no problem so far
                bad = {p.loc.split(".")[1] for p in rest if p.loc.startswith("sensors.")}
                loaded = dataclasses.replace(loaded, sensors={k: v for k, v in loaded.sensors.items()
                                                              if k not in bad})
        error = SuiteError(_sorted(problems + later + rest))
        error._partial = loaded  # type: ignore[attr-defined]  # read by `sensorcfg.suite.check_file`
        raise error from None
    loaded = _finish_valid(config, doc, file, dirs, problems)
    if problems:
        raise SuiteError(_sorted(problems))
    return loaded


def _without_invalid(value: dict[str, Any], error: ValidationError) -> dict[str, Any] | None:
    """The suite without the sensors (and top-level keys) the schema rejected, or None when the rest
    cannot stand alone (the `sensors` mapping itself is malformed)."""
    sensors_out: set[Any] = set()
    keys_out: set[Any] = set()
    for e in error.errors(include_url=False):
        loc = tuple(e["loc"])
        if len(loc) >= 2 and loc[0] == "sensors":
            sensors_out.add(loc[1])
        elif loc and loc[0] != "sensors":
            keys_out.add(loc[0])
        else:
            return None
    rest = {k: v for k, v in value.items() if k not in keys_out}
    if isinstance(rest.get("sensors"), dict):
        rest["sensors"] = {k: v for k, v in rest["sensors"].items() if k not in sensors_out}
    return rest


def _finish_valid(config: SuiteConfig, doc: Doc, file: str, dirs: dict[str, Path],
                  problems: list[Problem]) -> LoadedSuite:
    """Effective sensors and the model path of a schema-valid suite; their problems go to `problems`."""
    sensors: dict[str, SensorConfig] = {}
    for name, sensor in config.sensors.items():
        sensors[name], found = _effective(name, sensor, config, doc)
        problems.extend(found)
    sensors, twins = with_twins(sensors, doc, problems)
    model = None
    if config.model is not None:
        pos = doc.pos(("model",))
        base = dirs.get(pos.file, Path.cwd()) if pos else Path.cwd()
        try:
            model = resolve_model_path(config.model, base)
        except ValueError as e:
            problems.append(problem_at(doc, ("model",), str(e)))
    return LoadedSuite(config, sensors, doc, file, model, twins)


def _sorted(problems: list[Problem]) -> list[Problem]:
    """In reading order: file by file (in order of appearance), then line and column."""
    files = list(dict.fromkeys(p.file for p in problems))
    return sorted(problems, key=lambda p: (files.index(p.file), p.line or 0, p.col or 0))


def _load(text: str, file: str, base_dir: Path, overrides: Sequence[str] | None,
          top: Path | None) -> LoadedSuite:
    doc = compose(text, file)
    doc = _with_parents(doc, base_dir, (top,) if top else ())
    dirs = {file: base_dir}
    for path in {p.file for p in doc.values.values()}:
        candidate = Path(path)
        dirs.setdefault(path, (candidate if candidate.is_absolute() else Path.cwd() / candidate).parent)
    problems: list[Problem] = []
    for text_ in overrides or ():
        problems.extend(apply_override(doc, text_))
    return _finish(doc, file, dirs, problems)


def load_path(path: str | Path, overrides: Sequence[str] | None = None) -> LoadedSuite:
    """Read, merge, override and validate the suite at `path`."""
    resolved = Path(path).resolve()
    file = _display(resolved)
    return _load(_read(resolved, str(path), None), file, resolved.parent, overrides, resolved)


def load_text(text: str, overrides: Sequence[str] | None = None, *, file: str = "<string>",
              base_dir: str | os.PathLike[str] | None = None) -> LoadedSuite:
    """Validate a suite given as text; `extends` and `model` are relative to `base_dir` (default: cwd)."""
    return _load(text, file, Path(base_dir) if base_dir else Path.cwd(), overrides, None)
