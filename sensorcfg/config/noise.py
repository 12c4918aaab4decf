"""Noise stage configs: the one table of stages that validation, the JSON Schema and error hints read.

A sensor's `noise:` is a list of stages applied in order to each raw sample. Each stage is a frozen model
selected by its `type` (`STAGES` maps the type name to the model and to what it applies to). Numeric
parameters are a number or a list with one entry per value of the observation; whether a list fits the
observation's shape is checked when the sensor is bound (`sensorcfg.noise.build_noise`), since only then is
the shape known. Everything that can be checked without the model is checked here, as pydantic errors whose
`loc` ends in the stage's field (`('noise', 0, 'std')`, `('noise', 1, 'type')`), with no union tag segment, so
the suite layer can point at the YAML node.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, WithJsonSchema, WrapValidator, model_validator
from pydantic.json_schema import SkipJsonSchema
from pydantic_core import PydanticCustomError

from ..errors import did_you_mean, quote
from .callables import CALLABLE_PATTERN, callable_problem
from .parameters import (PER_VALUE, Duration, EpisodeUniform, Frequency, PerValue, Probability, Real, Std, Step,
                         error_at, ordered, parse_quantity)

__all__ = ["EpisodeUniform", "NoiseStage", "STAGES", "StageInfo", "IMAGE_STAGES", "parse_quantity"]

_MODEL = ConfigDict(frozen=True, extra="forbid")


def _type(name: str, what: str) -> Any:
    return Field(description=what, examples=[name])


# -- the stages ---------------------------------------------------------------------------------------


class GaussianStage(BaseModel):
    """Additive white noise: every value of every sample gets an independent draw of N(mean, std^2).

    Give `std` (per sample) or `density` (per square-root hertz, as IMU datasheets do): the std per sample
    is then density * sqrt(sample rate), the sensor's nominal rate, so a suite stays right when a rate
    changes.
    """

    model_config = _MODEL
    type: Literal["gaussian"] = _type("gaussian", "Additive white noise drawn from N(mean, std^2) per value.")
    mean: Real = Field(0.0, description="Mean of the noise, in the sensor's units. " + PER_VALUE,
                       examples=[0.0, [0.0, 0.0, 0.01]])
    std: Std | None = Field(None, description="Standard deviation of the noise per sample, in the sensor's units. "
                            + PER_VALUE, examples=[0.01, [0.01, 0.01, 0.02]])
    density: Std | None = Field(None, description="Noise density instead of `std`: units per square-root hertz; "
                                "std per sample = density * sqrt(the sensor's sample rate). " + PER_VALUE,
                                examples=[0.0003])

    @model_validator(mode="after")
    def _check(self) -> GaussianStage:
        if (self.std is None) == (self.density is None):
            raise PydanticCustomError("noise_gaussian", "gaussian takes std (per sample) or density (per "
                                      "square-root hertz), one of them")
        return self

    def at_rate(self, rate: float) -> GaussianStage:
        """This stage with its std per sample for a sensor sampled at `rate` Hz (density given)."""
        if self.density is None:
            return self
        root = math.sqrt(rate)
        std: PerValue
        if isinstance(self.density, EpisodeUniform):
            std = self.density.scaled(root)
        else:
            std = tuple(d * root for d in self.density) if isinstance(self.density, tuple) else self.density * root
        return self.model_copy(update={"std": std, "density": None})


class UniformStage(BaseModel):
    """Additive white noise drawn uniformly from [low, high) per value and sample."""

    model_config = _MODEL
    type: Literal["uniform"] = _type("uniform", "Additive white noise drawn from U(low, high) per value.")
    low: Real = Field(description="Lower end of the noise, in the sensor's units. " + PER_VALUE, examples=[-0.05])
    high: Real = Field(description="Upper end of the noise, in the sensor's units. " + PER_VALUE, examples=[0.05])

    @model_validator(mode="after")
    def _check(self) -> UniformStage:
        ordered(self.low, self.high, ("low", "high"))
        return self


class _EpisodeDraw(BaseModel):
    """A value drawn once per episode and per value: normal {mean, std} or uniform {low, high}."""

    model_config = _MODEL
    _centre: ClassVar[float] = 0.0
    mean: Real | None = Field(None, description="Mean of the normal draw (give `std` too, or alone for a "
                              "constant). " + PER_VALUE, examples=[0.0])
    std: Std | None = Field(None, description="Standard deviation of the normal draw. " + PER_VALUE,
                            examples=[0.02])
    low: Real | None = Field(None, description="Lower end of the uniform draw (with `high`). " + PER_VALUE,
                             examples=[-0.05])
    high: Real | None = Field(None, description="Upper end of the uniform draw (with `low`). " + PER_VALUE,
                              examples=[0.05])

    @model_validator(mode="after")
    def _check(self) -> _EpisodeDraw:
        normal = self.mean is not None or self.std is not None
        uniform = self.low is not None or self.high is not None
        if normal and uniform:
            raise error_at("low" if self.low is not None else "high", "noise_draw", "give either mean/std (a normal "
                      "draw) or low/high (a uniform draw), not both", self.low)
        if not normal and not uniform:
            raise PydanticCustomError("noise_draw", "give std (with an optional mean) for a normal draw, or low "
                                      "and high for a uniform draw")
        if uniform and (self.low is None or self.high is None):
            missing = "high" if self.high is None else "low"
            raise PydanticCustomError("noise_draw", f"a uniform draw needs both low and high; {missing} is "
                                      "missing")
        ordered(self.low, self.high, ("low", "high"))
        return self

    @property
    def uniform(self) -> bool:
        return self.low is not None

    def normal_params(self) -> tuple[PerValue, PerValue]:
        """(mean, std) of the normal draw, with the stage's default centre."""
        return (self._centre if self.mean is None else self.mean, 0.0 if self.std is None else self.std)


