"""The errors sensorcfg raises on purpose, the problems a `SuiteError` carries, and how input is quoted.

Every mistake in a suite file, an override, or the arguments of an observable built in Python becomes a
`Problem`: where it is (file, 1-based line and column, dotted location) and what to do. `SuiteError` holds
all of them at once, so a user fixes a file in one pass rather than one error per run. Mistakes that are
not about a suite have their own types under the same base, `SensorcfgError`:

- `SuiteError`: a suite (file, override, or an observable's configuration) or its model has problems;
- `ArgumentError`: a Python call got a value it cannot use (an action of the wrong shape, simulation ids
  out of range, a callback returning the wrong shape);
- `UnsupportedError`: the installed MuJoCo cannot do what was asked (a `BatchEnvironment` on MuJoCo 3).

Text that came from input (names, values, file names) is printed through `printable`, so a newline or an
ANSI escape in a sensor name cannot forge a line of output, and quoted through `quote`, which shortens it.
This module imports neither mujoco nor pydantic.
"""

from __future__ import annotations

import dataclasses
import difflib
import re
from collections.abc import Iterable, Sequence
from typing import Any

__all__ = ["ArgumentError", "Problem", "SensorcfgError", "SuiteError", "UnsupportedError", "did_you_mean",
           "install_hint", "printable", "quote", "QUOTE_LIMIT", "MESSAGE_LIMIT"]

QUOTE_LIMIT = 40  # characters of an input value a message quotes (then '...')
MESSAGE_LIMIT = 2000  # characters of one printed message (a safety net: the longest, a list of kinds, is ~1000)

_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
# A quoted literal ('...', as repr writes it) longer than this in a message is cut when printed: a safety net
# for messages that quote an input value without `quote`, so a value from an extended file is never
# printed back whole. Literals are read left to right; an apostrophe inside a word starts none.
_QUOTED = re.compile(r"(?<!\w)'((?:[^'\\\n]|\\.)*)'")  # linear: a literal cannot pass a quote
_QUOTED_LIMIT = 200  # paths are quoted whole; a value pasted from a file is not


def _cut(match: re.Match[str]) -> str:
    inner = match.group(1)
    return match.group(0) if len(inner) <= _QUOTED_LIMIT else f"'{inner[:_QUOTED_LIMIT]}'..."


def _shorten_quoted(message: str) -> str:
    return _QUOTED.sub(_cut, message) if len(message) > _QUOTED_LIMIT else message


def printable(text: str, limit: int | None = None) -> str:
    """`text` with every non-printable character (newlines, tabs, ANSI escapes, bidi controls, line
    separators) written as a backslash escape, so it prints on one line as itself; cut after `limit`."""
    if limit is not None and len(text) > limit:
        text = text[:limit] + "..."
    if text.isprintable():
        return text
    out = []
    for ch in text:
        if ch.isprintable():
            out.append(ch)
        elif ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        else:
            code = ord(ch)
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}")
    return "".join(out)


def quote(value: Any, limit: int = QUOTE_LIMIT) -> str:
    """A value from input as a message quotes it: its repr, shortened to about `limit` characters."""
    if isinstance(value, str) and len(value) > limit:
        return repr(value[:limit]) + f"... ({len(value)} characters)"
    text = repr(value)
    return text if len(text) <= limit + 2 else text[:limit] + "..."


@dataclasses.dataclass(frozen=True)
class Problem:
    """One mistake: where it is and how to fix it.

    Attributes:
        message: What is wrong and the fix.
        loc: Its dotted location in the suite, e.g. "sensors.wrist_cam.interval" ('' when none).
        file: The file (or override, or '<string>') it is in; None when it is not in one.
        line: Its 1-based line; None when not known.
        col: Its 1-based column; None when not known.
    """

    message: str
    loc: str = ""  # dotted location in the suite, e.g. "sensors.wrist_cam.interval"
    file: str | None = None
    line: int | None = None  # 1-based
    col: int | None = None  # 1-based

    def where(self) -> str:
        if self.file is None:
            return "<suite>"
        file = printable(self.file)
        if self.line is None:
            return file
        return f"{file}:{self.line}:{self.col or 1}"

    def format(self, severity: str = "error") -> str:
        """One line, `file:line:col: error: loc: message`, with input escaped (it cannot print two lines)."""
        loc = f"{printable(self.loc, 200)}: " if self.loc else ""
        return f"{self.where()}: {severity}: {loc}{printable(_shorten_quoted(self.message), MESSAGE_LIMIT)}"

    def as_dict(self) -> dict[str, object]:
        """The fields as the JSON reporter prints them, escaped as `format` escapes them."""
        return {"message": printable(_shorten_quoted(self.message), MESSAGE_LIMIT), "loc": printable(self.loc, 200),
                "file": None if self.file is None else printable(self.file), "line": self.line, "col": self.col}


class SensorcfgError(Exception):
    """The base of every error sensorcfg raises on purpose: catch it to catch them all."""


class SuiteError(SensorcfgError, ValueError):
    """A suite (or an observable's configuration) has one or more mistakes.

    `problems` lists all of them; `str()` prints one `path:line:col: error: message` line per problem.
    """

    def __init__(self, problems: Problem | str | Sequence[Problem]):
        """One error for every problem found.

        Args:
            problems: The problems (one `Problem`, or several), or a message (a problem with no place).
        """
        if isinstance(problems, str):
            problems = [Problem(problems)]
        elif isinstance(problems, Problem):
            problems = [problems]
        self.problems: list[Problem] = list(problems)
        super().__init__("\n".join(p.format() for p in self.problems))

    def __reduce__(self):  # picklable across processes
        return (type(self), (self.problems,))


class ArgumentError(SensorcfgError, ValueError):
    """A Python call got a value it cannot use (not a suite mistake): an action of the wrong shape,
    simulation ids out of range, a callback that returns the wrong shape, a bad setting of a constructor."""


class UnsupportedError(SensorcfgError, RuntimeError):
    """What was asked needs something this installation lacks, such as MuJoCo 4's `mujoco.batch`."""


def install_hint(extra: str, packages: str) -> str:
    """How to install an optional extra: sensorcfg is installed from a clone (it is not on the package
    index), so the extra is `'.[extra]'` there, and the packages it stands for install by their own names."""
    return f"pip install {packages} (or, from a sensorcfg clone, pip install '.[{extra}]')"


def did_you_mean(name: str, choices: Iterable[str], n: int = 3) -> str:
    """A ' (did you mean ...?)' hint, or '' when nothing is close."""
    choices = list(choices)
    if len(name) > 100 or len(choices) > 10_000:  # difflib is quadratic: a hint is not worth a hang
        return ""
    close = difflib.get_close_matches(name, choices, n=n, cutoff=0.6)
    if not close:
        return ""
    return " (did you mean " + " or ".join(quote(c) for c in close) + "?)"
