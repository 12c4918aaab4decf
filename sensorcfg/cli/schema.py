"""`sensorcfg schema`: the JSON Schema of a suite file, for editors (yaml-language-server) and CI."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from .common import EXIT_OK, HelpFormatter, UsageError

__all__ = ["add_parser"]

EXAMPLES = """examples:
  sensorcfg schema                                  print the schema
  sensorcfg schema -o schemas/sensor-suite.schema.json

Editors that use yaml-language-server pick it up from a comment on a suite's first line:
  # yaml-language-server: $schema=schemas/sensor-suite.schema.json"""


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("schema", help="print (or write) the JSON Schema of a suite file",
                       description="The JSON Schema (draft 2020-12) of a sensor suite file, generated from the "
                       "same models that validate suites.", epilog=EXAMPLES + "\n\n" + epilog,
                       formatter_class=HelpFormatter)
    p.add_argument("-o", "--output", metavar="FILE", help="write the schema to FILE instead of standard output")
    p.set_defaults(handler=command)


def command(args: argparse.Namespace) -> int:
    from ..config import schema_text

    text = schema_text()
    if args.output is None:
        print(text, end="")
        return EXIT_OK
    try:
        Path(args.output).write_text(text, encoding="utf-8")
    except OSError as e:
        raise UsageError(f"{args.output}: cannot write the schema: {e.strerror or e}") from None
    print(f"wrote {args.output}")
    return EXIT_OK
