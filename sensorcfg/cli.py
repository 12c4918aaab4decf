"""The `sensorcfg` command line (minimal entry point; the full CLI lives in sensorcfg.cli)."""

from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    from . import __version__

    args = sys.argv[1:] if argv is None else argv
    if args[:1] == ["--version"]:
        print(f"sensorcfg {__version__}")
        return 0
    print("usage: sensorcfg --version", file=sys.stderr)
    return 2
