"""`sensorcfg validate`: check suites (files or directories) for syntax, schema and, with a model, binding.

Parse the paths, check each file into a `FileResult`, then hand the results to a reporter from `REPORTERS`.
Problems print one per line as `path:line:col: error: loc: message`, the format compilers and linters use,
so editors and CI annotate them.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from ..errors import Problem, SuiteError
from .common import (EXIT_INVALID, EXIT_OK, HelpFormatter, UsageError, existing_file, importable_cwd, load_model,
                     override)

__all__ = ["add_parser", "FileResult", "REPORTERS", "collect", "check_file"]

SUFFIXES = (".yaml", ".yml")

EXAMPLES = """examples:
  sensorcfg validate configs/                        every *.yaml / *.yml below configs/
  sensorcfg validate my_suite.yaml --model robot.xml also check elements, kinds, units and shapes
  sensorcfg validate configs/imu.yaml --set defaults.buffer=2 --format json
  sensorcfg validate configs/ --import               also import 'generic' and 'custom' callables

Without --model, a suite that names its model ('model: robot.xml') is checked against it; one that does
not is checked for syntax and schema only (the summary says how many)."""


@dataclasses.dataclass
class FileResult:
    path: str
    model: str | None  # the model it was checked against, None when checked without one
    problems: list[Problem]
    loaded: bool = True  # False when syntax or schema problems stopped it before the model

    @property
    def valid(self) -> bool:
        return not self.problems


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("validate", help="check suites: syntax, schema and (with a model) elements, kinds, units",
                       description="Check sensor suites. Files are checked as given; directories are searched "
                       "recursively for *.yaml and *.yml (hidden folders skipped).",
                       epilog=EXAMPLES + "\n\n" + epilog, formatter_class=HelpFormatter)
    p.add_argument("paths", nargs="+", metavar="PATH", help="suite files or directories")
    p.add_argument("--model", metavar="MODEL", help="check every suite against this MJCF/MJB model "
                   "(default: each suite's own 'model:')")
    p.add_argument("--format", choices=sorted(REPORTERS), default="text", help="output format (default: text)")
    p.add_argument("--import", dest="import_callables", action="store_true",
                   help="import 'generic' and 'custom' callables too (a generic one with noise is called once, "
                   "to learn its shape)")
    p.add_argument("--set", dest="overrides", action="append", default=[], type=override, metavar="KEY=VALUE",
                   help="override a key in every suite before checking (repeatable)")
    p.set_defaults(handler=command)


def collect(paths: Sequence[str]) -> list[Path]:
    """The suite files named by `paths`, directories expanded (sorted), each file once."""
    found: list[Path] = []
    for text in paths:
        path = Path(text)
        if path.is_dir():
            files = sorted(_walk(path))
            if not files:
                raise UsageError(f"{text}: no *.yaml or *.yml files in this directory")
            found.extend(files)
        elif path.exists():
            found.append(path)
        else:
            raise UsageError(f"{text}: no such file or directory")
    return list(dict.fromkeys(found))


def _walk(root: Path) -> Iterator[Path]:
    for path in root.iterdir():
        if path.name.startswith("."):
            continue
        if path.is_dir():
            yield from _walk(path)
        elif path.suffix in SUFFIXES:
            yield path


def check_file(path: Path, model: tuple[str, Any] | None, overrides: Sequence[str], import_callables: bool,
               models: dict[str, Any] | None = None) -> FileResult:
    """One suite's problems. `model` is (name, MjModel) from --model, or None for the suite's own `model:`;
    `models` caches the suites' own models by path so a folder of suites for one robot loads it once.
    Sensors that pass the schema are checked against the model even when others do not."""
    from ..suite import Suite, load

    try:
        suite = load(path, list(overrides) or None)
        problems: list[Any] = []
    except SuiteError as e:
        partial = getattr(e, "_partial", None)
        if partial is None or (model is None and partial.model is None):
            return FileResult(str(path), None, list(e.problems), loaded=False)
        suite, problems = Suite(partial), list(e.problems)
    if model is not None:
        name, target = model
    elif suite.model is None:
        return FileResult(str(path), None, problems, loaded=not problems)
    else:
        name = target = suite.model
        if models is not None:
            if target not in models:
                try:
                    models[target] = load_model(target)
                except SuiteError:
                    models[target] = None  # let check() report it, positioned at the suite's `model:` line
            target = models[target]  # None: let the suite load it and report where its `model:` is
    from ..native import native_names

    if native_names(suite.sensors) and target is not None:
        target = name  # the path: the suite compiles it with the MuJoCo sensors its kinds add
    seen = {(p.file, p.line, p.col, p.message) for p in problems}
    problems += [p for p in suite.check(target, import_callables=import_callables)
                 if (p.file, p.line, p.col, p.message) not in seen]
    files = list(dict.fromkeys(p.file for p in problems))
    problems.sort(key=lambda p: (files.index(p.file), p.line or 0, p.col or 0))
    return FileResult(str(path), name, problems)


# -- reporters ------------------------------------------------------------------------------------------

def _summary(results: Sequence[FileResult]) -> dict[str, int]:
    return {"files": len(results), "invalid_files": sum(not r.valid for r in results),
            "problems": sum(len(r.problems) for r in results),
            "checked_with_model": sum(r.model is not None for r in results),
            "without_model": sum(r.loaded and r.model is None for r in results)}


def report_text(results: Sequence[FileResult]) -> str:
    lines = [p.format() for r in results for p in r.problems]
    s = _summary(results)
    files = f"{s['files']} suite{'s' if s['files'] != 1 else ''}"
    no_model = s["without_model"]
    scope = f" ({no_model} without a model: syntax and schema only)" if no_model else ""
    if s["problems"]:
        lines.append(f"{s['problems']} problem{'s' if s['problems'] != 1 else ''} in {s['invalid_files']} of "
                     f"{files}{scope}")
    else:
        lines.append(f"{files} valid{scope}")
    return "\n".join(lines)


def report_json(results: Sequence[FileResult]) -> str:
    problems = [{"severity": "error", **p.as_dict()} for r in results for p in r.problems]
    out = {"valid": all(r.valid for r in results), "summary": _summary(results), "problems": problems,
           "files": [{"path": r.path, "valid": r.valid, "model": r.model, "problems": len(r.problems)}
                     for r in results]}
    return json.dumps(out, indent=2)


REPORTERS: dict[str, Callable[[Sequence[FileResult]], str]] = {"text": report_text, "json": report_json}


def command(args: argparse.Namespace) -> int:
    files = collect(args.paths)
    model = (args.model, load_model(str(existing_file(args.model, "model file")))) if args.model else None
    if args.import_callables:
        importable_cwd()
    models: dict[str, Any] = {}
    results = [check_file(f, model, args.overrides, args.import_callables, models) for f in files]
    print(REPORTERS[args.format](results))
    return EXIT_OK if all(r.valid for r in results) else EXIT_INVALID
