"""What every command shares: exit codes, argument types, the user-facing errors, suite and model resolution.

A user's mistake never shows a traceback: commands raise `UsageError` (exit 2: a missing file, a bad option)
or let `SuiteError` through (exit 1: the suite or the model is wrong), and `main` prints either as
`path:line:col: error: message` lines on stderr.
"""

from __future__ import annotations

import argparse
import errno
import os
import stat
import sys
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

from ..errors import Problem, SensorcfgError, SuiteError, install_hint, printable, quote

__all__ = ["EXIT_OK", "EXIT_INVALID", "EXIT_USAGE", "EXIT_CODES_HELP", "HelpFormatter", "UsageError", "override",
           "positive_int", "positive_float", "writable", "require_matplotlib", "importable_cwd", "add_suite_args",
           "existing_file", "load_model", "load_suite", "model_option", "model_path", "suite_model",
           "user_code_failure", "user_code_problem", "add_common_suite_args", "os_reason", "seed"]

EXIT_OK, EXIT_INVALID, EXIT_USAGE = 0, 1, 2

EXIT_CODES_HELP = """exit status:
  0  every suite is valid (or the command succeeded)
  1  a suite or model has problems (listed as path:line:col: error: message), a run diverged,
     or a generic sensor or custom noise callable raised (its file and line are shown)
  2  usage or I/O error: unknown option, missing file, unwritable output, missing optional dependency"""


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Wraps one-paragraph descriptions to the terminal; keeps laid-out text (examples, exit status) as is."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text:
            return super()._fill_text(text, width, indent)
        return argparse.HelpFormatter._fill_text(self, text, width, indent)


class UsageError(SensorcfgError):
    """A mistake in how the command was called, or a file that cannot be read or written: exit 2."""


def override(text: str) -> str:
    """argparse type for --set: KEY=VALUE with a non-empty key."""
    key, sep, _ = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(
            f"expected KEY=VALUE (for example sensors.cam.interval=10ms or defaults.buffer=2), got {quote(text)}")
    return text


def add_suite_args(parser: argparse.ArgumentParser, *, suite_optional: bool = False) -> None:
    """SUITE, --model, --set and --extends-root, shared by spec, run and demo."""
    if suite_optional:
        parser.add_argument("suite", nargs="?", metavar="SUITE", help="suite file (default: the bundled demo suite)")
    else:
        parser.add_argument("suite", metavar="SUITE", help="suite file (YAML)")
    parser.add_argument("--model", metavar="MODEL", help="MJCF/MJB model, or package://PKG/FILE or "
                        "menagerie://ROBOT/FILE as in a suite (default: the suite's 'model:'; given, that line is "
                        "not read)")
    add_common_suite_args(parser)


def add_common_suite_args(parser: argparse.ArgumentParser, *, every: bool = False) -> None:
    """--set and --extends-root, shared by every command that loads suites."""
    which = "in every suite before checking" if every else "a suite key"
    parser.add_argument("--set", dest="overrides", action="append", default=[], type=override,
                        metavar="KEY=VALUE", help=f"override {which} (repeatable), e.g. defaults.buffer=2")
    parser.add_argument("--extends-root", metavar="DIR", help="let 'extends' and 'model:' name files below DIR "
                        "(default: only files in the suite's own folder and below; '/' allows any file)")


def seed(text: str) -> int:
    """argparse type for --seed: what numpy's RandomState accepts, 0 to 2**32 - 1."""
    value = int(text) if text.strip().isascii() and text.strip().lstrip("+").isdigit() else -1
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(f"expected a seed from 0 to {2**32 - 1}, got {printable(text, 40)!r}")
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {quote(text)}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, e.g. 0.02, got {quote(text)}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got {quote(text)}")
    return value


def require_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise UsageError(f"plotting needs matplotlib, which is not installed: {install_hint('plot', 'matplotlib')}"
                         ) from None


def os_reason(e: OSError) -> str:
    """An OSError as one line without the path (the caller names the path)."""
    return {errno.ENAMETOOLONG: "the file name is too long", errno.ELOOP: "a symlink loop"}.get(
        e.errno or 0, e.strerror or type(e).__name__)


def _stat(path: str) -> os.stat_result | None:
    """The file's status, None when it does not exist; any other failure is a usage error."""
    try:
        return os.stat(path)
    except FileNotFoundError:
        return None
    except OSError as e:
        raise UsageError(f"{printable(path)}: {os_reason(e)}") from None
    except ValueError:
        raise UsageError(f"{printable(path)}: the path holds a NUL character") from None


def writable(path: str | None, formats: Collection[str] = ()) -> Path | None:
    """`path` as a file that can be written (refused before any work: a directory, a name ending in a
    separator, a missing folder, or a name whose extension is not one of `formats`, the file types written,
    the first suggested)."""
    if path is None:
        return None
    p = Path(path)
    info = _stat(path)
    if (info is not None and stat.S_ISDIR(info.st_mode)) or path.endswith(("/", os.sep)) or not p.name:
        raise UsageError(f"{printable(path)}: is a directory; give a file name")
    parent = _stat(str(p.parent))
    if parent is None or not stat.S_ISDIR(parent.st_mode):
        raise UsageError(f"{printable(path)}: the folder {printable(repr(str(p.parent)))} does not exist")
    if formats and p.suffix[1:].lower() not in formats:
        kinds = ", ".join("." + f for f in formats)
        what = f"writes {kinds} files only" if len(formats) == 1 else f"the file type must be one of {kinds}"
        stem = p.stem.rstrip(".") if p.suffix or not p.name.startswith(".") else p.name.lstrip(".")
        fix = p.with_name(f"{stem or 'out'}.{next(iter(formats))}")
        raise UsageError(f"{printable(path)}: {what}; name it {printable(repr(str(fix)))}")
    return p


