"""The config layer: the suite language as frozen pydantic models, loading, units, and the JSON Schema.

Nothing here imports mujoco; names, kinds and time in steps are resolved against a model by
`sensorcfg.binding`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .loader import LoadedSuite, LoadResult, load_path, load_text, parse_path, parse_text, resolve_model_path
from .models import (CameraConfig, ChoiceDraw, DefaultsConfig, OptionsConfig, SensorConfig, SuiteConfig,
                     UniformDraw)
from .units import to_steps

__all__ = ["CameraConfig", "ChoiceDraw", "DefaultsConfig", "LoadResult", "LoadedSuite", "OptionsConfig",
           "SensorConfig", "SuiteConfig", "UniformDraw", "json_schema", "load_path", "load_text", "parse_path",
           "parse_text", "resolve_model_path", "schema_text", "to_steps", "write_schema"]

# Files that `extends` another give partial sensors (only the keys they change), so the editor schema
# requires no key of a suite or a sensor; `sensorcfg validate` checks that the merged suite is complete.


def json_schema() -> dict[str, Any]:
    """The JSON Schema of a suite file, generated from the pydantic models (draft 2020-12)."""
    schema = SuiteConfig.model_json_schema()
    schema.pop("required", None)
    schema["$defs"]["SensorConfig"].pop("required", None)
    # In a file that extends another, `name: null` removes an inherited sensor.
    sensors = schema["properties"]["sensors"]
    for pattern, sensor in sensors["patternProperties"].items():
        sensors["patternProperties"][pattern] = {"anyOf": [sensor, {"type": "null"}]}
    sensors["additionalProperties"] = False  # a name outside the pattern is an error in the editor too
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema}


def schema_text() -> str:
    """The schema as committed in `schemas/sensor-suite.schema.json` (stable formatting)."""
    return json.dumps(json_schema(), indent=2, ensure_ascii=False) + "\n"


def write_schema(path: str | Path) -> None:
    Path(path).write_text(schema_text(), encoding="utf-8")

