"""Which files a suite may name, and reading them: regular files only, bounded in size, never blocking.

`validate` runs in CI on suites from pull requests, so a suite must not make it read a FIFO (blocks
forever), a device such as /dev/zero (never ends), a directory or a socket: a file's type is checked
before it is opened and again on the open descriptor, and at most `MAX_SUITE_BYTES` are read (for a file of an
`extends` chain, what the files before it left of them). Failures are
`Unreadable` with a one-line reason that never includes the file's contents.

Which files: a suite's `extends` and `model:` stay inside the folder tree of the suite being loaded (its
`root`; the user widens it with `--extends-root`), so that MuJoCo's parse error cannot tell a pull request
whether a file elsewhere exists or quote it; `package://` and `menagerie://` stay inside their package's or
robot's folder (no `..` or symlink out). Both are decided from the path alone, before a file is opened.
"""

from __future__ import annotations

import errno
import importlib.util
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

from ..errors import quote
from . import limits
from .menagerie import MENAGERIE_SCHEME, menagerie_file, menagerie_missing

__all__ = ["Unreadable", "irregular", "display", "read_text", "resolve", "resolve_model_path", "model_file", "inside",
           "PACKAGE_SCHEME", "ROOT_HINT", "SCHEMES"]

PACKAGE_SCHEME = "package://"

_TYPES = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


_NUL = "the path holds a NUL character"
# how a user lets a suite's `extends` and `model:` reach more of the machine than the suite's own folder tree
ROOT_HINT = ("allow more with --extends-root DIR on the command line, or extends_root=DIR in Python "
             "(extends_root='/' allows any file)")


class Unreadable(Exception):
    """A file that cannot be read as a suite; `str()` is the reason (no content of the file)."""


def _reason(e: OSError) -> str:
    if e.errno == errno.ELOOP:
        return "a symlink loop"
    if e.errno == errno.ENAMETOOLONG:
        return "the file name is too long"
    return e.strerror or type(e).__name__


def resolve(path: Path) -> Path:
    """`path` made absolute with symlinks resolved; a symlink loop or an impossible name is `Unreadable`."""
    try:
        return path.resolve()
    except RuntimeError:  # Python < 3.13 reports a symlink loop this way
        raise Unreadable("a symlink loop") from None
    except OSError as e:
        raise Unreadable(_reason(e)) from None
    except ValueError:
        raise Unreadable(_NUL) from None


def _not_regular(mode: int) -> str | None:
    if stat.S_ISREG(mode):
        return None
    return next((what for test, what in _TYPES if test(mode)), "not a regular file")


def irregular(path: str | os.PathLike[str]) -> str | None:
    """Why `path` must not be opened ('it is a FIFO (named pipe), not a regular file'), or None when it is a
    regular file or cannot be looked at (the reader will say why), so that a reader such as MuJoCo's is
    never handed something that blocks or never ends."""
    try:
        what = _not_regular(os.stat(path).st_mode)
    except (OSError, ValueError):
        return None
    return f"it is {what}, not a regular file" if what else None


def read_text(path: Path, spent: int = 0) -> str:
    """The UTF-8 text of the regular file at `path`, at most `MAX_SUITE_BYTES` less the `spent` bytes of the
    files that extend it (a suite's files together are bounded, not each); anything else is `Unreadable`."""
    limit = max(limits.MAX_SUITE_BYTES - spent, 0)

    def too_large(size: str) -> Unreadable:
        if not spent:
            return Unreadable(f"it is {size} bytes; a suite may be at most {limit:,}")
        return Unreadable(f"it is {size} bytes, and the files that extend it {spent:,}; a suite's files together "
                          f"may be at most {limits.MAX_SUITE_BYTES:,} bytes")

    try:
        what = _not_regular(os.stat(path).st_mode)  # before opening: opening a FIFO or a device may block
        if what:
            raise Unreadable(f"it is {what}, not a regular file")
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as e:
        raise Unreadable(_reason(e)) from None
    except ValueError:  # a NUL character in the path
        raise Unreadable(_NUL) from None
    try:
        info = os.fstat(fd)
        what = _not_regular(info.st_mode)  # it may have been replaced between the two looks
        if what:
            raise Unreadable(f"it is {what}, not a regular file")
        if info.st_size > limit:
            raise too_large(f"{info.st_size:,}")
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 16, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as e:
        raise Unreadable(_reason(e)) from None
    finally:
        os.close(fd)
    if size > limit:
        raise too_large(f"more than {limit:,}")
    try:
        return b"".join(chunks).decode("utf-8")
    except UnicodeDecodeError as e:
        raise Unreadable(f"it is not UTF-8 text (byte {e.object[e.start]:#04x} at offset {e.start})") from None