def importable_cwd() -> None:
    """Let `generic` and `custom` callables of the project being worked on import, as `python -m` would:
    the console script does not put the working directory on sys.path by itself."""
    if "" not in sys.path:
        sys.path.insert(0, "")


def existing_file(path: str, what: str) -> Path:
    info = _stat(path)
    if info is None:
        raise UsageError(f"{printable(path)}: no such {what}")
    if stat.S_ISDIR(info.st_mode):
        raise UsageError(f"{printable(path)}: is a directory, expected a {what}")
    if not stat.S_ISREG(info.st_mode):
        raise UsageError(f"{printable(path)}: is not a regular file, expected a {what}")
    return Path(path)


def load_model(path: str) -> Any:
    """The MjModel at `path` (MJCF, or MJB by its suffix); a file MuJoCo rejects is a problem of that file."""
    from ..physics import read_model

    try:
        return read_model(path)
    except (ValueError, OSError) as e:
        raise SuiteError(Problem(f"MuJoCo cannot load this model: {str(e).strip()}", file=str(path))) from None


def suite_model(suite: Any, path: str) -> Any:
    """The model a suite runs on: the file's, compiled with what the suite adds (MuJoCo sensors, cameras)."""
    model = load_model(path)
    return suite.compile(path) if suite._adds_to_model() else model


def load_suite(path: str, overrides: Sequence[str] = (), extends_root: str | None = None,
               model: str | None = None) -> Any:
    """The validated suite at `path` (SuiteError for its problems, UsageError when it cannot be read); with
    `model` (--model), its own `model:` line is left out (`with_model`)."""
    from ..config import parse_path
    from ..config.overrides import with_model
    from ..suite import Suite

    existing_file(path, "suite file")
    result = parse_path(path, with_model(overrides, model), extends_root=extends_root)
    if result.unreadable is not None:
        raise UsageError(f"{printable(path)}: cannot read this suite: {result.unreadable}")
    return Suite(result.unwrap())


def model_option(model: str) -> str:
    """The file --model names (`package://` and `menagerie://` resolved as in a suite's `model:`); a missing
    file is a usage error."""
    from ..config.files import model_file

    try:
        path = model_file(model)
    except ValueError as e:
        raise UsageError(f"--model {printable(quote(model, 160))}: {printable(str(e))}") from None
    existing_file(path, "model file")
    return path


def model_path(suite: Any, model: str | None) -> str:
    """The model to use: --model, or the suite's `model:`; a missing file is a usage error."""
    if model is not None:
        return model_option(model)
    if suite.model is None:
        raise UsageError(f"{printable(suite.file)}: the suite names no model; pass --model MODEL.xml or add "
                         "'model: path/to/robot.xml' to the suite")
    if not Path(suite.model).is_file():
        pos = suite._loaded.doc.pos(("model",))
        message = f"the model file {suite.model!r} does not exist"
        raise SuiteError(pos.problem(message, "model") if pos else Problem(message, "model", suite.file))
    return suite.model


# -- errors in the user's own Python code (generic sensors, custom noise) --------------------------------

_LIBRARIES = ("numpy", "mujoco", "dm_env")


def _user_frames(exc: BaseException) -> list[Any] | None:
    """The frames of the user's code (a generic sensor, a custom noise stage) that sensorcfg called and that
    raised `exc`, outermost first; None when `exc` was raised in sensorcfg itself or in a library (a
    sensorcfg bug, whose traceback is for us)."""
    import sysconfig
    import traceback

    package = Path(__file__).resolve().parent.parent
    stdlib = Path(sysconfig.get_paths()["stdlib"]).resolve()

    def ours(filename: str) -> bool:
        path = Path(filename).resolve()
        return path.is_relative_to(package) and path.parent.name != "assets"

    def library(filename: str) -> bool:
        path = Path(filename).resolve()
        return path.is_relative_to(stdlib) and "site-packages" not in path.parts or any(
            part in _LIBRARIES for part in path.parts)

    frames = traceback.extract_tb(exc.__traceback__)
    called = [i for i, f in enumerate(frames) if ours(f.filename)]
    if not called:
        return None
    user = [f for f in frames[called[0]:] if not ours(f.filename) and not library(f.filename)]
    if not user or ours(frames[-1].filename):
        return None
    return user


def user_code_failure(exc: BaseException) -> list[str] | None:
    """`path:line: error: ...` lines when `exc` was raised in the user's code called by sensorcfg, else None.

    A generic sensor or a custom noise stage is the user's code: its bug deserves its own file and line,
    not a traceback through sensorcfg. An exception raised in sensorcfg itself is a sensorcfg bug: None.
    """
    user = _user_frames(exc)
    if user is None:
        return None
    lines = [f"{printable(f.filename)}:{f.lineno}: note: in {f.name}: {printable((f.line or '').strip())}"
             for f in user[:-1]]
    last = user[-1]
    lines.append(f"{printable(last.filename)}:{last.lineno}: error: in {last.name}: {type(exc).__name__}: "
                 f"{printable(str(exc), 300)}")
    return lines


def user_code_problem(exc: BaseException) -> Problem | None:
    """The user's code that raised `exc` as a problem at its file and line (see `user_code_failure`)."""
    user = _user_frames(exc)
    if user is None:
        return None
    last = user[-1]
    return Problem(f"in {last.name}: {type(exc).__name__}: {exc}", file=last.filename, line=last.lineno)
