"""`python -m sensorcfg.config [OUT]` regenerates the committed JSON Schema (schemas/sensor-suite.schema.json)."""

import sys

from . import write_schema

write_schema(sys.argv[1] if len(sys.argv) > 1 else "schemas/sensor-suite.schema.json")
