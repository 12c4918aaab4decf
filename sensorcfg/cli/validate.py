"""`sensorcfg validate`: check suites (files or directories) for syntax, schema and, with a model, binding.

Parse the paths, check each file into a `FileResult`, then hand the results to a reporter from `REPORTERS`.
Problems print one per line as `path:line:col: error: loc: message`, the format compilers and linters use,
so editors and CI annotate them.
"""

from __future__ import annotations

import argparse
import dataclasses
import errno
import json
import os
import stat
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, cast

from ..config.overrides import with_model
from ..errors import Problem, SuiteError, printable, quote
from .common import (EXIT_INVALID, EXIT_OK, EXIT_USAGE, HelpFormatter, UsageError, add_common_suite_args,
                     importable_cwd, load_model, model_option, os_reason, user_code_problem)

__all__ = ["add_parser", "FileResult", "Found", "REPORTERS", "collect", "check_file", "check_isolated"]

SUFFIXES = (".yaml", ".yml")

# --engine -> (the batch's checks, the Warp engine's checks): what `Suite.check` is asked besides `Environment`'s
ENGINES: dict[str, tuple[bool, bool]] = {"single": (False, False), "batch": (True, False), "warp": (True, True)}

EXAMPLES = """examples:
  sensorcfg validate configs/                        every *.yaml / *.yml below configs/
  sensorcfg validate my_suite.yaml --model robot.xml also check elements, kinds, units and shapes
  sensorcfg validate configs/imu.yaml --set defaults.buffer=2 --format json
  sensorcfg validate configs/ --import               also import 'generic' and 'custom' callables
  sensorcfg validate configs/ --engine warp          also what the Warp engine (GPU) does not run

Without --model, a suite that names its model ('model: robot.xml') is checked against it; one that does
not is checked for syntax and schema only (the summary says how many)."""


@dataclasses.dataclass
class FileResult:
    path: str
    model: str | None  # the model it was checked against, None when checked without one
    problems: list[Problem]
    loaded: bool = True  # False when syntax or schema problems stopped it before the model
    notes: list[Problem] = dataclasses.field(default_factory=list)  # advice on a valid suite (`Suite.notes`)
    error: str | None = None  # an I/O error: the path could not be read (reported on its own line, exit 2)
    not_imported: int = 0  # the callables it names that were not imported (checked without --import)

    @property
    def valid(self) -> bool:
        return not self.problems and self.error is None


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("validate", help="check suites: syntax, schema and (with a model) elements, kinds, units",
                       description="Check sensor suites. Files are checked as given; directories are searched "
                       "recursively for *.yaml and *.yml (hidden folders skipped; each file once, whatever "
                       "the symlinks).", epilog=EXAMPLES + "\n\n" + epilog, formatter_class=HelpFormatter)
    p.add_argument("paths", nargs="+", metavar="PATH", help="suite files or directories")
    p.add_argument("--model", metavar="MODEL", help="check every suite against this MJCF/MJB model (or "
                   "package://PKG/FILE, menagerie://ROBOT/FILE) "
                   "(default: each suite's own 'model:'; given, that line is not read)")
    p.add_argument("--format", choices=sorted(REPORTERS), default="text", help="output format (default: text)")
    p.add_argument("--import", dest="import_callables", action="store_true",
                   help="import 'generic' and 'custom' callables too (a generic one whose noise or aggregator needs "
                   "its value's shape is called once, as building calls it; custom noise is never called)")
    p.add_argument("--engine", choices=list(ENGINES), default="single",
                   help="check what this engine runs: single (Environment; the default), batch (BatchEnvironment: "
                   "no noise, aggregators or drawn schedules on cameras; float64 mjData features; no generic or "
                   "custom callables; ...), warp (WarpEnvironment: what batch refuses, and what its camera renderer "
                   "does not cover, height scans meeting SDF geoms, some noise settings and fields; Warp need not "
                   "be installed)")
    p.add_argument("--batch", action="store_true", help="the same as --engine batch")
    add_common_suite_args(p, every=True)
    p.set_defaults(handler=command)


@dataclasses.dataclass
class Found:
    """The suite files named by the arguments (each once), and the paths that could not be read."""

    files: list[Path] = dataclasses.field(default_factory=list)
    errors: list[FileResult] = dataclasses.field(default_factory=list)
    seen: set[tuple[int, int]] = dataclasses.field(default_factory=set)  # (device, inode) of files and folders

    def once(self, info: os.stat_result) -> bool:
        key = (info.st_dev, info.st_ino)
        if key in self.seen:
            return False
        self.seen.add(key)
        return True

    def error(self, path: Path | str, message: str) -> None:
        self.errors.append(FileResult(str(path), None, [], loaded=False, error=message))


