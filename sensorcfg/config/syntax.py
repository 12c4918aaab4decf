"""PyYAML's syntax errors about tabs and indentation, in plain words with the fix.

PyYAML says `found character '\\t' that cannot start any token` for a tab and `expected <block end>, but found
'<block mapping start>'` or `mapping values are not allowed here` for a key indented as no mapping around it
is. Each row of `_WORDS` knows one of these messages and says what is wrong in the text and how to fix it,
from the error's marks and the lines around them, and where to say it (PyYAML's mark, or the start of the key
it is about); `source` makes the problem. Any other error keeps PyYAML's words. No mujoco, no pydantic.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import yaml

from ..errors import quote

__all__ = ["Words", "plain_words"]


class Words(NamedTuple):
    """What an error means and its fix, and where to say it (0-based line and column of the text)."""

    message: str
    line: int
    column: int


def _lines(text: str) -> list[str]:
    return text.split("\n")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _spaces(n: int) -> str:
    return f"{n} space" + ("" if n == 1 else "s")


def _content(line: str) -> bool:
    """Whether a line holds YAML (not blank, not only a comment)."""
    stripped = line.strip(" \t")
    return bool(stripped) and not stripped.startswith("#")


def _above(lines: list[str], line: int, shallower_than: int | None = None) -> int | None:
    """The nearest line above `line` (0-based) that holds YAML, indented less than `shallower_than` if given."""
    for n in range(min(line, len(lines)) - 1, -1, -1):
        if _content(lines[n]) and (shallower_than is None or _indent(lines[n]) < shallower_than):
            return n
    return None


def _tab(error: yaml.MarkedYAMLError, lines: list[str]) -> Words:
    mark = error.problem_mark
    before = lines[mark.line][:mark.column] if mark.line < len(lines) else ""
    if not before.strip(" \t"):
        return Words("tabs are not allowed for indentation in YAML; indent with spaces", mark.line, mark.column)
    return Words("a tab cannot be read here: sensorcfg's YAML reader takes only spaces between keys, values and "
                 "items outside quotes; replace the tab with a space", mark.line, mark.column)


def _key_in_value(error: yaml.MarkedYAMLError, lines: list[str]) -> Words:
    """A ': ' where a plain value is being read: a key indented deeper than the line above it (so it reads as
    more of that line's value), or a ': ' inside a one-line value."""
    mark = error.problem_mark
    line = lines[mark.line] if mark.line < len(lines) else ""
    before = line[:mark.column]
    owner = _above(lines, mark.line, _indent(line))
    if ": " not in before and not before.lstrip(" ").startswith("- ") and owner is not None:
        key, at = before.strip(), _indent(lines[owner])
        return Words(f"this line is indented deeper than line {owner + 1}, so YAML reads {quote(key)} as more of that "
                     f"line's value, where no key can start; indent it as line {owner + 1}'s key ({_spaces(at)}) if "
                     "it is the next key of that mapping", mark.line, _indent(line))
    return Words("a ': ' inside a value starts a key where YAML does not allow one; quote the value (key: 'a: b') "
                 "if the ': ' is part of it, or start the key on a line of its own", mark.line, mark.column)


def _misaligned(error: yaml.MarkedYAMLError, lines: list[str]) -> Words:
    """A key or item between indentations: deeper than the mapping it would continue (the error's context),
    and not as deep as the lines above it (or after a key whose value is written on its line)."""
    mark, opened = error.problem_mark, error.context_mark
    here = _indent(lines[mark.line]) if mark.line < len(lines) else mark.column
    outer = opened.column
    above = _above(lines, mark.line)
    if above is not None and _indent(lines[above]) > here:
        inner = _indent(lines[above])
        return Words(f"this line is indented {_spaces(here)}, but the lines above it are indented {inner} (line "
                     f"{above + 1}) and {outer} (line {opened.line + 1}): YAML places each line in a mapping or "
                     f"list by its indentation; indent it {inner} or {outer} spaces, as the lines it belongs with",
                     mark.line, mark.column)
    return Words(f"this line is indented {_spaces(here)}, deeper than the keys of the mapping above it "
                 f"({_spaces(outer)}, from line {opened.line + 1}), whose last value is already written; indent it "
                 f"{_spaces(outer)} if it is that mapping's next key", mark.line, mark.column)


def _is_misaligned(error: yaml.MarkedYAMLError) -> bool:
    return (isinstance(error, yaml.parser.ParserError) and error.problem_mark is not None
            and error.context_mark is not None and str(error.context) == "while parsing a block mapping"
            and str(error.problem).startswith("expected <block end>, but found '<block")
            and error.problem_mark.line > error.context_mark.line)


# which PyYAML errors are said in plain words: (does this row speak for the error, the words)
_WORDS: tuple[tuple[Callable[[yaml.MarkedYAMLError], bool], Callable[[yaml.MarkedYAMLError, list[str]], Words]],
              ...] = (
    (lambda e: isinstance(e, yaml.scanner.ScannerError) and e.problem_mark is not None
     and str(e.problem) == "found character '\\t' that cannot start any token", _tab),
    (lambda e: isinstance(e, yaml.scanner.ScannerError) and e.problem_mark is not None
     and str(e.problem) == "mapping values are not allowed here", _key_in_value),
    (_is_misaligned, _misaligned),
)


def plain_words(error: yaml.MarkedYAMLError, text: str) -> Words | None:
    """What `error` (PyYAML's, on `text`) means, how to fix it and where; None when PyYAML's own words are
    all there is."""
    return next((words(error, _lines(text)) for speaks, words in _WORDS if speaks(error)), None)