class BiasStage(_EpisodeDraw):
    """An additive offset drawn per value at each reset and constant within the episode."""

    type: Literal["bias"] = _type("bias", "Additive offset drawn once per episode per value.")


class ScaleStage(_EpisodeDraw):
    """A multiplicative gain drawn per value at each reset (normal with mean 1 by default)."""

    _centre: ClassVar[float] = 1.0
    type: Literal["scale"] = _type("scale", "Multiplicative gain drawn once per episode per value "
                                   "(normal draws have mean 1 unless `mean` is given).")


class RandomWalkStage(BaseModel):
    """A drifting additive bias: first-order Gauss-Markov with a correlation time, or Brownian without one.

    It advances with the simulated time between samples, so its statistics do not depend on the sensor's
    interval. The Gauss-Markov walk starts each episode from its stationary distribution N(0, std^2); the
    Brownian walk starts at 0.
    """

    model_config = _MODEL
    type: Literal["random_walk"] = _type("random_walk", "A drifting additive bias (Gauss-Markov or Brownian).")
    std: Std = Field(description="Stationary standard deviation of the bias with `correlation_time`; without "
                     "it, the Brownian walk's standard deviation per square-root second. " + PER_VALUE,
                     examples=[0.01])
    correlation_time: Duration | None = Field(
        None, description="Correlation time of the Gauss-Markov process: a duration such as '2s' or '500ms', "
        "or a number of seconds. Omit for a Brownian walk. " + PER_VALUE, examples=["2s", 0.5])


class QuantizeStage(BaseModel):
    """Limited resolution: every value rounds to the nearest multiple of `step` (ties to even)."""

    model_config = _MODEL
    type: Literal["quantize"] = _type("quantize", "Rounds each value to the nearest multiple of `step`.")
    step: Step = Field(description="Resolution, in the sensor's units (> 0). " + PER_VALUE,
                       examples=[0.001, [0.01, 0.01, 0.05]])


class ClipStage(BaseModel):
    """Saturation: values below `min` become `min`, above `max` become `max` (NaN stays NaN)."""

    model_config = _MODEL
    type: Literal["clip"] = _type("clip", "Saturates each value to [min, max].")
    min: Real | None = Field(None, description="Lowest value the sensor reports (at any noise level; a read may "
                             "also show the zeros it is padded with, which its spec's bounds then include). "
                             + PER_VALUE, examples=[-10.0])
    max: Real | None = Field(None, description="Highest value the sensor reports (at any noise level; a read may "
                             "also show the zeros it is padded with, which its spec's bounds then include). "
                             + PER_VALUE, examples=[10.0])

    @model_validator(mode="after")
    def _check(self) -> ClipStage:
        if self.min is None and self.max is None:
            raise PydanticCustomError("noise_clip", "clip needs min, max or both")
        ordered(self.min, self.max, ("min", "max"))
        return self


