"""Noise stage configs: the stage table, validation messages and locations, and the JSON Schema."""

from __future__ import annotations

import typing

import pytest
from pydantic import BaseModel, TypeAdapter, ValidationError

from sensorcfg.config.noise import STAGES, NoiseStage, parse_quantity
from sensorcfg.config.units import DURATION_UNITS, RATE_UNITS
from sensorcfg.noise.pipeline import BUILDERS

STAGE_LIST = TypeAdapter(tuple[NoiseStage, ...])


def errors(stages: list) -> list[tuple[tuple, str]]:
    with pytest.raises(ValidationError) as info:
        STAGE_LIST.validate_python(stages)
    return [(e["loc"], e["msg"]) for e in info.value.errors()]


def test_the_table_is_the_union_and_the_runtime():
    """One table: the union's members, the runtime builders and the type names all agree."""
    union = typing.get_args(typing.get_args(NoiseStage)[0])
    assert [m.model_fields["type"].annotation.__args__[0] for m in union] == list(STAGES)
    assert [info.model for info in STAGES.values()] == list(union)
    assert set(BUILDERS) == set(STAGES)
    assert list(STAGES) == ["gaussian", "uniform", "bias", "scale", "random_walk", "quantize", "clip", "dropout",
                            "outlier", "lowpass", "misalign", "custom"]


@pytest.mark.parametrize("name", list(STAGES))
def test_every_field_has_a_description_and_examples(name):
    model: type[BaseModel] = STAGES[name].model
    assert model.model_config.get("frozen") and model.model_config.get("extra") == "forbid"
    for field_name, field in model.model_fields.items():
        assert field.description, f"{name}.{field_name} has no description"
        assert field.examples, f"{name}.{field_name} has no examples"


def test_json_schema_is_a_discriminated_union_with_every_stage():
    schema = STAGE_LIST.json_schema()
    mapping = schema["items"]["discriminator"]["mapping"]
    assert sorted(mapping) == sorted(STAGES)
    gaussian = schema["$defs"]["GaussianStage"]
    assert gaussian["additionalProperties"] is False
    std = gaussian["properties"]["std"]
    assert std["anyOf"][0] == {"type": "number", "minimum": 0}
    assert std["anyOf"][1]["items"] == {"type": "number", "minimum": 0}
    assert "custom" in mapping and schema["$defs"]["CustomStage"]["properties"]["callable"]["type"] == "string"


def test_values_are_numbers_or_tuples_in_si_units():
    a, b, c = STAGE_LIST.validate_python([
        {"type": "gaussian", "std": [0.1, 0.2, 0.3]},
        {"type": "random_walk", "std": 1, "correlation_time": ["50ms", 2, "500us"]},
        {"type": "lowpass", "cutoff": "2kHz"},
    ])
    assert a.std == (0.1, 0.2, 0.3) and a.mean == 0.0
    assert b.correlation_time == pytest.approx((0.05, 2.0, 0.0005))
    assert c.cutoff == 2000.0
    with pytest.raises(ValidationError):  # frozen
        a.std = 1.0  # type: ignore[misc]


@pytest.mark.parametrize("text, units, expected", [
    pytest.param("50ms", DURATION_UNITS, 0.05, id="ms"),
    pytest.param("2 s", DURATION_UNITS, 2.0, id="space"),
    pytest.param("1.5e-3s", DURATION_UNITS, 0.0015, id="exponent"),
    pytest.param("20Hz", RATE_UNITS, 20.0, id="hz"),
    pytest.param(3, RATE_UNITS, 3.0, id="number"),
])
def test_parse_quantity(text, units, expected):
    assert parse_quantity(text, units, "duration") == pytest.approx(expected)