def display(path: Path) -> str:
    """How a file is named in messages: relative to the working directory when it is below it."""
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def inside(path: Path, root: Path) -> bool:
    """Whether the resolved `path` lies in the folder tree of the resolved `root`."""
    return path == root or root in path.parents


class _Found(NamedTuple):
    """Where a scheme's model lives: the folder it must stay in, the file named inside it, and what owns
    the folder (for messages)."""

    folder: Path
    path: Path
    owner: str
    missing: Callable[[], str] | None = None  # why the file is not there, when the scheme says more than MuJoCo


# packages that hold no robot files of their own: naming them with package:// means menagerie://
_MENAGERIE_PACKAGES = ("mujoco_menagerie", "mujoco-menagerie", "menagerie")


def _in_package(value: str) -> _Found:
    package, _, inner = value[len(PACKAGE_SCHEME):].partition("/")
    if package in _MENAGERIE_PACKAGES:
        raise ValueError(f"Menagerie robots are named {MENAGERIE_SCHEME}<robot folder>/<file>, not through a "
                         f"package; write {quote(MENAGERIE_SCHEME + inner, 120)}")
    spec = None
    if package.isidentifier():
        try:
            spec = importlib.util.find_spec(package)
        except (ImportError, ValueError):
            spec = None
    if spec is None or not spec.submodule_search_locations:
        raise ValueError(f"no installed package {quote(package)} for {quote(value)}; write "
                         f"'package://<package>/<path inside it>' or a path relative to this suite")
    folder = Path(list(spec.submodule_search_locations)[0])
    return _Found(folder, folder / inner, f"the package {quote(package)}")


def _in_menagerie(value: str) -> _Found:
    folder, path = menagerie_file(value)
    return _Found(folder, path, f"the Menagerie robot {quote(folder.name)}", lambda: menagerie_missing(value, folder))


# scheme -> where the model it names lives
SCHEMES: dict[str, Callable[[str], _Found]] = {PACKAGE_SCHEME: _in_package, MENAGERIE_SCHEME: _in_menagerie}


def _confined(path: Path, root: Path) -> Path | None:
    """`path` resolved, when it lies in the tree of `root` (symlinks followed); else None."""
    try:
        resolved, top = resolve(path), resolve(root)
    except Unreadable as e:
        raise ValueError(f"the model path cannot be resolved: {e}") from None
    return resolved if inside(resolved, top) else None


def _scheme_path(value: str) -> str | None:
    """The file a `package://` or `menagerie://` model names, confined to its package's or robot's folder;
    None when `value` has no scheme."""
    scheme = next((s for s in SCHEMES if value.startswith(s)), None)
    if scheme is None:
        return None
    found = SCHEMES[scheme](value)
    path = _confined(found.path, found.folder)
    if path is None:  # said before anything is opened, and without saying whether the file exists
        raise ValueError(f"{quote(value, 160)} leaves the folder of {found.owner} ({found.folder}); a {scheme} "
                         "model is a file inside it, named without '..' and not through a symlink out of it")
    if found.missing is not None and not path.is_file():
        raise ValueError(found.missing())
    return str(path)


def resolve_model_path(value: str, base_dir: Path, root: Path | None = None) -> str:
    """A suite's `model:` as a path: relative to the suite (and inside the tree of `root`, when given),
    inside an installed package, or in Menagerie. ValueError with the fix, before any model file is opened."""
    found = _scheme_path(value)
    if found is not None:
        return found
    if root is None:
        try:
            return str(resolve(base_dir / value))
        except Unreadable as e:
            raise ValueError(f"the model path cannot be resolved: {e}") from None
    path = _confined(base_dir / value, root)
    if path is None:
        raise ValueError(f"{quote(value, 160)} is outside the folder of the suite being loaded ({root}), where "
                         f"model may reach; {ROOT_HINT}, or name a file of an installed package as "
                         "'package://<package>/<path>'")
    return str(path)


def model_file(model: str | os.PathLike[str]) -> str:
    """A model the user named in Python or on the command line (not a suite's `model:`): a `package://` or
    `menagerie://` name resolved as in a suite, any other path as it is. ValueError with the fix."""
    value = os.fspath(model)
    found = _scheme_path(value) if isinstance(value, str) else None
    return value if found is None else found