class DropoutStage(BaseModel):
    """Lost readings: with probability `p` a sample (or, with `per: value`, a value) is lost."""

    model_config = _MODEL
    type: Literal["dropout"] = _type("dropout", "Loses samples (or values) with probability p.")
    p: Probability = Field(description="Probability that a sample is lost, in [0, 1]. A list (one per value) "
                           "needs `per: value`.", examples=[0.01])
    mode: Literal["hold", "zero", "nan"] = Field(
        "hold", description="What a lost reading becomes: `hold` repeats the last delivered value (the first "
        "sample after a reset is always delivered), `zero` gives 0, `nan` gives NaN (floats only).",
        examples=["hold", "nan"])
    per: Literal["sample", "value"] = Field(
        "sample", description="`sample`: a whole sample is lost at once (a lost packet); `value`: each value "
        "independently (e.g. depth pixels).", examples=["sample", "value"])

    @model_validator(mode="after")
    def _check(self) -> DropoutStage:
        if isinstance(self.p, tuple) and self.per == "sample":
            raise error_at("p", "noise_dropout", "a list of p (one per value) needs `per: value`; a whole "
                      "sample is lost with one probability", self.p)
        return self


class OutlierStage(BaseModel):
    """Spikes: with probability `p` a value is replaced by value + N(0, scale^2)."""

    model_config = _MODEL
    type: Literal["outlier"] = _type("outlier", "Adds N(0, scale^2) to a value with probability p.")
    p: Probability = Field(description="Probability that a value is an outlier, in [0, 1]. " + PER_VALUE,
                           examples=[0.001])
    scale: Std = Field(description="Standard deviation of an outlier's error, in the sensor's units. "
                       + PER_VALUE, examples=[1.0])


class LowpassStage(BaseModel):
    """Limited bandwidth: a first-order low-pass filter, applied with the real time between samples.

    It starts each episode settled at the first sample; between samples the input is taken as held at the
    new sample, so a step input gives exactly 1 - exp(-2 pi cutoff t) at the sample times.
    """

    model_config = _MODEL
    type: Literal["lowpass"] = _type("lowpass", "First-order low-pass filter with cutoff frequency `cutoff`.")
    cutoff: Frequency = Field(description="Cutoff (-3 dB) frequency: a frequency such as '20Hz' or a number of "
                              "Hz. " + PER_VALUE, examples=["20Hz", 5.0])


_ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180}


def _angle(value: Any) -> float:
    x = parse_quantity(value, _ANGLE_UNITS, "angle")
    if not (math.isfinite(x) and x >= 0):
        raise ValueError(f"the rotation's standard deviation must be >= 0, got {value!r}")
    return x


def _matrix(value: Any) -> tuple[tuple[float, float, float], ...]:
    rows = value if isinstance(value, (list, tuple)) else None
    if (rows is None or len(rows) != 3 or not all(isinstance(r, (list, tuple)) and len(r) == 3 for r in rows)
            or not all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)
                       for r in rows for x in r)):
        raise ValueError(f"matrix takes 3 rows of 3 numbers, e.g. [[1, 0.01, 0], [0, 1, 0], [0, 0, 1]]; got {value!r}")
    return tuple(tuple(float(x) for x in r) for r in rows)  # type: ignore[misc]


class MisalignStage(BaseModel):
    """Misaligned axes: each 3-vector x (the observation's last axis) reads R M x, with M a fixed cross-axis
    matrix and R a small rotation drawn per episode (a rotation vector with N(0, std^2) components)."""

    model_config = _MODEL
    type: Literal["misalign"] = _type("misalign", "Maps each 3-vector by a cross-axis matrix and a random rotation "
                                      "drawn per episode.")
    matrix: Annotated[tuple[tuple[float, float, float], ...] | None, WrapValidator(
        lambda v, h, i: None if v is None else _matrix(v))] = Field(
        None, description="Fixed 3x3 cross-axis matrix M (rows): scale factors on the diagonal, cross-coupling "
        "off it. Default: identity.", examples=[[[1.0, 0.01, 0.0], [0.0, 1.0, 0.02], [0.0, 0.0, 1.0]]])
    std: Annotated[float | str | None, WrapValidator(lambda v, h, i: None if v is None else _angle(v))] = Field(
        None, description="Standard deviation of each component of the rotation vector drawn per episode: "
        "radians, or an angle such as '0.5deg'. Omit for no random rotation.", examples=["0.5deg", 0.01])

    @model_validator(mode="after")
    def _check(self) -> MisalignStage:
        if self.matrix is None and self.std is None:
            raise PydanticCustomError("noise_misalign", "misalign needs matrix, std or both")
        return self


