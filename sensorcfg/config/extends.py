"""`extends`: a suite starts from another one and overrides it key by key.

The child wins key by key: mappings merge, anything else replaces, and `null` removes an inherited key.
Positions follow the values, so a mistake inherited from a parent points into the parent.

A suite names files on the machine that checks it (often CI, on suites from pull requests), so what it
may extend is bounded: files inside `root` (by default the folder of the suite that was named, and every
folder below it), regular files only (see `files`), at most `MAX_EXTENDS` in a chain, no cycles, and the
chain's bytes and values together within `limits` (each parent read and built only within what the files
extending it left, so a long chain of large files stops at the first one past the budget). A file
that is not a suite (its top level is not a mapping of suite keys) is reported at the `extends` line
without quoting any of its contents.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, cast

from ..errors import SuiteError, quote
from .files import ROOT_HINT, Unreadable, display, inside, read_text, resolve
from .limits import MAX_EXTENDS
from .models import SuiteConfig
from .source import Doc, Path_, Pos, TooLarge, compose

__all__ = ["with_parents", "merge", "SUITE_KEYS"]

SUITE_KEYS = tuple(SuiteConfig.model_fields)
_PATH_QUOTE = 160  # characters of an `extends` path a message quotes


def _shown(target: Any) -> str:
    return quote(target, _PATH_QUOTE)


def _fail(at: Pos, message: str) -> SuiteError:
    return SuiteError(at.problem(message, "extends"))


def _parent_path(target: Any, at: Pos, base_dir: Path, chain: tuple[Path, ...], root: Path | None) -> Path:
    """The file `extends: target` names, once it is known to be allowed."""
    if not isinstance(target, str) or not target.strip():
        raise _fail(at, f"extends takes a path to another suite, relative to this file; got {_shown(target)}")
    if len(chain) >= MAX_EXTENDS:
        raise _fail(at, f"extends chains more than {MAX_EXTENDS} files; merge some of them")
    try:
        path = resolve(base_dir / target)
    except Unreadable as e:
        raise _fail(at, f"cannot read {_shown(target)}: {e}") from None
    if path in chain:
        cycle = " -> ".join(display(p) for p in chain + (path,))
        raise _fail(at, f"extends makes a cycle: {cycle}; remove one of these extends")
    if root is not None and not inside(path, root):
        raise _fail(at, f"{_shown(target)} is outside the folder of the suite being loaded ({root}), "
                        f"where extends may reach; {ROOT_HINT}")
    return path


def with_parents(doc: Doc, base_dir: Path, chain: tuple[Path, ...], root: Path | None, *, nodes: int = 0,
                 size: int = 0) -> Doc:
    """`doc` merged over the suites it extends (recursively); bad paths, cycles, non-suites and a chain past
    the limits raise SuiteError at the `extends` line. `chain` holds the files already on the way (for cycles);
    `nodes` and `size` the values and bytes of the files that extend `doc`: a suite's files together are
    bounded (`limits`), so a parent is read and built only within what they left."""
    nodes, size = nodes + doc.nodes, size + doc.size
    if not isinstance(doc.value, dict) or "extends" not in doc.value:
        return doc
    target = doc.value.pop("extends")
    at = cast(Pos, doc.pos(("extends",)))  # the key was read from YAML, so it has a position
    if target is None:
        return doc
    path = _parent_path(target, at, base_dir, chain, root)
    try:
        text = read_text(path, size)
    except Unreadable as e:
        raise _fail(at, f"cannot read {_shown(target)} (resolved to {path}): {e}; extends paths are relative "
                        "to the file that names them") from None
    try:
        parent = compose(text, display(path), spent=nodes)
    except TooLarge as e:  # a limit's message quotes nothing of the file
        place = e.problems[0]
        raise _fail(at, f"{_shown(target)} takes the suite past a limit (at its line {place.line}, column "
                        f"{place.col}): {place.message}") from None
    except SuiteError as e:  # PyYAML's message may quote the file (an alias name): say only where
        place = e.problems[0]
        raise _fail(at, f"{_shown(target)} is not a suite: it is not valid YAML (line {place.line}, column "
                        f"{place.col}); check it with 'sensorcfg validate' on that file") from None
    if parent.value is not None and not isinstance(parent.value, dict):
        raise _fail(at, f"{_shown(target)} is not a suite (its top level is not a mapping)")
    unknown = [k for k in parent.value or {} if k not in SUITE_KEYS]
    if unknown:
        raise _fail(at, f"{_shown(target)} is not a suite: {len(unknown)} of its top-level keys are not suite "
                        f"keys ({', '.join(SUITE_KEYS)}); check it with 'sensorcfg validate' on that file")
    parent = with_parents(parent, path.parent, chain + (path,), root, nodes=nodes, size=size)
    return merge(parent, doc)


def merge(parent: Doc, child: Doc) -> Doc:
    """Child over parent: mappings merge key by key, anything else replaces, `null` deletes the key.

    Positions follow the values: a replaced or deleted subtree takes its positions from the child (or
    loses them), in one pass over each table whatever the number of keys the child changes.
    """
    out = Doc(parent.value, dict(parent.values), dict(parent.keys), parent.problems + child.problems,
              parent.nodes + child.nodes, parent.size + child.size)
    if child.value is None:
        return out
    plan = _Plan()
    out.value = _merge_into(parent.value, child.value, (), plan)
    gone, replaced = plan.deleted | plan.replaced, plan.replaced
    out.values = {p: pos for p, pos in parent.values.items() if not _within(p, gone, inclusive=True)}
    out.values.update((p, pos) for p, pos in child.values.items() if _within(p, replaced, inclusive=True))
    out.keys = {p: pos for p, pos in parent.keys.items()
                if not _within(p, plan.deleted, inclusive=True) and not _within(p, replaced, inclusive=False)}
    out.keys.update((p, pos) for p, pos in child.keys.items() if _within(p, replaced, inclusive=False))
    out.keys.update((p, child.keys[p]) for p in plan.written)
    for path in plan.mappings:
        if path in child.values and path not in out.values:
            out.values[path] = child.values[path]
    return out


@dataclasses.dataclass
class _Plan:
    """What a merge did, by path: subtrees the child deleted or replaced, keys it wrote, mappings merged."""

    deleted: set[Path_] = dataclasses.field(default_factory=set)
    replaced: set[Path_] = dataclasses.field(default_factory=set)
    written: list[Path_] = dataclasses.field(default_factory=list)
    mappings: list[Path_] = dataclasses.field(default_factory=list)


def _within(path: Path_, roots: set[Path_], *, inclusive: bool) -> bool:
    """Whether `path` lies below one of `roots` (or is one, when `inclusive`)."""
    if not roots:
        return False
    return any(path[:k] in roots for k in range(len(path) + inclusive))


def _merge_into(old: Any, new: Any, path: Path_, plan: _Plan) -> Any:
    if isinstance(old, dict) and isinstance(new, dict):
        merged = dict(old)
        for key, value in new.items():
            sub = path + (key,)
            if value is None:
                merged.pop(key, None)
                plan.deleted.add(sub)
                continue
            merged[key] = _merge_into(old.get(key), value, sub, plan)
            plan.written.append(sub)
        plan.mappings.append(path)
        return merged
    plan.replaced.add(path)
    return new