def collect(paths: Sequence[str]) -> Found:
    """The suite files named by `paths`, directories expanded (sorted), each file once. A path named on
    the command line that does not exist is a usage error; a folder or file below it that cannot be read
    is listed in `errors` and the rest is still checked."""
    found = Found()
    for text in paths:
        path = Path(text)
        try:
            info = os.stat(path)
        except OSError as e:
            reason = "no such file or directory" if e.errno == errno.ENOENT else os_reason(e)
            raise UsageError(f"{printable(text)}: {reason}") from None
        except ValueError:
            raise UsageError(f"{printable(text)}: the path holds a NUL character") from None
        if stat.S_ISDIR(info.st_mode):
            before = len(found.files) + len(found.errors)
            if found.once(info):
                _walk(path, found)
            if len(found.files) + len(found.errors) == before:
                raise UsageError(f"{printable(text)}: no *.yaml or *.yml files in this directory")
        elif found.once(info):
            found.files.append(path)
    return found


def _walk(root: Path, found: Found) -> None:
    """Suite files below `root`, depth first in name order (a loop, not recursion: folders may nest
    thousands deep); a folder reached twice (a symlink loop, or two links to one folder) is walked once. A
    symlink that leads out of `root` is not followed (a link named `x.yaml` to any file would otherwise be
    read, its text quoted in the problems): it is reported, and checked when named on the command line."""
    first = len(found.files)
    top = root.resolve()
    stack = [root]
    while stack:
        folder = stack.pop()
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except OSError as e:
            found.error(folder, f"cannot read this folder: {os_reason(e)}")
            continue
        below = []
        for entry in entries:
            if entry.name.startswith("."):
                continue
            path = folder / entry.name
            try:
                is_dir = entry.is_dir()
                if (entry.is_symlink() and (is_dir or path.suffix in SUFFIXES)
                        and not path.resolve().is_relative_to(top)):
                    found.error(path, f"a link out of the folder being validated ({printable(str(root))}): not "
                                      "followed; name it on the command line to check the file it leads to")
                    continue
                info = os.stat(path) if is_dir or path.suffix in SUFFIXES else None
            except OSError as e:  # a broken symlink, or one in a loop: a suite name is worth reporting
                if path.suffix in SUFFIXES:
                    found.error(path, f"cannot read this file: {os_reason(e)}")
                continue
            if info is None or not found.once(info):
                continue
            if is_dir:
                below.append(path)
            else:
                found.files.append(path)
        stack.extend(reversed(below))
    found.files[first:] = sorted(found.files[first:])  # path order: a folder's files and subfolders by name

def check_file(path: Path, model: tuple[str, Any] | None, overrides: Sequence[str], import_callables: bool,
               models: dict[str, Any] | None = None, extends_root: str | None = None, engine: str = "single"
               ) -> FileResult:
    """One suite's problems. `model` is (name, MjModel) from --model, or None for the suite's own `model:`;
    `models` caches the suites' own models by path so a folder of suites for one robot loads it once;
    `engine` a key of `ENGINES`. Sensors that pass the schema are checked against the model even when others
    do not."""
    from ..config import parse_path
    from ..suite import Suite

    result = parse_path(path, list(overrides) or None, extends_root=extends_root)
    if result.unreadable is not None:
        return FileResult(str(path), None, [], loaded=False, error=f"cannot read this suite: {result.unreadable}")
    problems = list(result.problems)
    if result.suite is None or (model is None and result.suite.model is None):
        return FileResult(str(path), None, problems, loaded=result.suite is not None and not problems)
    suite = Suite(result.suite)
    batch, warp = ENGINES[engine]
    if model is not None:
        name, target = model
    else:
        name = target = cast(str, suite.model)  # checked above
        if models is not None:
            if target not in models:
                try:
                    models[target] = load_model(target)
                except SuiteError:
                    models[target] = None  # let check() report it, positioned at the suite's `model:` line
            target = models[target]  # None: let the suite load it and report where its `model:` is
    if target is not None and suite._adds_to_model(batch):
        target = name  # the path: the suite compiles it with what it adds (sensors, cameras), as the environments do
    seen = {(p.file, p.line, p.col, p.message) for p in problems}
    problems += [p for p in suite.check(target, import_callables=import_callables, batch=batch, warp=warp)
                 if (p.file, p.line, p.col, p.message) not in seen]
    files = list(dict.fromkeys(p.file for p in problems))
    problems.sort(key=lambda p: (files.index(p.file), p.line or 0, p.col or 0))
    notes = [] if problems else suite.notes(target)
    return FileResult(str(path), name, problems, notes=notes,
                      not_imported=0 if import_callables else len(_callables(suite)))