BAD = [
    pytest.param({"type": "gausian", "std": 1}, ("type",),
                 "unknown noise stage type 'gausian' (did you mean 'gaussian'?); stage types are gaussian, uniform, "
                 "bias, scale, random_walk, quantize, clip, dropout, outlier, lowpass, misalign, custom", id="unknown-type"),
    pytest.param({"type": "randomwalk", "std": 1}, ("type",),
                 "unknown noise stage type 'randomwalk' (did you mean 'random_walk'?); stage types are gaussian, "
                 "uniform, bias, scale, random_walk, quantize, clip, dropout, outlier, lowpass, misalign, custom",
                 id="unknown-type-2"),
    pytest.param({"std": 1}, (), "a noise stage needs a `type`: one of gaussian, uniform, bias, scale, random_walk, "
                 "quantize, clip, dropout, outlier, lowpass, misalign, custom", id="no-type"),
    pytest.param({"type": "gaussian", "std": -0.1}, ("std",), "a standard deviation must be >= 0, got -0.1",
                 id="negative-std"),
    pytest.param({"type": "gaussian", "std": [0.1, -1]}, ("std", 1), "a standard deviation must be >= 0, got -1",
                 id="negative-std-entry"),
    pytest.param({"type": "gaussian", "std": []}, ("std",), "an empty list gives no values; give a number or one "
                 "entry per value of the observation", id="empty-list"),
    pytest.param({"type": "gaussian", "std": "big"}, ("std",), "expected a number, got 'big'", id="text-std"),
    pytest.param({"type": "gaussian", "std": True}, ("std",), "expected a number, got True", id="bool-std"),
    pytest.param({"type": "gaussian", "std": float("inf")}, ("std",), "expected a finite number, got inf",
                 id="inf-std"),
    pytest.param({"type": "gaussian", "std": 1, "sigma": 2}, ("sigma",), "Extra inputs are not permitted",
                 id="extra-key"),
    pytest.param({"type": "uniform", "low": 1, "high": 0}, ("low",),
                 "low must not exceed high: low is 1 and high is 0; swap them", id="low-gt-high"),
    pytest.param({"type": "uniform", "low": [0, 2], "high": 1}, ("low",),
                 "low must not exceed high (entry 1): low is 2 and high is 1; swap them", id="low-gt-high-entry"),
    pytest.param({"type": "bias", "low": 1, "high": -1}, ("low",),
                 "low must not exceed high: low is 1 and high is -1; swap them", id="bias-low-gt-high"),
    pytest.param({"type": "bias", "std": -1}, ("std",), "a standard deviation must be >= 0, got -1",
                 id="bias-negative-std"),
    pytest.param({"type": "bias"}, (), "give std (with an optional mean) for a normal draw, or low and high for a "
                 "uniform draw", id="bias-nothing"),
    pytest.param({"type": "scale", "std": 0.1, "low": 0.9, "high": 1.1}, ("low",),
                 "give either mean/std (a normal draw) or low/high (a uniform draw), not both", id="scale-both"),
    pytest.param({"type": "scale", "low": 0.9}, (), "a uniform draw needs both low and high; high is missing",
                 id="scale-half"),
    pytest.param({"type": "dropout", "p": 1.5}, ("p",), "a probability must be <= 1, got 1.5", id="p-above-1"),
    pytest.param({"type": "outlier", "p": -0.1, "scale": 1}, ("p",), "a probability must be >= 0, got -0.1",
                 id="p-below-0"),
    pytest.param({"type": "dropout", "p": [0.1, 0.2]}, ("p",), "a list of p (one per value) needs `per: value`; a "
                 "whole sample is lost with one probability", id="dropout-list-per-sample"),
    pytest.param({"type": "dropout", "p": 0.1, "mode": "last"}, ("mode",),
                 "Input should be 'hold', 'zero' or 'nan'", id="dropout-mode"),
    pytest.param({"type": "quantize", "step": 0}, ("step",), "a quantisation step must be > 0, got 0",
                 id="zero-step"),
    pytest.param({"type": "clip"}, (), "clip needs min, max or both", id="clip-nothing"),
    pytest.param({"type": "clip", "min": 2, "max": 1}, ("min",),
                 "min must not exceed max: min is 2 and max is 1; swap them", id="clip-min-gt-max"),
    pytest.param({"type": "random_walk", "std": 1, "correlation_time": "0s"}, ("correlation_time",),
                 "a correlation time must be > 0, got '0s'", id="zero-correlation-time"),
    pytest.param({"type": "random_walk", "std": 1, "correlation_time": "5 parsecs"}, ("correlation_time",),
                 "unknown unit 'parsecs' in '5 parsecs'; a duration takes s, ms, us, µs, ns", id="bad-unit"),
    pytest.param({"type": "lowpass", "cutoff": "20hz"}, ("cutoff",),
                 "unknown unit 'hz' in '20hz' (did you mean 'Hz'?); a frequency takes Hz, kHz", id="unit-case"),
    pytest.param({"type": "lowpass", "cutoff": "fast"}, ("cutoff",),
                 "expected a frequency such as '20Hz' or a number (Hz), got 'fast'", id="not-a-frequency"),
    pytest.param({"type": "custom", "callable": "os.path"}, ("callable",),
                 "a callable is written 'module:function' (for example 'mypkg.noise:corrupt'); got 'os.path': it has "
                 "no ':' (one separates the module from the function)", id="callable-form"),
    pytest.param({"type": "custom", "callable": 3}, ("callable",),
                 "expected 'module:function' (e.g. 'mypkg.noise:corrupt'), got 3", id="callable-not-text"),
]


@pytest.mark.parametrize("stage, loc, message", BAD)
def test_bad_stage(stage, loc, message):
    """Each mistake is one error at the stage's field (no union tag in loc), saying what to do."""
    assert errors([{"type": "gaussian", "std": 1}, stage]) == [((1, *loc), message)]


def test_not_a_mapping():
    assert errors(["gaussian"]) == [((0,), "a noise stage is a mapping with a `type` (one of gaussian, uniform, "
                                           "bias, scale, random_walk, quantize, clip, dropout, outlier, lowpass, "
                                           "misalign, custom), got 'gaussian'")]


def test_every_problem_is_reported_at_once():
    got = errors([{"type": "gaussian", "std": -1}, {"type": "quantize", "step": 0},
                  {"type": "dropout", "p": 2}])
    assert [loc for loc, _ in got] == [(0, "std"), (1, "step"), (2, "p")]


def test_validated_stages_revalidate():
    stages = STAGE_LIST.validate_python([{"type": "scale", "std": 0.1}, {"type": "bias", "low": -1, "high": 1}])
    assert STAGE_LIST.validate_python(stages) == stages
    assert stages[0].normal_params() == (1.0, 0.1)  # scale draws around 1
    assert not stages[0].uniform and stages[1].uniform
