"""Which files a suite may name, and reading them: regular files only, bounded in size, never blocking.

`validate` runs in CI on suites from pull requests, so a suite must not make it read a FIFO (blocks
forever), a device such as /dev/zero (never ends), a directory or a socket: a file's type is checked
before it is opened and again on the open descriptor, and at most `MAX_FILE_BYTES` are read. Failures are
`Unreadable` with a one-line reason that never includes the file's contents.
"""

from __future__ import annotations

import errno
import importlib.util
import os
import stat
from pathlib import Path

from ..errors import quote
from . import limits
from .menagerie import MENAGERIE_SCHEME, resolve_menagerie

__all__ = ["Unreadable", "irregular", "display", "read_text", "resolve", "resolve_model_path", "inside", "PACKAGE_SCHEME"]

PACKAGE_SCHEME = "package://"

_TYPES = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


_NUL = "the path holds a NUL character"


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


def read_text(path: Path, limit: int | None = None) -> str:
    """The UTF-8 text of the regular file at `path`, at most `limit` bytes (default `MAX_FILE_BYTES`);
    anything else is `Unreadable`."""
    limit = limits.MAX_FILE_BYTES if limit is None else limit
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
            raise Unreadable(f"it is {info.st_size:,} bytes; a suite may be at most {limit:,}")
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
        raise Unreadable(f"it is more than {limit:,} bytes; a suite may be at most {limit:,}")
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


def resolve_model_path(value: str, base_dir: Path) -> str:
    """A suite's `model:` as a path: relative to the suite, inside an installed package, or in Menagerie."""
    if value.startswith(MENAGERIE_SCHEME):
        return resolve_menagerie(value)
    if value.startswith(PACKAGE_SCHEME):
        package, _, inner = value[len(PACKAGE_SCHEME):].partition("/")
        spec = None
        if package.isidentifier():
            try:
                spec = importlib.util.find_spec(package)
            except (ImportError, ValueError):
                spec = None
        if spec is None or not spec.submodule_search_locations:
            raise ValueError(f"no installed package {quote(package)} for {quote(value)}; write "
                             f"'package://<package>/<path inside it>' or a path relative to this suite")
        return str(Path(list(spec.submodule_search_locations)[0]) / inner)
    try:
        return str(resolve(base_dir / value))
    except Unreadable as e:
        raise ValueError(f"the model path cannot be resolved: {e}") from None