def _callables(suite: Any) -> set[str]:
    """The callables a suite names ('module:function', each once): its generic sensors' and its custom noise's."""
    named = {cfg.callable for cfg in suite.sensors.values() if cfg.callable is not None}
    named |= {stage.callable for cfg in suite.sensors.values() for stage in cfg.noise or ()
              if stage.type == "custom" and isinstance(stage.callable, str)}
    return named


def check_isolated(path: Path, *args: Any) -> FileResult:
    """`check_file`, with a failure of user code (a generic sensor or custom noise called with --import) or
    of sensorcfg itself reported as that file's problem, so one file cannot stop the others' report."""
    try:
        return check_file(path, *args)
    except Exception as e:  # noqa: BLE001 - each file is independent; the failure is reported, not lost
        problem = user_code_problem(e) or Problem(
            f"sensorcfg failed on this file ({type(e).__name__}: {quote(str(e), 200)}); this is a bug in sensorcfg: "
            "please report it with the file", file=str(path))
        return FileResult(str(path), None, [problem], loaded=False)


# -- reporters ------------------------------------------------------------------------------------------

def _summary(results: Sequence[FileResult]) -> dict[str, int]:  # suites read (I/O errors are listed apart)
    return {"files": len(results), "invalid_files": sum(not r.valid for r in results),
            "problems": sum(len(r.problems) for r in results),
            "checked_with_model": sum(r.model is not None for r in results),
            "without_model": sum(r.loaded and r.model is None for r in results),
            "callables_not_imported": sum(r.not_imported for r in results)}


def report_text(results: Sequence[FileResult]) -> str:
    """One line per problem and a summary on stdout; I/O errors go to stderr, from `command`."""
    results = [r for r in results if r.error is None]
    lines = [p.format() for r in results for p in r.problems] + [p.format("note") for r in results for p in r.notes]
    s = _summary(results)
    files = f"{s['files']} suite{'s' if s['files'] != 1 else ''}"
    no_model = s["without_model"]
    scope = f" ({no_model} without a model: syntax and schema only)" if no_model else ""
    n = s["callables_not_imported"]
    if n:
        plural = ("s", "them") if n != 1 else ("", "it")
        scope += f"; {n} callable{plural[0]} not imported (pass --import to check {plural[1]})"
    if not results:
        lines.append("no suite could be read")
    elif s["problems"]:
        lines.append(f"{s['problems']} problem{'s' if s['problems'] != 1 else ''} in {s['invalid_files']} of "
                     f"{files}{scope}")
    else:
        lines.append(f"{files} valid{scope}")
    return "\n".join(lines)


def report_json(results: Sequence[FileResult]) -> str:
    read = [r for r in results if r.error is None]
    problems = [{"severity": "error", **p.as_dict()} for r in read for p in r.problems]
    notes = [{"severity": "note", **p.as_dict()} for r in read for p in r.notes]
    out = {"valid": all(r.valid for r in results), "summary": _summary(read), "problems": problems, "notes": notes,
           "files": [{"path": printable(r.path), "valid": r.valid, "model": r.model and printable(r.model),
                      "problems": len(r.problems)} for r in read],
           "errors": [{"path": printable(r.path), "message": printable(r.error or "")} for r in results if r.error]}
    return json.dumps(out, indent=2)


REPORTERS: dict[str, Callable[[Sequence[FileResult]], str]] = {"text": report_text, "json": report_json}


def command(args: argparse.Namespace) -> int:
    found = collect(args.paths)
    path = model_option(args.model) if args.model else None
    model = (path, load_model(path)) if path else None
    if args.import_callables:
        importable_cwd()
    models: dict[str, Any] = {}
    engine = "batch" if args.batch and args.engine == "single" else args.engine  # (warp's checks include batch's)
    results = [check_isolated(f, model, with_model(args.overrides, args.model) or [], args.import_callables, models,
                              args.extends_root, engine) for f in found.files]
    results += found.errors
    print(REPORTERS[args.format](results))
    errors = [r for r in results if r.error]
    for r in errors:
        print(f"sensorcfg: error: {printable(r.path)}: {printable(r.error or '')}", file=sys.stderr)
    if errors:
        return EXIT_USAGE
    return EXIT_OK if all(r.valid for r in results) else EXIT_INVALID
