"""The JSON Schema for editors: generated from the configs, committed, and agreeing with the examples."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml

from sensorcfg.assets import path as asset_path
from sensorcfg.config import json_schema, schema_text

from conftest import ROOT

SCHEMA_FILE = ROOT / "schemas" / "sensor-suite.schema.json"
EXAMPLES = sorted((ROOT / "configs").glob("*.yaml")) + [asset_path("demo.yaml")]


@pytest.fixture(scope="module")
def validator() -> jsonschema.Draft202012Validator:
    schema = json.loads(SCHEMA_FILE.read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_committed_schema_is_up_to_date() -> None:
    assert SCHEMA_FILE.read_text() == schema_text(), (
        "schemas/sensor-suite.schema.json is stale: regenerate it with `python -m sensorcfg.config`")


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_validate_against_the_schema(path: Path, validator) -> None:
    errors = [f"{'.'.join(map(str, e.absolute_path))}: {e.message}"
              for e in validator.iter_errors(yaml.safe_load(path.read_text()))]
    assert errors == []


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_name_the_schema(path: Path) -> None:
    first = path.read_text().splitlines()[0]
    assert first.startswith("# yaml-language-server: $schema=")
    target = (path.parent / first.split("$schema=", 1)[1]).resolve()
    assert target == SCHEMA_FILE


@pytest.mark.parametrize(("text", "where"), [
    pytest.param("sensors: {a: {kind: qpos, buffr: 2}}", "sensors.a", id="unknown-key"),
    pytest.param("sensors: {a: {kind: qpos, interval: 7 parsecs}}", "sensors.a.interval", id="unit"),
    pytest.param("sensors: {a: {kind: qpos, aggregator: avg}}", "sensors.a.aggregator", id="aggregator"),
    pytest.param("sensors: {a: {kind: qpos, noise: [{type: gaussian, std: -1}]}}", "sensors.a.noise.0", id="noise"),
    pytest.param("sensors: {a.b: {kind: qpos}}", "sensors", id="name"),
    pytest.param("version: 2\nsensors: {}", "version", id="version"),
])
def test_schema_rejects_mistakes(text: str, where: str, validator) -> None:
    errors = list(validator.iter_errors(yaml.safe_load(text)))
    assert errors
    assert any(".".join(map(str, e.absolute_path)).startswith(where) for e in _with_context(errors))


def _with_context(errors):
    """Errors and, recursively, the errors of the anyOf/oneOf branches they summarise."""
    for error in errors:
        yield error
        yield from _with_context(error.context or [])


def _properties(schema: dict[str, Any]):
    for name, definition in [("suite", schema)] + list(schema["$defs"].items()):
        for field, spec in definition.get("properties", {}).items():
            if field != "type":  # a noise stage's tag names itself
                yield f"{name}.{field}", spec


@pytest.mark.parametrize(("field", "spec"), list(_properties(json_schema())), ids=lambda v: v if isinstance(v, str) else "")
def test_every_field_has_a_description_and_an_example(field: str, spec: dict[str, Any]) -> None:
    assert spec.get("description"), field
    assert spec.get("examples"), field
