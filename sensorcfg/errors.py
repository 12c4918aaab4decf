"""The one user-facing error type, and the problems it carries.

Every mistake a user can make (in a suite file, an override, or the arguments of an observable built in
Python) becomes a `Problem`: where it is (file, 1-based line and column, dotted location) and what to do.
`SuiteError` holds all of them at once, so a user fixes a file in one pass rather than one error per run.
This module imports neither mujoco nor pydantic.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Iterable, Sequence

__all__ = ["Problem", "SuiteError", "did_you_mean"]


@dataclasses.dataclass(frozen=True)
class Problem:
    """One mistake: where it is and how to fix it."""

    message: str
    loc: str = ""  # dotted location in the suite, e.g. "sensors.wrist_cam.interval"
    file: str | None = None
    line: int | None = None  # 1-based
    col: int | None = None  # 1-based

    def where(self) -> str:
        if self.file is None:
            return "<suite>"
        if self.line is None:
            return self.file
        return f"{self.file}:{self.line}:{self.col or 1}"

    def format(self, severity: str = "error") -> str:
        loc = f"{self.loc}: " if self.loc else ""
        return f"{self.where()}: {severity}: {loc}{self.message}"

    def as_dict(self) -> dict[str, object]:
        return dataclasses.asdict(self)


class SuiteError(ValueError):
    """A suite (or an observable's configuration) has one or more mistakes.

    `problems` lists all of them; `str()` prints one `path:line:col: error: message` line per problem.
    """

    def __init__(self, problems: Problem | str | Sequence[Problem]):
        if isinstance(problems, str):
            problems = [Problem(problems)]
        elif isinstance(problems, Problem):
            problems = [problems]
        self.problems: list[Problem] = list(problems)
        super().__init__("\n".join(p.format() for p in self.problems))

    def __reduce__(self):  # picklable across processes
        return (type(self), (self.problems,))


def did_you_mean(name: str, choices: Iterable[str], n: int = 3) -> str:
    """A ' (did you mean ...?)' hint, or '' when nothing is close."""
    close = difflib.get_close_matches(name, list(choices), n=n, cutoff=0.6)
    if not close:
        return ""
    return " (did you mean " + " or ".join(repr(c) for c in close) + "?)"
