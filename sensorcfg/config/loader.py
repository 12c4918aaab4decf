"""Files -> one validated suite config, as a `LoadResult`: the suite (whole, or the part that stands) and
every problem found.

The steps, each in its own module: read and compose the file, positions kept (`files`, `source`); merge
the chain of `extends` (`extends`); apply overrides (`overrides`); validate with pydantic (`models`,
problems positioned by `locate`); then fill in `defaults` and check the rules between keys (`rules`).
Problems are collected, not raised one at a time. No mujoco here.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from pydantic_core import ErrorDetails

from ..errors import ArgumentError, Problem, SuiteError, quote
from .extends import with_parents
from .files import PACKAGE_SCHEME, Unreadable, display, read_text, resolve, resolve_model_path
from .groups import resolve_groups
from .limits import MAX_SENSORS
from .locate import describe, problem_at, problems_from, too_many
from .models import SensorConfig, SuiteConfig
from .overrides import apply_override
from .rules import effective
from .source import Doc, Pos, compose
from .twins import with_twins

__all__ = ["LoadedSuite", "LoadResult", "load_path", "load_text", "parse_path", "parse_text", "resolve_model_path",
           "PACKAGE_SCHEME"]


@dataclasses.dataclass(frozen=True)
class LoadedSuite:
    """A validated suite: the config as written (merged), the effective sensors, and node positions."""

    config: SuiteConfig
    sensors: dict[str, SensorConfig]  # defaults applied, file order
    doc: Doc
    file: str
    model: str | None  # resolved default model path
    twins: dict[str, str] = dataclasses.field(default_factory=dict)  # twin name -> the sensor it mirrors
    groups: dict[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)  # group -> its observations, in order


@dataclasses.dataclass(frozen=True)
class LoadResult:
    """What loading found: every problem, and the suite.

    With no problems, `suite` is the whole suite. With problems, it holds the sensors that have none (so
    they can still be checked against a model), or is None when nothing stands on its own (invalid YAML,
    a top level that is not a mapping, a malformed `sensors`).
    """

    suite: LoadedSuite | None
    problems: tuple[Problem, ...] = ()
    unreadable: str | None = None  # why the suite's own file could not be read (then `problems` says so too)

    @property
    def ok(self) -> bool:
        return not self.problems

    def unwrap(self) -> LoadedSuite:
        """The whole suite, or SuiteError listing every problem."""
        if self.problems or self.suite is None:
            raise SuiteError(list(self.problems))
        return self.suite


def _sorted(problems: Sequence[Problem]) -> tuple[Problem, ...]:
    """In reading order: file by file (in order of appearance), then line and column."""
    files = list(dict.fromkeys(p.file for p in problems))
    return tuple(sorted(problems, key=lambda p: (files.index(p.file), p.line or 0, p.col or 0)))


# key -> the keys whose rules read it: when the schema rejects the key (or an unknown key that names it,
# `buffers:`), those keys cannot be judged either (an aggregator is checked against the buffer), so they are
# left out of the partial suite rather than reported against a value the user did not write
_JUDGED_WITH: dict[str, tuple[str, ...]] = {"buffer": ("aggregator",)}
_SENSOR_KEYS = tuple(f.alias or n for n, f in SensorConfig.model_fields.items())


def _rejected_key(error: ErrorDetails) -> Any:
    """The key a sensor- or defaults-level error rejects: an unknown key close to a known one (`buffers`)
    stands for that key."""
    key = error["loc"][2] if error["loc"][0] == "sensors" else error["loc"][1]
    if error["type"] == "extra_forbidden" and isinstance(key, str):
        close = difflib.get_close_matches(key, _SENSOR_KEYS, n=1, cutoff=0.8)
        return close[0] if close else key
    return key


def _without_invalid(value: dict[str, Any], error: ValidationError, whole_sensors: bool) -> dict[str, Any] | None:
    """The suite without what the schema rejected: each sensor's rejected keys (or, with `whole_sensors`,
    those sensors) and rejected top-level keys (of `defaults`, only the rejected ones), and the keys judged
    with a rejected one (`_JUDGED_WITH`); None when the rest cannot stand alone (the `sensors` mapping itself
    is malformed). Keeping a sensor's valid keys lets binding report its model mistakes in the same pass as
    its schema mistakes."""
    sensors_out: set[Any] = set()
    sensor_keys_out: dict[Any, set[Any]] = {}
    defaults_out: set[Any] = set()
    cameras_out: set[Any] = set()
    keys_out: set[Any] = set()
    for e in error.errors(include_url=False):
        loc = tuple(e["loc"])
        if len(loc) >= 3 and loc[0] == "sensors" and not whole_sensors and e["type"] != "missing":
            sensor_keys_out.setdefault(loc[1], set()).update((loc[2], *_JUDGED_WITH.get(_rejected_key(e), ())))
        elif len(loc) >= 2 and loc[0] == "sensors":
            sensors_out.add(loc[1])
        elif len(loc) >= 2 and loc[0] == "cameras" and isinstance(value.get("cameras"), dict):
            cameras_out.add(loc[1])
        elif len(loc) >= 2 and loc[0] == "defaults" and isinstance(value.get("defaults"), dict):
            defaults_out.update((loc[1], *_JUDGED_WITH.get(_rejected_key(e), ())))
        elif loc and loc[0] != "sensors":
            keys_out.add(loc[0])
        else:
            return None
    rest = {k: v for k, v in value.items() if k not in keys_out}
    if cameras_out:  # the suite's other cameras are mounted; a sensor reading a rejected one cannot be judged
        rest["cameras"] = {k: v for k, v in rest["cameras"].items() if k not in cameras_out}
        if isinstance(rest.get("sensors"), dict):
            sensors_out.update(k for k, v in rest["sensors"].items() if _reads_camera(v, cameras_out))
    if defaults_out:
        rest["defaults"] = {k: v for k, v in rest["defaults"].items() if k not in defaults_out}
    if isinstance(rest.get("sensors"), dict):
        rest["sensors"] = {k: ({kk: vv for kk, vv in v.items() if kk not in sensor_keys_out.get(k, ())
                                and not _judged_with_default(kk, v, defaults_out)}
                               if isinstance(v, dict) else v)
                           for k, v in rest["sensors"].items() if k not in sensors_out}
    return rest


def _reads_camera(sensor: Any, cameras: set[Any]) -> bool:
    """Whether a sensor's `element` names one of `cameras` ('camera:<name>', alone or in a list)."""
    element = sensor.get("element") if isinstance(sensor, dict) else None
    entries = element if isinstance(element, list) else [element]
    return any(isinstance(e, str) and e.strip().startswith("camera:") and e.strip()[len("camera:"):] in cameras
               for e in entries)


