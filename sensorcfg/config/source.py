"""YAML text -> plain values that remember where every node came from.

Validating a bare dict loses positions, so suites are read with PyYAML's `compose` and turned into plain
Python values here, recording for every dotted path the file, line and column of its key and its value.
Only the tags `yaml.safe_load` understands are accepted: a `!!python/...` tag is a problem, never code,
and a standard tag whose text does not fit it (`!!int abc`) is a problem at its node. Duplicate keys (which
PyYAML silently lets the last one win) are problems too. Reading is bounded (`limits`): nesting depth,
values (aliases expanded) and integer digits, so no file can recurse, hang or exhaust memory here; a
file past a limit is stopped there, with that one problem. No mujoco, no pydantic.

Plain scalars are read as YAML 1.2's core schema reads them (`_CoreLoader`), as the JSON Schema, editors
(yaml-language-server) and other YAML 1.2 readers do, not by PyYAML's YAML 1.1 rules: `1e-3`, `1E+2`,
`.5` and `+1` are numbers, `017` is seventeen, `0o17` and `0x1F` are integers, `true`/`false` (any of
three spellings) the only booleans; `yes`, `on`, `1_000`, `0b101`, `1:20` and dates are text.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Iterator
from typing import Any

import yaml

from ..errors import QUOTE_LIMIT, Problem, SuiteError, printable, quote
from . import limits
from .limits import MAX_NODES
from .syntax import plain_words

__all__ = ["Doc", "Pos", "Path_", "TooLarge", "compose", "dotted", "MAX_NODES", "DECIMAL"]

Path_ = tuple[str | int, ...]

_MERGE = "tag:yaml.org,2002:merge"
_MAP = "tag:yaml.org,2002:map"
_SEQ = "tag:yaml.org,2002:seq"
_INT = "tag:yaml.org,2002:int"
_FLOAT = "tag:yaml.org,2002:float"
_BOOL = "tag:yaml.org,2002:bool"
_NULL = "tag:yaml.org,2002:null"

# A number in decimal notation as YAML 1.2 writes it, unsigned, ASCII digits only (units.py reads times with
# it, and the JSON Schema's time pattern is built from it).
DECIMAL = r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?"

_SIGNED_DECIMAL = re.compile(rf"[-+]?{DECIMAL}")

# YAML 1.2 core schema (yaml.org/spec/1.2.2, 10.3.2): the tag of a plain scalar, first match wins; any other
# plain scalar is a string. The merge key `<<` (YAML 1.1's, kept: suites use it) is the one addition.
_PLAIN: tuple[tuple[str, re.Pattern[str]], ...] = tuple((tag, re.compile(pattern)) for tag, pattern in (
    (_NULL, r"~|null|Null|NULL|"),
    (_BOOL, r"true|True|TRUE|false|False|FALSE"),
    (_INT, r"[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+"),
    (_FLOAT, rf"{_SIGNED_DECIMAL.pattern}|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)"),
    (_MERGE, r"<<"),
))
# each integer form and its base (the text given to int() is group 1)
_INTS = ((re.compile(r"([-+]?[0-9]+)"), 10), (re.compile(r"0o([0-7]+)"), 8), (re.compile(r"0x([0-9a-fA-F]+)"), 16))
_SPECIAL_FLOATS = re.compile(r"([-+]?)\.(?:(inf|Inf|INF)|nan|NaN|NAN)")
_BOOLS = {"true": True, "True": True, "TRUE": True, "false": False, "False": False, "FALSE": False}


class _Unrepresentable(ValueError):
    """A number whose text is valid but which a float64 cannot hold; its message says so."""


def _read_int(text: str) -> int:
    for pattern, base in _INTS:
        match = pattern.fullmatch(text)
        if match:
            return int(match.group(1), base)
    raise ValueError(text)


def _read_float(text: str) -> float:
    special = _SPECIAL_FLOATS.fullmatch(text)
    if special:
        return (-math.inf if special.group(1) == "-" else math.inf) if special.group(2) else math.nan
    if not _SIGNED_DECIMAL.fullmatch(text):
        raise ValueError(text)
    value = float(text)
    if math.isinf(value):
        raise _Unrepresentable(f"{text} is too large for a number (at most about 1.8e308); write .inf or "
                               "-.inf for infinity, or quote it to make it text")
    if value == 0 and re.search(r"[1-9]", text.partition("e")[0].partition("E")[0]):
        raise _Unrepresentable(f"{text} is too close to zero for a number (at least about 5e-324); write 0 for "
                               "zero, or quote it to make it text")
    return value


def _read_bool(text: str) -> bool:
    return _BOOLS[text]  # KeyError: not a YAML 1.2 boolean


def _constructor(read: Callable[[str], object]) -> Callable[[yaml.SafeLoader, yaml.ScalarNode], object]:
    """A PyYAML constructor that reads a scalar node's text with `read`."""
    def construct(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> object:
        return read(str(loader.construct_scalar(node)))
    return construct


class _CoreLoader(yaml.SafeLoader):
    """PyYAML's safe loader with YAML 1.2's core schema: plain scalars resolved by `_PLAIN`, and numbers and
    booleans (implicit or tagged: `!!int 017` is 17) constructed by its rules. Used only here, so PyYAML's
    own loaders keep their behaviour."""

    def resolve(self, kind: type[yaml.Node], value: str, implicit: tuple[bool, bool]) -> str:
        if kind is yaml.ScalarNode and implicit[0]:
            return next((tag for tag, pattern in _PLAIN if pattern.fullmatch(value)), self.DEFAULT_SCALAR_TAG)
        return str(super().resolve(kind, value, implicit))


_CoreLoader.add_constructor(_INT, _constructor(_read_int))
_CoreLoader.add_constructor(_FLOAT, _constructor(_read_float))
_CoreLoader.add_constructor(_BOOL, _constructor(_read_bool))
_SAFE_SCALARS = frozenset(t for t in _CoreLoader.yaml_constructors if t and t not in (_MAP, _SEQ))


@dataclasses.dataclass(frozen=True)
class Pos:
    """A 1-based place in a file (or in an override, whose 'file' names it)."""

    file: str
    line: int
    col: int

    def problem(self, message: str, loc: str = "") -> Problem:
        return Problem(message, loc, self.file, self.line, self.col)


def dotted(path: Path_) -> str:
    return ".".join(str(p) for p in path)


@dataclasses.dataclass
class Doc:
    """A plain value (dicts, lists, scalars) and the positions of its nodes by path.

    `keys[path]` is where the key of `path` was written, `values[path]` where its value starts. Merges and
    overrides keep both maps in step with the value, so any path in the value has a position.
    """

    value: Any
    values: dict[Path_, Pos] = dataclasses.field(default_factory=dict)
    keys: dict[Path_, Pos] = dataclasses.field(default_factory=dict)
    problems: list[Problem] = dataclasses.field(default_factory=list)  # found while composing (tags, duplicates)
    nodes: int = 0  # values built (aliases expanded) of its text and of every text merged into it (`limits`)
    size: int = 0  # bytes of those texts

    def pos(self, path: Path_, *, key: bool = False) -> Pos | None:
        """The position of `path` (its key when asked and known), else of its nearest ancestor."""
        path = tuple(path)
        if key and path in self.keys:
            return self.keys[path]
        while True:
            if path in self.values:
                return self.values[path]
            if not path:
                return None
            path = path[:-1]

    def drop(self, prefix: Path_) -> None:
        """Forget the positions under `prefix` (its value is being replaced)."""
        n = len(prefix)
        for table in (self.values, self.keys):
            for path in [p for p in table if p[:n] == prefix and len(p) > n]:
                del table[path]

    def graft(self, other: Doc, at: Path_) -> None:
        """Take the positions of `other` (a value placed at path `at`)."""
        for path, pos in other.values.items():
            self.values[at + path] = pos
        for path, pos in other.keys.items():
            self.keys[at + path] = pos


def _pos(mark: yaml.Mark, file: str, line_offset: int = 0, col_offset: int = 0) -> Pos:
    col = mark.column + 1 + (col_offset if mark.line == 0 else 0)
    return Pos(file, mark.line + 1 + line_offset, col)


class TooLarge(SuiteError):
    """A text past a limit of `limits` (nesting, values): its one problem quotes nothing of the text."""


class _TooLarge(yaml.MarkedYAMLError):
    """Raised while composing: the text nests too deep or holds too many values."""


def _too_many(spent: int, through_aliases: bool) -> str:
    """The problem of a text past `MAX_NODES` values, `spent` of them in the files that extend it."""
    if not spent:
        return (f"the file expands to more than {limits.MAX_NODES:,} values (through aliases); write it out plainly"
                if through_aliases else f"the file holds more than {limits.MAX_NODES:,} values; a suite is far smaller")
    alias = ", through aliases" if through_aliases else ""
    return (f"the suite's files hold more than {limits.MAX_NODES:,} values together{alias} ({spent:,} of them in the "
            "files that extend this one); a suite is far smaller")


class _BoundedLoader(_CoreLoader):
    """The core-schema composer, stopped at `MAX_DEPTH` nested collections and `MAX_NODES` nodes less the
    `spent` values of the files that extend this one (its composer recurses once per level, so a deeply
    nested file would otherwise raise RecursionError)."""

    def __init__(self, stream: str, spent: int = 0):
        super().__init__(stream)
        self.depth = 0
        self.nodes = spent
        self.spent = spent

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:  # type: ignore[override]
        mark = self.peek_event().start_mark
        self.nodes += 1
        if self.nodes > limits.MAX_NODES:
            raise _TooLarge(problem=_too_many(self.spent, through_aliases=False), problem_mark=mark)
        self.depth += 1
        if self.depth > limits.MAX_DEPTH:
            raise _TooLarge(problem=f"values nest more than {limits.MAX_DEPTH} levels deep; a suite needs about 6",
                            problem_mark=mark)
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


class _Stop(Exception):
    """Raised while building: the value expands past a limit (through aliases); the document stops there."""

    def __init__(self, problem: Problem):
        super().__init__(problem.message)
        self.problem = problem


# what opens -> what closes it, and where the closer goes
_CLOSERS = {"[": ("]", "after its last item"), "{": ("}", "after its last entry"),
            "'": ("'", "where the text ends"), '"': ('"', "where the text ends")}
_ENDS = (yaml.StreamEndToken, yaml.DocumentStartToken, yaml.DocumentEndToken)
_QUOTE_ENDS = ("found unexpected end of stream", "found unexpected document separator")


def _indent(text: str, line: int) -> int:
    lines = text.split("\n")
    shown = lines[line] if line < len(lines) else ""
    return len(shown) - len(shown.lstrip(" "))


def _unclosed(error: yaml.MarkedYAMLError, loader: _BoundedLoader | None, text: str) -> yaml.Mark | None:
    """Where the flow collection (`[`, `{`) or quoted text (`'`, `"`) that `error` found never closed was
    opened, else None.

    PyYAML reports these where the text ran out (or where it stopped making sense), which may be far below
    the mistake. Quoted text never closed when the scanner met the end of the document inside it. A
    collection never closed when the parser met the end of the document inside it, or a later line
    indented no deeper than the line that opened it (YAML 1.2 requires a flow collection's lines to be
    indented deeper; PyYAML does not check, so it reads on).
    """
    if isinstance(error, yaml.scanner.ScannerError):
        quoted = error.context_mark is not None and str(error.problem).startswith(_QUOTE_ENDS)
        return error.context_mark if quoted else None
    if not isinstance(error, yaml.parser.ParserError) or loader is None or not loader.marks:
        return None
    opened: yaml.Mark = loader.marks[-1]  # the innermost collection being parsed
    if text[opened.index:opened.index + 1] not in ("[", "{"):
        return None
    found = loader.tokens[0] if loader.tokens else None
    at = error.problem_mark
    if isinstance(found, _ENDS) or (at is not None and at.line > opened.line
                                    and _indent(text, at.line) <= _indent(text, opened.line)):
        return opened
    return None


def _syntax_problem(error: yaml.MarkedYAMLError, loader: _BoundedLoader | None, text: str, file: str,
                    col_offset: int) -> Problem:
    opened = _unclosed(error, loader, text)
    if opened is not None and text[opened.index:opened.index + 1] in _CLOSERS:
        char = text[opened.index]
        closer, where = _CLOSERS[char]
        return _pos(opened, file, col_offset=col_offset).problem(
            f"invalid YAML: this {quote(char)} is never closed; add {quote(closer)} {where}")
    said = plain_words(error, text)
    if said is not None:
        return Pos(file, said.line + 1, said.column + 1 + (col_offset if said.line == 0 else 0)).problem(
            f"invalid YAML: {said.message}")
    mark = error.problem_mark or error.context_mark
    problem = str(error.problem or error.context).removeprefix("but ")
    what = problem + (f" ({error.context})" if error.problem and error.context else "")
    pos = _pos(mark, file, col_offset=col_offset) if mark else Pos(file, 1, 1)
    return pos.problem(f"invalid YAML: {printable(what, 200)}")


def _compose_node(text: str, file: str, col_offset: int, spent: int) -> yaml.Node | None:
    """The composed document; SuiteError for invalid YAML, TooLarge for a text past the limits."""
    loader: _BoundedLoader | None = None
    try:
        loader = _BoundedLoader(text, spent)  # reads the text: a character YAML does not allow is a marked error
        return loader.get_single_node()
    except _TooLarge as e:
        pos = _pos(e.problem_mark, file, col_offset=col_offset) if e.problem_mark else Pos(file, 1, 1)
        raise TooLarge(pos.problem(str(e.problem))) from None
    except yaml.MarkedYAMLError as e:
        raise SuiteError(_syntax_problem(e, loader, text, file, col_offset)) from None
    except yaml.YAMLError as e:
        raise SuiteError(Problem(f"invalid YAML: {printable(str(e), 200)}", file=file)) from None
    finally:
        if loader is not None:
            loader.dispose()


def compose(text: str, file: str, *, col_offset: int = 0, spent: int = 0) -> Doc:
    """Parse one YAML document into a `Doc`; raises SuiteError for invalid YAML, TooLarge for a text past the
    limits (also through aliases: then that is the one problem reported). `spent`: the values of the files
    that extend this one, which count towards `MAX_NODES` with its own.

    Disallowed tags and duplicate keys do not stop the walk: they are listed in `Doc.problems` (the node
    is left out) so that the rest of the file is still checked. `col_offset` shifts columns of the first
    line (an override's value starts after `key=`).
    """
    node = _compose_node(text, file, col_offset, spent)
    doc = Doc(None, size=len(text.encode("utf-8", "surrogatepass")))
    if node is None:
        return doc
    builder = _Builder(file, col_offset, doc, spent)
    try:
        doc.value = builder.build(node, ())
    except _Stop as e:
        raise TooLarge(e.problem) from None
    doc.problems.extend(builder.problems)
    doc.nodes = builder.count - spent
    return doc


# what YAML reads a key that is not a string as (a key is written in YAML, so its Python type is not said)
_READ_AS: dict[type, str] = {type(None): "null", bool: "a boolean", int: "an integer", float: "a number"}


def _spelled(node: yaml.Node) -> str:
    """A scalar as it was written (`~`, `null`, `True`, `0x1F`), shortened; an empty one said so."""
    text = str(node.value)
    return printable(text if len(text) <= QUOTE_LIMIT else text[:QUOTE_LIMIT] + "...") if text else "(empty)"


class _Builder:
    """Walks composed nodes, building values and recording positions and problems."""

    def __init__(self, file: str, col_offset: int, doc: Doc, spent: int = 0):
        self.file = file
        self.col_offset = col_offset
        self.doc = doc
        self.problems: list[Problem] = []
        self.constructor = _CoreLoader("")  # constructs single safe scalars
        self.open: set[int] = set()  # ids of the collections being built (an alias to one is a cycle)
        self.count = spent  # values built, with those of the files that extend this one
        self.spent = spent

    def pos(self, node: yaml.Node) -> Pos:
        return _pos(node.start_mark, self.file, col_offset=self.col_offset)

    def build(self, node: yaml.Node, path: Path_) -> Any:
        self.doc.values[path] = self.pos(node)
        self.count += 1
        if self.count > limits.MAX_NODES:
            raise _Stop(self.pos(node).problem(_too_many(self.spent, through_aliases=True), dotted(path)))
        if len(path) > limits.MAX_DEPTH:  # aliases inside aliases nest deeper than the text does
            raise _Stop(self.pos(node).problem(
                f"values nest more than {limits.MAX_DEPTH} levels deep (through aliases); a suite needs about 6"))
        if isinstance(node, yaml.CollectionNode):
            if id(node) in self.open:
                self.problems.append(self.pos(node).problem(
                    "this alias refers to a node that contains it (an endless value); remove the alias",
                    dotted(path)))
                return None
            self.open.add(id(node))
            try:
                return self.collection(node, path)
            finally:
                self.open.discard(id(node))
        if node.tag not in _SAFE_SCALARS:
            return self.bad_tag(node, path)
        return self.scalar(node, path)

    def scalar(self, node: yaml.Node, path: Path_) -> Any:
        """A scalar's value by its (safe) tag, or None and a problem when its text does not fit the tag."""
        tag = node.tag.replace("tag:yaml.org,2002:", "!!")
        if node.tag == _INT and len(str(node.value).lstrip("+-")) > limits.MAX_INT_DIGITS:
            digits = len(str(node.value))
            self.problems.append(self.pos(node).problem(
                f"an integer of {digits} digits is too large (at most {limits.MAX_INT_DIGITS}); no setting needs more",
                dotted(path)))
            return None
        try:
            return self.constructor.construct_object(node, deep=True)
        except _Unrepresentable as e:
            self.problems.append(self.pos(node).problem(str(e), dotted(path)))
            return None
        except (yaml.YAMLError, ValueError, TypeError, KeyError, AttributeError, OverflowError):
            self.problems.append(self.pos(node).problem(
                f"{quote(str(node.value))} is not a valid {tag}; fix it, or quote it to make it text", dotted(path)))
            return None

    def collection(self, node: yaml.CollectionNode, path: Path_) -> Any:
        if isinstance(node, yaml.MappingNode):
            return self.mapping(node, path) if node.tag == _MAP else self.bad_tag(node, path)
        if node.tag != _SEQ:
            return self.bad_tag(node, path)
        return [self.build(item, path + (i,)) for i, item in enumerate(node.value)]

    def bad_tag(self, node: yaml.Node, path: Path_) -> None:
        tag = node.tag.replace("tag:yaml.org,2002:", "!!")
        self.problems.append(self.pos(node).problem(
            f"the tag {quote(tag)} is not allowed: suites hold plain YAML values only (no Python objects); "
            "remove the tag", dotted(path)))
        return None

    def pairs(self, node: yaml.MappingNode) -> Iterator[tuple[yaml.Node, yaml.Node]]:
        """Key/value nodes, with YAML merge keys (`<<: *anchor`) expanded; explicit keys win."""
        merged: list[tuple[yaml.Node, yaml.Node]] = []
        for key, value in node.value:
            if key.tag == _MERGE:
                sources = value.value if isinstance(value, yaml.SequenceNode) else [value]
                for source in sources:
                    if isinstance(source, yaml.MappingNode):
                        merged.extend(source.value)
                    else:
                        self.problems.append(self.pos(source).problem(
                            "a merge key '<<' takes a mapping (or a list of mappings) to merge in"))
            else:
                yield key, value
        own = {k.value for k, _ in node.value if isinstance(k, yaml.ScalarNode) and k.tag != _MERGE}
        seen: set[Any] = set()
        for key, value in merged:
            if isinstance(key, yaml.ScalarNode) and key.value not in own and key.value not in seen:
                seen.add(key.value)
                yield key, value

    def mapping(self, node: yaml.MappingNode, path: Path_) -> dict[str, Any]:
        out: dict[str, Any] = {}
        first: dict[str, Pos] = {}
        for key_node, value_node in self.pairs(node):
            key_pos = self.pos(key_node)
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag not in _SAFE_SCALARS:
                self.problems.append(key_pos.problem("a key must be a plain name, not a list or mapping",
                                                     dotted(path)))
                continue
            key = self.scalar(key_node, path)
            if key is None and key_node.tag != "tag:yaml.org,2002:null":
                continue  # its problem is reported
            if not isinstance(key, str):
                self.problems.append(key_pos.problem(
                    f"the key {_spelled(key_node)} must be a name (a string), but YAML reads it as "
                    f"{_READ_AS.get(type(key), 'a value')}; quote it if it really is one", dotted(path)))
                continue
            if key in first:
                self.problems.append(key_pos.problem(
                    f"duplicate key {quote(key)} (first written at line {first[key].line}); "
                    "a key may appear once per mapping: merge the two", dotted(path + (key,))))
                continue
            first[key] = key_pos
            self.doc.keys[path + (key,)] = key_pos
            out[key] = self.build(value_node, path + (key,))
        return out