def _check_callable(value: Any, handler: Any, info: Any) -> Any:
    if callable(value):
        return value
    if not isinstance(value, str):
        raise PydanticCustomError("noise_callable", "expected 'module:function' (e.g. 'mypkg.noise:corrupt'), got "
                                  f"{quote(value)}")
    problem = callable_problem(value, "mypkg.noise:corrupt")
    if problem:
        raise PydanticCustomError("noise_callable", problem)
    return value


class CustomStage(BaseModel):
    """A hand-written corruptor with dm_control's signature `(value, random_state) -> value`.

    `random_state` is a numpy RandomState seeded from the sensor's own stream at each reset.
    """

    model_config = _MODEL
    type: Literal["custom"] = _type("custom", "A callable corruptor with dm_control's signature.")
    callable: Annotated[Union[Annotated[str, WithJsonSchema({"type": "string", "pattern": CALLABLE_PATTERN})],
                              SkipJsonSchema[Callable[..., Any]]], WrapValidator(_check_callable)] = Field(
        description="'module:function' importable at binding time, called as f(value, random_state=rs) and "
        "returning a value of the same shape (from Python, the function itself).",
        examples=["mypkg.noise:salt_and_pepper"])


# -- the table ----------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class StageInfo:
    """One row of the stage table."""

    model: type[BaseModel]
    images: bool  # applies to uint8 images (rgb): the result is rounded and clipped to 0..255
    integers: bool = False  # applies to other integer observations (segmentation, counts)


STAGES: dict[str, StageInfo] = {
    "gaussian": StageInfo(GaussianStage, images=True),
    "uniform": StageInfo(UniformStage, images=True),
    "bias": StageInfo(BiasStage, images=False),
    "scale": StageInfo(ScaleStage, images=False),
    "random_walk": StageInfo(RandomWalkStage, images=False),
    "quantize": StageInfo(QuantizeStage, images=True),
    "clip": StageInfo(ClipStage, images=True),
    "dropout": StageInfo(DropoutStage, images=True),
    "outlier": StageInfo(OutlierStage, images=True),
    "lowpass": StageInfo(LowpassStage, images=False),
    "misalign": StageInfo(MisalignStage, images=False),
    "custom": StageInfo(CustomStage, images=True, integers=True),
}
IMAGE_STAGES = tuple(name for name, info in STAGES.items() if info.images)


def _dispatch(value: Any, handler: Any, info: Any) -> Any:
    """Validate a stage against the model its `type` names, with errors located at the stage's fields.

    Pydantic's discriminated unions put the tag in `loc` (`noise.0.gaussian.std`) and give no hint for a
    misspelt type; this reads the table instead.
    """
    if isinstance(value, BaseModel):
        return handler(value)
    if not isinstance(value, Mapping):
        raise PydanticCustomError("noise_stage", f"a noise stage is a mapping with a `type` (one of "
                                  f"{', '.join(STAGES)}), got {quote(value)}")
    if "type" not in value:
        raise PydanticCustomError("noise_stage", f"a noise stage needs a `type`: one of {', '.join(STAGES)}")
    kind = value["type"]
    row = STAGES.get(kind) if isinstance(kind, str) else None
    if row is None:
        hint = did_you_mean(kind, STAGES) if isinstance(kind, str) else ""
        raise error_at("type", "noise_type", f"unknown noise stage type {quote(kind)}{hint}; stage types are "
                  f"{', '.join(STAGES)}", kind)
    return row.model.model_validate(value, context=info.context)


if TYPE_CHECKING:  # the union pydantic builds from the table below
    NoiseStage = Union[GaussianStage, UniformStage, BiasStage, ScaleStage, RandomWalkStage, QuantizeStage,
                       ClipStage, DropoutStage, OutlierStage, LowpassStage, MisalignStage, CustomStage]
else:
    NoiseStage = Annotated[
        Union[tuple(info.model for info in STAGES.values())],
        Field(discriminator="type"),
        WrapValidator(_dispatch),
    ]
