"""`python -m sensorcfg.config [OUT]` regenerates the committed JSON Schema (`schemas/sensor-suite.schema.json`
from the repository's root): `sensorcfg schema -o OUT`, with its messages and exit status."""

import sys

from ..cli import main

_args = sys.argv[1:]
if _args and _args[0].startswith("-"):  # -h, --help, -o FILE: as `sensorcfg schema`
    sys.exit(main(["schema", *_args]))
sys.exit(main(["schema", "-o", _args[0] if _args else "schemas/sensor-suite.schema.json"]))
