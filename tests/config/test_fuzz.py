"""Property-based fuzzing of the suite language, with suites and YAML text generated from the JSON Schema.

Two properties:
- whatever the text, `loads`, `Suite.check` and `sensorcfg validate` raise nothing but sensorcfg's own
  errors (`SuiteError` for the suite's mistakes), and validate prints a report with exit status 0 or 1;
- a suite that validates (imports included) builds, runs 20 control steps, and every observation matches
  its spec (shape, dtype and bounds: `spec.validate`) and is finite (unless its noise drops readings to NaN).

Suites are drawn from `schemas/sensor-suite.schema.json` (every key, enum, pattern, bound and example it
states), with hostile values mixed in for the first property, and with each sensor's kind and element
drawn from the bundled robot for the second (the schema cannot know the model's names).

The profile is chosen by SENSORCFG_FUZZ_PROFILE: `ci` (default, 50 examples per property, what nox runs)
or `long` (2,000 examples) for a local campaign:

    SENSORCFG_FUZZ_PROFILE=long python -m pytest -q tests/config/test_fuzz.py
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import sensorcfg
import sensorcfg.assets
import sensorcfg.config.models
import sensorcfg.errors
from sensorcfg import SuiteError
from sensorcfg.cli import main

from conftest import ROOT

settings.register_profile("ci", max_examples=50, deadline=None, derandomize=True, database=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.register_profile("long", max_examples=2000, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.load_profile(os.environ.get("SENSORCFG_FUZZ_PROFILE", "ci"))

SCHEMA = json.loads((ROOT / "schemas" / "sensor-suite.schema.json").read_text())
ROBOT = str(sensorcfg.assets.path("robot.xml"))
SMALL = 12  # the largest integer drawn above a schema minimum (steps, buffer, pixels): keeps runs short

# Kinds and elements the bundled robot has, as a suite names them (the schema only knows their form).
READS = [
    {"kind": "qpos", "element": "joint:*"}, {"kind": "qvel", "element": ["joint:shoulder", "joint:elbow"]},
    {"kind": "qpos", "element": "joint:*", "within": "body:upper_arm", "index": "0:2"},
    {"kind": "sensordata", "element": ["sensor:imu_gyro", "sensor:imu_accel"]},
    {"kind": "sensordata", "element": "sensor:imu_quat"}, {"kind": "xpos", "element": "body:hand"},
    {"kind": "xquat", "element": "body:*"}, {"kind": "xpos", "element": "site:hand_site", "index": 2},
    {"kind": "force", "element": "actuator:*"}, {"kind": "ctrl", "element": "actuator:*"},
    {"kind": "rgb", "element": "camera:wrist", "camera": {"width": 8, "height": 6}},
    {"kind": "depth", "element": "camera:overview", "camera": {"width": 6, "height": 4}},
    {"kind": "segmentation", "element": "camera:wrist", "camera": {"width": 4, "height": 4}},
    {"kind": "generic", "callable": "sensorcfg.assets.demo_sensors:hand_to_target"},
]
READ_KEYS = ("kind", "element", "within", "index", "camera", "callable")
SENSOR_PATTERN = sensorcfg.config.models.SENSOR_NAME_PATTERN

# -- from the schema -------------------------------------------------------------------------------------


def _resolve(node: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in node:
        node = SCHEMA["$defs"][node["$ref"].rsplit("/", 1)[1]]
    return node


def _number(node: dict[str, Any], integer: bool) -> st.SearchStrategy[Any]:
    low = node.get("minimum", node.get("exclusiveMinimum", -SMALL))
    high = node.get("maximum", low + SMALL if integer else max(low, 0) + 2)
    if integer:
        return st.integers(int(low) + ("exclusiveMinimum" in node), int(min(high, low + SMALL)))
    return st.floats(low, min(high, low + 4), exclude_min="exclusiveMinimum" in node, allow_nan=False)


def from_schema(node: dict[str, Any], depth: int = 0, prefer: int = 1) -> st.SearchStrategy[Any]:
    """Values the schema `node` describes (its examples `prefer` times as often as each other form), small
    enough to run."""
    node = _resolve(node)
    options = []
    if node.get("examples") and depth > 0:
        options += [st.sampled_from(node["examples"])] * prefer
    if "const" in node:
        return st.just(node["const"])
    if "enum" in node:
        return st.sampled_from(node["enum"])
    for key in ("anyOf", "oneOf"):
        if key in node:
            options += [from_schema(n, depth + 1, prefer) for n in node[key]]
    kind = node.get("type")
    if kind == "object":
        props = node.get("properties", {})
        required = set(node.get("required", ()))
        optional = {k: from_schema(v, depth + 1, prefer) for k, v in props.items() if k not in required}
        needed = {k: from_schema(props[k], depth + 1, prefer) for k in required}
        fixed = st.fixed_dictionaries(needed, optional=optional)
        if node.get("patternProperties"):
            [(pattern, value)] = node["patternProperties"].items()
            names = st.from_regex(pattern, fullmatch=True).map(lambda s: s[:16])
            fixed = st.dictionaries(names, from_schema(value, depth + 1, prefer), max_size=4)
        options.append(fixed)
    elif kind == "array":
        items = from_schema(node.get("items", {}), depth + 1, prefer)
        least = node.get("minItems", 0)  # (a quaternion has 4 items)
        options.append(st.lists(items, min_size=least, max_size=max(least, min(node.get("maxItems", 3), 3))))
    elif kind in ("integer", "number"):
        options.append(_number(node, kind == "integer"))
    elif kind == "string":
        pattern = node.get("pattern")
        options.append(st.from_regex(pattern, fullmatch=True) if pattern else st.text(max_size=12))
    elif kind == "boolean":
        options.append(st.booleans())
    elif kind == "null":
        options.append(st.none())
    return st.one_of(options) if options else st.none()


SUITES = from_schema(SCHEMA)
LIKELY = from_schema(SCHEMA, prefer=6)  # mostly the schema's own examples: suites that validate more often
SENSORS = from_schema(SCHEMA["properties"]["sensors"]["patternProperties"][SENSOR_PATTERN]["anyOf"][0], 1, prefer=6)

# -- hostile values and text ----------------------------------------------------------------------------

JUNK = st.one_of(
    st.integers(), st.floats(), st.text(max_size=30), st.booleans(), st.none(),
    st.sampled_from(["\n", "\x1b[31m", "a\nsrc/main.py:1:1: error: x", "1e999s", "-1ms", "0Hz", "nanms", "9" * 40,
                     "joint:", "body:", "camera:*", ":", "..", "x:y", "package://", "/dev/zero", "../../etc"]),
    st.lists(st.integers(-3, 3), max_size=3), st.dictionaries(st.text(max_size=5), st.integers(), max_size=2))


def _corrupt(value: Any, draw: Any) -> Any:
    """`value` with a few of its leaves or keys replaced by hostile values."""
    if isinstance(value, dict):
        out = {k: (_corrupt(v, draw) if draw(st.integers(0, 3)) else draw(JUNK)) for k, v in value.items()}
        if draw(st.integers(0, 4)) == 0:
            out[draw(st.one_of(st.sampled_from(READ_KEYS + ("interval", "noise", "defaults")),
                               st.text(max_size=8)))] = draw(JUNK)
        return out
    if isinstance(value, list):
        return [(_corrupt(v, draw) if draw(st.integers(0, 3)) else draw(JUNK)) for v in value]
    return value


@st.composite
def hostile_texts(draw: Any) -> str:
    suite = draw(SUITES)
    if draw(st.booleans()):
        suite = _corrupt(suite, draw)
    text = yaml.safe_dump(suite, sort_keys=False, allow_unicode=True)
    edit = draw(st.integers(0, 3))
    if edit == 1:  # cut or splice the text
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.sampled_from(["", "\n", "  ", "[", "{", ": ", "!!int x", "&a", "*a", "\t", "- "]))
        text += text[at:] if draw(st.booleans()) else ""
    elif edit == 2:
        text = draw(st.text(max_size=60)) + text
    return text


OVERRIDE_KEYS = st.one_of(
    st.sampled_from(["sensors.a", "sensors.a.interval", "defaults.buffer", "defaults.noise.0.std", "options",
                     "sensors.a.noise.-1", "extends", "model", "sensors", "sensors.a.noise.\u0661.std", ""]),
    st.text(max_size=12))
OVERRIDES = st.lists(st.builds(lambda key, value: f"{key}={value}", OVERRIDE_KEYS, st.one_of(
    st.sampled_from(["null", "!!python/name:os.system", "{kind: qpos}", "[", "1e999s", "*a", "!!int x", "4ms"]),
    st.text(max_size=16))), max_size=2)


def _validate_cli(text: str, overrides: list[str]) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "suite.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            sets = [arg for o in overrides for arg in ("--set", o)]
            code = main(["validate", str(path), "--model", ROBOT, "--format", "json", *sets])
    if code == 2:  # a malformed --set is a usage error: one line, nothing on stdout
        assert out.getvalue() == "" and "error: argument --set" in err.getvalue()
        return
    report = json.loads(out.getvalue())
    assert code in (0, 1) and report["valid"] == (code == 0)
    assert all(p["message"].isprintable() and p["file"].isprintable() for p in report["problems"])


@given(hostile_texts(), OVERRIDES)
def test_any_text_raises_only_sensorcfg_errors(text: str, overrides: list[str]) -> None:
    try:
        suite = sensorcfg.loads(text, overrides, base_dir=tempfile.gettempdir())
    except SuiteError as e:
        event("load problem")
        assert e.problems and all(p.format().isprintable() for p in e.problems)
    else:
        event("loaded")
        problems = suite.check(ROBOT)
        assert all(isinstance(p, sensorcfg.Problem) for p in problems)
    if not any("\ud800" <= c <= "\udfff" for c in text + "".join(overrides)):  # not encodable: not a file
        _validate_cli(text, overrides)


# -- valid suites run ---------------------------------------------------------------------------------


@st.composite
def runnable_suites(draw: Any) -> dict[str, Any]:
    suite = draw(LIKELY)
    suite = {k: v for k, v in suite.items() if k not in ("extends", "model")}
    suite["model"] = ROBOT
    sensors = {}
    names = st.from_regex(SENSOR_PATTERN, fullmatch=True).map(lambda s: s[:16])
    for name, sensor in draw(st.dictionaries(names, SENSORS, min_size=1, max_size=4)).items():
        sensor = {k: v for k, v in (sensor or {}).items() if k not in READ_KEYS}
        read = draw(st.sampled_from(READS))
        sensors[name] = {**read, **sensor}
        if read["kind"] in ("rgb", "depth", "segmentation") and isinstance(sensors[name].get("noise"), list):
            sensors[name]["noise"] = [s for s in sensors[name]["noise"] if s.get("type") in ("gaussian", "clip")]
    suite["sensors"] = sensors
    defaults = suite.get("defaults")
    if isinstance(defaults, dict) and "camera" in defaults:
        defaults["camera"] = {"width": 8, "height": 8}
    return suite


@given(runnable_suites(), st.integers(0, 2**32 - 1))
def test_a_suite_that_validates_runs_and_matches_its_spec(config: dict[str, Any], seed: int) -> None:
    text = yaml.safe_dump(config, sort_keys=False)
    try:
        suite = sensorcfg.loads(text)
    except SuiteError as e:
        event(f"load problem: {e.problems[0].message[:50]}")
        return  # the schema allows what only the rules between keys forbid: the first property covers it
    problems = suite.check(import_callables=True)
    if problems:
        event(f"model problem: {problems[0].message[:50]}")
        return
    event(f"ran {len(suite.sensors)} sensors")
    env = sensorcfg.Environment(ROBOT, suite, seed=seed)
    spec = env.observation_spec()
    zero = np.zeros(env.action_spec().shape)
    observations = [env.reset().observation] + [env.step(zero).observation for _ in range(20)]
    nan_allowed = {name for name, s in suite.sensors.items() if any(getattr(n, "mode", "") == "nan" for n in s.noise)}
    for observation in observations:
        assert observation.keys() == spec.keys()
        for name, value in observation.items():
            spec[name].validate(value)
            if name not in nan_allowed:  # a reading is a number: inf or nan would be silently wrong
                assert np.isfinite(value).all(), (name, value)