def _judged_with_default(key: str, sensor: dict[str, Any], rejected: set[Any]) -> bool:
    """Whether a sensor's `key` is judged with a default the schema rejected that the sensor does not set
    itself (its aggregator, with a rejected `defaults.buffer` and no buffer of its own)."""
    return any(key in _JUDGED_WITH.get(default, ()) and default not in sensor for default in rejected)


def _left_out(value: Any, loc: str) -> bool:
    """Whether the node at dotted `loc` was left out for its problem (source.py: its value is None)."""
    node = value
    for part in loc.split("."):
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.isascii() and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return False
    return node is None


def _complete(config: SuiteConfig, doc: Doc, file: str, dirs: dict[str, Path], root: Path | None
              ) -> tuple[LoadedSuite, list[Problem]]:
    """Effective sensors and the model path of a schema-valid suite (inside `root`, see `files`), and the
    problems of the rules."""
    sensors: dict[str, SensorConfig] = {}
    problems: list[Problem] = []
    for name, sensor in config.sensors.items():
        sensors[name], found = effective(name, sensor, config, doc)
        problems.extend(found)
    sensors, twins = with_twins(sensors, doc, problems)
    written = doc.value.get("sensors") if isinstance(doc.value, dict) else None  # a sensor left out has its own problem
    groups = resolve_groups(config.groups, sensors, doc, problems, set(written) if isinstance(written, dict) else set())
    model = None
    if config.model is not None:
        pos = doc.pos(("model",))
        base = dirs.get(pos.file, Path.cwd()) if pos else Path.cwd()
        try:
            model = resolve_model_path(config.model, base, root)
        except ValueError as e:
            problems.append(problem_at(doc, ("model",), str(e)))
    return LoadedSuite(config, sensors, doc, file, model, twins, groups), problems


def _partial(value: dict[str, Any], error: ValidationError, doc: Doc, file: str, dirs: dict[str, Path],
             root: Path | None, dropped: set[str]) -> tuple[LoadedSuite | None, list[Problem]]:
    """What passed the schema, with its own problems and without any sensor that has one: first each sensor
    without its rejected keys (so a model mistake is found in the same pass as a schema mistake), else
    without the sensors the schema rejected. `dropped`: the locations the schema already reported."""
    for whole in (False, True):
        rest = _without_invalid(value, error, whole_sensors=whole)
        if rest is None:
            return None, []
        try:
            loaded, problems = _complete(SuiteConfig.model_validate(rest), doc, file, dirs, root)
        except ValidationError:
            continue
        problems = [p for p in problems if p.loc not in dropped]  # a dropped key is reported once
        bad = {p.loc.split(".")[1] for p in problems if p.loc.startswith("sensors.")}
        return dataclasses.replace(loaded, sensors={k: v for k, v in loaded.sensors.items() if k not in bad}), problems
    return None, []


