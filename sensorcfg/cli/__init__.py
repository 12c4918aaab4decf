"""The `sensorcfg` command line: validate, schema, spec, run, demo.

`main` parses the arguments, hands them to the command's handler, and turns a user's mistake into a message
and an exit code: 0 success (every suite valid), 1 a suite or model has problems, 2 a usage or I/O error.
One module per command; shared pieces live in `common` (errors, suite and model resolution) and `report`
(tables, progress bar).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from .._version import __version__
from ..errors import MESSAGE_LIMIT, SensorcfgError, SuiteError, printable
from .. import compiled
from ..noise import streams
from . import demo, run, schema, spec, validate
from .common import EXIT_CODES_HELP, EXIT_INVALID, EXIT_USAGE, HelpFormatter, UsageError, user_code_failure

__all__ = ["main", "build_parser"]

COMMANDS = (validate, schema, spec, run, demo)

DESCRIPTION = """Declarative robot sensing for MuJoCo: check, inspect and run YAML sensor suites."""

EXAMPLES = """examples:
  sensorcfg demo                                     run the bundled demo suite end to end
  sensorcfg validate configs/                        check every suite in a folder
  sensorcfg spec configs/sim2real.yaml               shapes, rates, delays and noise of each observation
  sensorcfg run configs/vision.yaml --steps 500 --out obs.npz --plot obs.png
  sensorcfg schema -o sensor-suite.schema.json       JSON Schema for editors

'sensorcfg COMMAND --help' describes each command; 'python -m sensorcfg' works the same."""


class _Parser(argparse.ArgumentParser):
    """argparse, with usage errors that name the command and point at its --help."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n(see '{self.prog} --help')\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="sensorcfg", description=DESCRIPTION, epilog=EXAMPLES + "\n\n" + EXIT_CODES_HELP,
                     formatter_class=HelpFormatter)
    parser.add_argument("--version", action="version",
                        version=f"sensorcfg {__version__} (noise numbers: {streams.KERNEL}"
                                + (f", Philox {compiled.PHILOX})" if compiled.PHILOX else ")"))
    sub = parser.add_subparsers(title="commands", metavar="COMMAND", parser_class=_Parser)
    for command in COMMANDS:
        command.add_parser(sub, EXIT_CODES_HELP)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok or valid, 1 problems found, 2 usage or I/O error)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help, --version and usage errors: argparse exits; return its status
        return e.code if isinstance(e.code, int) else EXIT_USAGE
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.print_help(sys.stderr)
        return EXIT_USAGE
    try:
        return handler(args)
    except UsageError as e:
        print(f"sensorcfg: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except SuiteError as e:
        for problem in e.problems:  # one without a place is about the command, not a file
            print(problem.format() if problem.file else f"sensorcfg: error: {printable(problem.message)}",
                  file=sys.stderr)
        return EXIT_INVALID
    except SensorcfgError as e:  # ArgumentError, UnsupportedError: about the command, not a suite
        print(f"sensorcfg: error: {printable(str(e), MESSAGE_LIMIT)}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("sensorcfg: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `sensorcfg schema | head`: the reader left; not an error of ours
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the interpreter's final flush does not complain
        return 0
    except Exception as e:  # noqa: BLE001 - the user's sensor code failing is their error to see, briefly
        lines = user_code_failure(e)
        if lines is None:
            raise  # a bug in sensorcfg: the traceback is for us
        print("\n".join(lines), file=sys.stderr)
        return EXIT_INVALID