def _validate(doc: Doc, file: str, dirs: dict[str, Path], root: Path | None, problems: list[Problem]) -> LoadResult:
    if doc.value is None:  # an empty file: an empty suite, whose problems are at its start
        doc.value = {}
    value = doc.value
    doc.values.setdefault((), Pos(file, 1, 1))
    if not isinstance(value, dict):
        problems.append(problem_at(doc, (), "a suite is a mapping with keys such as version, model, options, "
                                   f"defaults and sensors; got {describe(value)}", fallback_file=file))
        return LoadResult(None, _sorted(problems))
    problems[:0] = doc.problems
    sensors = value.get("sensors")
    if isinstance(sensors, dict) and len(sensors) > MAX_SENSORS:  # before any sensor is validated: one problem
        return LoadResult(None, (problem_at(doc, ("sensors",), too_many("sensors", MAX_SENSORS, len(sensors))),))
    try:
        config = SuiteConfig.model_validate(value)
    except ValidationError as e:
        # a node left out for its own problem is reported once: not again where it is missing, nor as a flaw
        # of the mapping that held it (a model's rule between its keys, `gaussian takes std or density`)
        found = {(p.file, p.line, p.col) for p in doc.problems}
        holders = {p.loc.rpartition(".")[0] for p in doc.problems if "." in p.loc and _left_out(value, p.loc)}
        later = [p for p in problems_from(e, doc, SuiteConfig)
                 if (p.file, p.line, p.col) not in found and p.loc not in holders]
        partial, rest = _partial(value, e, doc, file, dirs, root, {p.loc for p in later})
        return LoadResult(partial, _sorted(problems + later + rest))
    loaded, rest = _complete(config, doc, file, dirs, root)
    problems += rest
    return LoadResult(None, _sorted(problems)) if problems else LoadResult(loaded)


def _parse(text: str, file: str, base_dir: Path, overrides: Sequence[str] | None, top: Path | None,
           root: Path | None) -> LoadResult:
    try:
        doc = with_parents(compose(text, file), base_dir, (top,) if top else (), root)
    except SuiteError as e:
        return LoadResult(None, tuple(e.problems))
    dirs = {file: base_dir}
    for path in {p.file for p in doc.values.values()}:
        candidate = Path(path)
        dirs.setdefault(path, (candidate if candidate.is_absolute() else Path.cwd() / candidate).parent)
    problems: list[Problem] = []
    for text_ in overrides or ():
        problems.extend(apply_override(doc, text_))
    return _validate(doc, file, dirs, root, problems)


def _root(extends_root: str | os.PathLike[str] | None, default: Path) -> Path:
    try:
        return resolve(Path(extends_root)) if extends_root is not None else default
    except Unreadable as e:
        raise ArgumentError(f"extends_root {quote(str(extends_root))} cannot be resolved: {e}") from None


def parse_path(path: str | os.PathLike[str], overrides: Sequence[str] | None = None, *,
               extends_root: str | os.PathLike[str] | None = None) -> LoadResult:
    """Read, merge, override and validate the suite at `path`, returning what was found (never raising for
    a mistake in the files). `extends` and `model:` may name files below `extends_root` (default: the suite's
    folder); `package://` and `menagerie://` models stay inside their package's or robot's folder."""
    try:
        resolved = resolve(Path(path))
        file = display(resolved)
        text = read_text(resolved)
    except Unreadable as e:
        return LoadResult(None, (Problem(f"cannot read this suite: {e}", file=str(path)),), unreadable=str(e))
    return _parse(text, file, resolved.parent, overrides, resolved, _root(extends_root, resolved.parent))


def parse_text(text: str, overrides: Sequence[str] | None = None, *, file: str = "<string>",
               base_dir: str | os.PathLike[str] | None = None,
               extends_root: str | os.PathLike[str] | None = None) -> LoadResult:
    """Like `parse_path`, for a suite given as text; `extends` and `model` are relative to `base_dir`
    (default: the working directory), and may name files below `extends_root` (default: `base_dir`)."""
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    try:
        root = _root(extends_root, resolve(base))
    except Unreadable as e:
        raise ArgumentError(f"base_dir {quote(str(base_dir))} cannot be resolved: {e}") from None
    return _parse(text, file, base, overrides, None, root)


def load_path(path: str | os.PathLike[str], overrides: Sequence[str] | None = None, *,
              extends_root: str | os.PathLike[str] | None = None) -> LoadedSuite:
    """Read, merge, override and validate the suite at `path`; SuiteError lists every problem."""
    return parse_path(path, overrides, extends_root=extends_root).unwrap()


def load_text(text: str, overrides: Sequence[str] | None = None, *, file: str = "<string>",
              base_dir: str | os.PathLike[str] | None = None,
              extends_root: str | os.PathLike[str] | None = None) -> LoadedSuite:
    """Validate a suite given as text; SuiteError lists every problem."""
    return parse_text(text, overrides, file=file, base_dir=base_dir, extends_root=extends_root).unwrap()
