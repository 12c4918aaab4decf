"""The pydantic models of a sensor suite: what each key means, its type, its description and an example.

These models are the single source of the suite language: validation, the JSON Schema for editors and
the error hints all read them. Every config is frozen and forbids unknown keys. Values that need the
model (element names, kinds, time in steps) are checked for form here and resolved by `sensorcfg.binding`.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeAlias

from pydantic import (AfterValidator, BaseModel, ConfigDict, Field, PlainSerializer, PlainValidator, StringConstraints,
                      WithJsonSchema, field_validator, model_validator)

from .callables import CALLABLE_PATTERN, callable_problem
from .noise import NoiseStage
from .tables import GENERIC_KIND, HEIGHTSCAN_KIND, IMAGE_KINDS, aggregator_names
from ..errors import quote
from .limits import MAX_BUFFER, MAX_RAYS, MAX_SCHEDULE_STEPS, MAX_SENSORS
from .units import TIME_PATTERN, parse_time

__all__ = ["CameraConfig", "ChoiceDraw", "DefaultsConfig", "MountedCameraConfig", "OptionsConfig", "ScanConfig",
           "SensorConfig", "SuiteConfig", "UniformDraw", "SENSOR_NAME_PATTERN"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")
SENSOR_NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-/]*$"
_SELECTOR = re.compile(r"\A[a-z]+:\S.*\Z")
_INDEX_PART = re.compile(r"\A\s*(-?\d+|(-?\d+)?\s*:\s*(-?\d+)?(\s*:\s*(-?\d+)?)?|\.\.\.)\s*\Z")


# -- time: steps, durations, rates, and draws per sample ------------------------------------------

class UniformDraw(BaseModel):
    """A value drawn per sample, uniformly from the integers lo..hi (inclusive, in physics steps)."""

    model_config = _FROZEN
    low: int | str = Field(description="Smallest value: physics steps or a duration.", examples=[1, "2ms"])
    high: int | str = Field(description="Largest value (inclusive): physics steps or a duration.", examples=[3])


class ChoiceDraw(BaseModel):
    """A value drawn per sample from `values`, with probabilities `p` (uniform when omitted)."""

    model_config = _FROZEN
    values: tuple[int | str, ...] = Field(description="The values to pick from: physics steps or durations.",
                                          examples=[[1, 2, 4], ["10ms", "20ms"]])
    p: tuple[float, ...] | None = Field(None, description="Probability of each value (summing to 1); "
                                        "uniform when omitted.", examples=[[0.8, 0.2]])


def _fixed(value: Any, *, rates: bool, minimum: int, drawn: bool = False) -> int | str:
    """A fixed number of steps or a time; `drawn`: where a draw would be accepted too (the message says so)."""
    if isinstance(value, bool) or not isinstance(value, (int, str)):
        forms = ["integer physics steps", *(["a rate like '50Hz'"] if rates else []), "a duration like '4ms'",
                 *(["{uniform: [lo, hi]} / {choice: [...], p: [...]}"] if drawn else [])]
        raise ValueError(f"expected {', '.join(forms[:-1])}, or {forms[-1]}; got {quote(value)}")
    if isinstance(value, int):
        if value < 0:
            raise ValueError(f"a number of physics steps cannot be negative; got {value}; use {minimum} or more")
        if value < minimum:
            raise ValueError(f"expected at least {minimum} physics step{'s' if minimum != 1 else ''}; got {value}")
        if value > MAX_SCHEDULE_STEPS:
            raise ValueError(f"{value} physics steps is more than {MAX_SCHEDULE_STEPS:,}, the most a schedule may take")
        return value
    parse_time(value, rates=rates)
    return value.strip()


def _schedule(value: Any, *, rates: bool, minimum: int) -> int | str | UniformDraw | ChoiceDraw:
    """Validate an interval (rates allowed, >= 1 step) or a delay (>= 0 steps) without the model."""
    if isinstance(value, (UniformDraw, ChoiceDraw)):  # built in Python
        return value
    if not isinstance(value, dict):
        return _fixed(value, rates=rates, minimum=minimum, drawn=True)
    keys = set(value)
    if keys == {"uniform"}:
        bounds = value["uniform"]
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise ValueError(f"uniform takes two bounds, [lo, hi] (inclusive); got {quote(bounds)}")
        low, high = (_fixed(b, rates=False, minimum=minimum) for b in bounds)
        if isinstance(low, int) and isinstance(high, int) and low > high:
            raise ValueError(f"uniform bounds must satisfy lo <= hi; got [{low}, {high}]: swap them")
        return UniformDraw(low=low, high=high)
    if keys in ({"choice"}, {"choice", "p"}):
        values, p = value["choice"], value.get("p")
        if not isinstance(values, list) or not values:
            raise ValueError(f"choice takes a non-empty list of values; got {quote(values)}")
        fixed = tuple(_fixed(v, rates=False, minimum=minimum) for v in values)
        if p is not None:
            if (not isinstance(p, list) or len(p) != len(values)
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and x >= 0 for x in p)):
                raise ValueError(f"p takes one non-negative probability per choice ({len(values)}); got {quote(p)}")
            if abs(sum(p) - 1.0) > 1e-6:
                raise ValueError(f"the probabilities p must sum to 1; they sum to {sum(p):g}")
            p = tuple(float(x) for x in p)
        return ChoiceDraw(values=fixed, p=p)
    raise ValueError("a random schedule is {uniform: [lo, hi]} or {choice: [a, b, ...], p: [...]}; "
                     f"got keys {', '.join(sorted(map(str, keys))) or '(none)'}")


def _time_schema(rates: bool, minimum: int) -> dict[str, Any]:
    pattern = TIME_PATTERN if rates else TIME_PATTERN.replace("|Hz|kHz", "")
    fixed = [{"type": "integer", "minimum": minimum, "maximum": MAX_SCHEDULE_STEPS, "description": "physics steps"},
             {"type": "string", "pattern": pattern,
              "description": "a duration (s, ms, us)" + (" or a rate (Hz, kHz)" if rates else "")}]
    duration = [fixed[0], {"type": "string", "pattern": TIME_PATTERN.replace("|Hz|kHz", "")}]
    return {"anyOf": fixed + [
        {"type": "object", "additionalProperties": False, "required": ["uniform"],
         "properties": {"uniform": {"type": "array", "minItems": 2, "maxItems": 2, "items": {"anyOf": duration},
                                    "description": "inclusive bounds [lo, hi], drawn per sample"}}},
        {"type": "object", "additionalProperties": False, "required": ["choice"],
         "properties": {"choice": {"type": "array", "minItems": 1, "items": {"anyOf": duration}},
                        "p": {"type": "array", "items": {"type": "number", "minimum": 0}}}},
    ]}


def _dump_schedule(value: int | str | UniformDraw | ChoiceDraw) -> Any:
    """Back to the suite's own spelling, so a dumped config validates again."""
    if isinstance(value, UniformDraw):
        return {"uniform": [value.low, value.high]}
    if isinstance(value, ChoiceDraw):
        return {"choice": list(value.values), **({"p": list(value.p)} if value.p is not None else {})}
    return value


Interval = Annotated[int | str | UniformDraw | ChoiceDraw,
                     PlainValidator(lambda v: _schedule(v, rates=True, minimum=1)),
                     PlainSerializer(_dump_schedule, return_type=Any),
                     WithJsonSchema(_time_schema(rates=True, minimum=1))]
Delay = Annotated[int | str | UniformDraw | ChoiceDraw,
                  PlainValidator(lambda v: _schedule(v, rates=False, minimum=0)),
                  PlainSerializer(_dump_schedule, return_type=Any),
                  WithJsonSchema(_time_schema(rates=False, minimum=0))]
ControlInterval = Annotated[int | str, PlainValidator(lambda v: _fixed(v, rates=True, minimum=1)),
                            WithJsonSchema({"anyOf": _time_schema(rates=True, minimum=1)["anyOf"][:2]})]


# -- elements and indices -------------------------------------------------------------------------

def _selector(value: Any) -> str:
    if not isinstance(value, str) or not _SELECTOR.match(value.strip()):
        raise ValueError(f"an element is written 'type:name' (for example 'joint:elbow', 'site:finger_*'); "
                         f"got {quote(value)}")
    return value.strip()


def _element(value: Any) -> str | tuple[str, ...]:
    if isinstance(value, list):
        if not value:
            raise ValueError("an empty element list selects nothing; name at least one element")
        return tuple(_selector(v) for v in value)
    return _selector(value)


_WITHIN = re.compile(r"\Abody:\S.*\Z")


def _within(value: Any) -> str | tuple[str, ...]:
    """`within`: a body ('body:leg', 'body:#3') or a non-empty list of them."""
    values = value if isinstance(value, list) else [value]
    if not values or not all(isinstance(v, str) and _WITHIN.match(v.strip()) for v in values):
        raise ValueError("within takes a body selector, 'body:name' (for example 'body:forearm'), or a list of them; "
                         f"got {value!r}")
    return tuple(v.strip() for v in values) if isinstance(value, list) else value.strip()


def _index(value: Any) -> int | tuple[int, ...] | str:
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    if isinstance(value, list) and value and all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        return tuple(value)
    if isinstance(value, str) and all(_INDEX_PART.match(part) for part in value.split(",")):
        return value.strip()
    raise ValueError("index takes an integer, a list of integers, or numpy-style slices such as '0:3' or "
                     f"':, 2'; got {quote(value)}")


def _dump_listlike(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


Element = Annotated[str | tuple[str, ...], PlainValidator(_element), PlainSerializer(_dump_listlike, return_type=Any),
                    WithJsonSchema({"anyOf": [
    {"type": "string", "pattern": _SELECTOR.pattern.replace(r"\A", "^").replace(r"\Z", "$")},
    {"type": "array", "minItems": 1, "items": {"type": "string"}}]})]
Within = Annotated[str | tuple[str, ...], PlainValidator(_within), PlainSerializer(_dump_listlike, return_type=Any),
                   WithJsonSchema({"anyOf": [
    {"type": "string", "pattern": _WITHIN.pattern.replace(r"\A", "^").replace(r"\Z", "$")},
    {"type": "array", "minItems": 1, "items": {"type": "string",
                                               "pattern": _WITHIN.pattern.replace(r"\A", "^").replace(r"\Z", "$")}}]})]
Index = Annotated[int | tuple[int, ...] | str, PlainValidator(_index), PlainSerializer(_dump_listlike, return_type=Any),
                  WithJsonSchema({"anyOf": [
    {"type": "integer"}, {"type": "array", "items": {"type": "integer"}, "minItems": 1}, {"type": "string"}]})]
if TYPE_CHECKING:  # a Literal of the registered aggregators' names, built at import
    AggregatorName: TypeAlias = str
else:
    AggregatorName = Literal[aggregator_names()]
SensorName = Annotated[str, StringConstraints(pattern=SENSOR_NAME_PATTERN)]


def _callable_name(value: str) -> str:
    problem = callable_problem(value, "my_pkg.sensors:distance")
    if problem:
        raise ValueError(problem)
    return value


CallableName = Annotated[str, AfterValidator(_callable_name),
                         WithJsonSchema({"type": "string", "pattern": CALLABLE_PATTERN})]


# -- the configs ----------------------------------------------------------------------------------

class CameraConfig(BaseModel):
    """Image settings for rgb, depth and segmentation sensors."""

    model_config = _FROZEN
    width: int | None = Field(None, ge=1, strict=True, description="Image width in pixels. Default: the "
                              "camera's own MJCF `resolution` when the model sets one, else 320.", examples=[64])
    height: int | None = Field(None, ge=1, strict=True, description="Image height in pixels. Default: the "
                               "camera's own MJCF `resolution` when the model sets one, else 240.", examples=[48])
    scene: dict[str, bool] = Field(
        default_factory=dict, description="Scene flags switched on or off for this camera, by name (lower case, "
        "without prefix): MuJoCo's render flags (mjtRndFlag: shadow, reflection, skybox, fog, haze, wireframe, "
        "...) and visualisation flags (mjtVisFlag: contactpoint, transparent, ...). Turning off shadow and "
        "reflection makes frames much cheaper.", examples=[{"shadow": False, "reflection": False}])


_Finite = Annotated[float, Field(allow_inf_nan=False)]


class MountedCameraConfig(BaseModel):
    """A camera the suite adds to its model when it compiles it (a robot file without one, such as
    Menagerie's Panda): it looks along its own -z axis, +x to the right of the image and +y up."""

    model_config = _FROZEN
    element: str = Field(description="The frame it is mounted in, moving with it: 'body:<name>' ('body:world' "
                         "for a fixed camera) or 'site:<name>'.", examples=["body:hand", "site:attachment_site"])
    pos: tuple[_Finite, _Finite, _Finite] = Field((0.0, 0.0, 0.0), description="Position in that frame (m).",
                                                  examples=[[0.0, 0.0, 0.1]])
    quat: tuple[_Finite, _Finite, _Finite, _Finite] | None = Field(
        None, description="Orientation in that frame as a quaternion (w, x, y, z), as MJCF writes it; give "
        "this or `xyaxes`. Default: the frame's own axes.", examples=[[0.0, 1.0, 0.0, 0.0]])
    xyaxes: tuple[_Finite, _Finite, _Finite, _Finite, _Finite, _Finite] | None = Field(
        None, description="Orientation as the image's x axis then its y axis in that frame, as MJCF's "
        "`xyaxes` (orthogonalised as MuJoCo does).", examples=[[0.0, -1.0, 0.0, 1.0, 0.0, 0.0]])
    fovy: float = Field(45.0, gt=0, lt=180, description="Vertical field of view (degrees), as MJCF's `fovy`.",
                        examples=[58.0])
    resolution: tuple[Annotated[int, Field(ge=1, strict=True)], Annotated[int, Field(ge=1, strict=True)]] | None = \
        Field(None, description="Its resolution [width, height] in pixels, as MJCF's `resolution`: the image size "
              "of the sensors that read it unless they set `camera: {width, height}`.", examples=[[640, 480]])

    @field_validator("quat")
    @classmethod
    def _a_rotation(cls, quat: tuple[float, ...] | None) -> tuple[float, ...] | None:
        if quat is not None and not any(quat):
            raise ValueError("quat (0, 0, 0, 0) is no rotation; the frame's own axes are (1, 0, 0, 0)")
        return quat

    @field_validator("xyaxes")
    @classmethod
    def _two_axes(cls, xyaxes: tuple[float, ...] | None) -> tuple[float, ...] | None:
        if xyaxes is not None:
            x, y = xyaxes[:3], xyaxes[3:]
            cross = (x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0])
            if not any(cross):
                raise ValueError(f"xyaxes {list(xyaxes)} has a zero or parallel x and y axis; give two axes at "
                                 "right angles, such as [1, 0, 0, 0, 1, 0]")
        return xyaxes

    @model_validator(mode="after")
    def _one_orientation(self) -> MountedCameraConfig:
        if self.quat is not None and self.xyaxes is not None:
            raise ValueError("give its orientation once: `quat` or `xyaxes`, not both")
        return self


class ScanConfig(BaseModel):
    """Where a height scan casts its rays (kind 'heightscan'): a grid or rings of vertical rays around the
    frame, each reading the height of the frame's origin above the terrain it hits."""

    model_config = _FROZEN
    pattern: Literal["grid", "ring"] = Field("grid", description="'grid': size[0] x size[1] metres every "
                                             "`resolution`, both ends included; 'ring': `count` rays on each "
                                             "circle of `radii`.", examples=["grid"])
    size: tuple[Annotated[float, Field(ge=0)], Annotated[float, Field(ge=0)]] = Field(
        (1.6, 1.0), description="Grid extent along x and y (m), centred on the frame: whole multiples of "
        "`resolution`.", examples=[[1.6, 1.0]])
    resolution: float = Field(0.1, gt=0, description="Grid spacing (m): 1.6 x 1.0 at 0.1 is 17 x 11 rays.",
                              examples=[0.1])
    radii: tuple[Annotated[float, Field(gt=0)], ...] = Field((0.5,), min_length=1, description="Ring radii (m).",
                                                              examples=[[0.3, 0.6]])
    count: int = Field(8, ge=1, strict=True, description="Rays per ring, evenly spaced from the x axis.",
                       examples=[12])
    alignment: Literal["yaw", "full", "world"] = Field(
        "yaw", description="'yaw': the pattern turns with the frame's heading, rays point down; 'full': it "
        "follows the frame's whole orientation, rays along its -z; 'world': world axes.", examples=["yaw"])
    above: float = Field(1.0, ge=0, description="Rays start this far above the frame's origin (m), so terrain "
                         "above the origin is seen.", examples=[1.0])
    max_distance: float = Field(5.0, gt=0, description="Longest ray (m) from its start; beyond is a miss.",
                                examples=[5.0])
    miss: float | None = Field(None, description="The value a miss reads; default: max_distance - above (the "
                               "height above the farthest point a ray reaches).", examples=[0.0])
    geomgroup: tuple[Annotated[int, Field(ge=0, le=5)], ...] | None = Field(
        None, description="Geom groups (0-5) the rays see; default all.", examples=[[0]])

    @model_validator(mode="after")
    def _whole_grid(self) -> ScanConfig:
        per_axis = [extent / self.resolution + 1 for extent in self.size]
        rays = per_axis[0] * per_axis[1] if self.pattern == "grid" else float(len(self.radii)) * self.count
        if not rays <= MAX_RAYS:  # (also inf and nan: a resolution of 1e-300)
            what = (f"{self.size[0]:g} x {self.size[1]:g} m every {self.resolution:g} m" if self.pattern == "grid"
                    else f"{len(self.radii)} ring{'s' if len(self.radii) > 1 else ''} of {self.count} rays")
            raise ValueError(f"{what} makes {rays:.3g} rays; a scan casts at most {MAX_RAYS:,}: use a coarser "
                             "resolution, a smaller size or fewer rays")
        if self.pattern != "grid":
            return self
        for axis, extent in zip("xy", self.size):
            steps = extent / self.resolution
            if abs(steps - round(steps)) > 1e-9 * max(1.0, steps):
                near = [round(math.floor(steps) * self.resolution, 9), round(math.ceil(steps) * self.resolution, 9)]
                raise ValueError(f"size along {axis} ({extent:g} m) is not a whole number of {self.resolution:g} m "
                                 f"steps ({steps:.3g}); use {near[0]:g} or {near[1]:g}, or another resolution")
        return self


# Fields a sensor and `defaults` share: one description each, used by both models.
_SHARED: dict[str, dict[str, Any]] = {
    "interval": dict(description="Time between samples: integer physics steps, a duration ('4ms', '0.02s', "
                     "'500us'), a rate ('50Hz'), or drawn per sample: {uniform: [lo, hi]} or "
                     "{choice: [...], p: [...]}. Default 1 step.", examples=[2, "4ms", "50Hz", {"uniform": [2, 4]}]),
    "delay": dict(description="Time from sampling to delivery: integer physics steps or a duration; "
                  "{uniform: [lo, hi]} or {choice: [...], p: [...]} draw it per sample. Default 0.",
                  examples=[0, "4ms", {"uniform": [1, 3]}]),
    "buffer": dict(ge=1, le=MAX_BUFFER, strict=True,
                   description="How many of the latest delivered samples an observation "
                   "holds (a leading axis). Default 1.", examples=[1, 4]),
    "aggregator": dict(description="Reduces the buffer axis: " + ", ".join(aggregator_names()) + ".",
                       examples=["mean"]),
    "enabled": dict(strict=True, description="Whether the Updater computes this observation. Default true.",
                    examples=[True, False]),
    "noise": dict(description="Noise stages applied in order to each raw sample before it is buffered.",
                  examples=[[{"type": "gaussian", "std": 0.01}]]),
    "twin": dict(description="Also deliver this sensor clean under another key: no noise, no delay, sampled at "
                 "every read (a privileged observation for a critic). In `defaults`, '{name}' stands for each "
                 "sensor's name; `false` turns off a twin that `defaults` gives.",
                 examples=["base_lin_vel_clean", "{name}_clean", False]),
}


def _shared(name: str) -> Any:
    """An optional field's `Field(None, ...)` with its shared description (a call mypy reads as a default)."""
    return Field(None, **_SHARED[name])


class DefaultsConfig(BaseModel):
    """Settings applied to every sensor that does not give its own (field by field)."""

    model_config = _FROZEN
    interval: Interval | None = _shared("interval")
    delay: Delay | None = _shared("delay")
    buffer: int | None = _shared("buffer")
    aggregator: AggregatorName | None = _shared("aggregator")
    enabled: bool | None = _shared("enabled")
    noise: tuple[NoiseStage, ...] | None = _shared("noise")
    twin: str | bool | None = _shared("twin")
    camera: CameraConfig | None = Field(
        None, description="Camera settings for every image sensor that does not give its own.",
        examples=[{"width": 64, "height": 48}])


class SensorConfig(BaseModel):
    """One observation: what to read (`kind`), from which elements, how often, how late, how noisy."""

    model_config = _FROZEN
    kind: str = Field(
        pattern=r"^[A-Za-z_][A-Za-z0-9_]*$",
        description="What to read: an attribute of the element as dm_control's `physics.bind(element).<kind>` "
        "names it (qpos, xpos, sensordata, ...); a MuJoCo sensor type that the suite adds to the model "
        "(velocimeter, gyro, framepos, contact, ...; where an element type has an attribute of that name, "
        "the attribute); 'gravity': the unit vector along the model's gravity in the element's frame ([0, 0, -1] "
        "upright; the direction of opt.gravity when the suite compiles the model: changing model.opt.gravity "
        f"later does not turn it); {', '.join(IMAGE_KINDS)} for a camera; '{HEIGHTSCAN_KIND}' for a terrain height "
        f"scan; '{GENERIC_KIND}' for a Python callable.",
        examples=["qpos", "velocimeter", "framepos", "contact", "sensordata", "rgb", "heightscan", "generic"])
    element: Element | None = Field(
        None, description="Which elements: 'type:name' or 'type:#id' (one element, unbatched shape), a glob "
        "('joint:*': every joint, unnamed ones included; 'site:finger_*') or a list of selectors (batched shape, "
        "list order, then model order within a glob). Unnamed elements are labelled '#<id>'. Actuators on a joint "
        "attribute ('actuator:*' with kind qpos, qvel, ...) are the joints they drive, in actuator order.",
        examples=["joint:*", "actuator:*", ["sensor:imu_gyro", "sensor:imu_accel"], "camera:wrist"])
    within: Within | None = Field(
        None, description="Keep only elements in the subtree of this body (or of any of a list of bodies).",
        examples=["body:forearm", ["body:FL_calf", "body:FR_calf"]])
    index: Index | None = Field(
        None, description="A part of the value: an integer, a list of integers, or numpy-style slices as text.",
        examples=[0, [0, 2], "0:3", ":, 2"])
    constant: bool | None = Field(
        None, strict=True, description="Read a model constant (a body's `mass`, a joint's `range`) rather than "
        "simulation state. Without it a kind that does not change with the simulation is an error, since a "
        "constant read as a sensor is silently wrong data.", examples=[True])
    camera: CameraConfig | None = Field(
        None, description=f"Image settings; for {', '.join(IMAGE_KINDS)} sensors only.",
        examples=[{"width": 64, "height": 48}])
    callable: CallableName | None = Field(
        None, description="For kind 'generic': 'module:function', called with the physics handle; imported when the "
        "suite is built, not when it is checked.", examples=["my_pkg.sensors:distance_to_target"])
    batched: bool | None = Field(
        None, strict=True, description="For kind 'generic', on the Warp engine (WarpEnvironment) only: the callable "
        "takes every world at once. It is called as f(model, data) with MuJoCo Warp's Model and Data of all worlds "
        "after every physics step (and after a restart's forward, for the reset sample) and returns an (nworld, "
        "...) float32 Warp array on the engine's device (float32 vectors and matrices count as their components; "
        "the same array each call or a new one); its value shape is found by one call when the engine is built. "
        "It runs inside the control step's CUDA graph, so it may do device work only: Warp kernels, no copies to "
        "the host, no Python branching on values. Its values then go through the sensor's schedule, delay, "
        "buffer, aggregator and noise as a feature's do. The CPU engines refuse it.", examples=[True])
    frame: str | None = Field(
        None, pattern=_SELECTOR.pattern.replace(r"\A", "^").replace(r"\Z", "$"),
        description="For MuJoCo's frame sensors (framepos, framelinvel, ...): the reference frame the value is "
        "relative to and expressed in (MuJoCo's reftype/refname); a body means its frame. Without it, the world "
        "frame: framezaxis of an element is its z axis in world coordinates (framezaxis of body:world in "
        "frame body:base is the world's up axis in the base frame, [0, 0, 1] upright; kind 'gravity' is its "
        "opposite).",
        examples=["body:base"])
    with_: str | None = Field(
        None, alias="with", pattern=_SELECTOR.pattern.replace(r"\A", "^").replace(r"\Z", "$"),
        description="The second object of a MuJoCo sensor: what a contact is matched against (a contact's "
        "force and torque are what the element exerts on it), the site of insidesite, the other geom of "
        "geomdist, the camera of camprojection.", examples=["geom:floor"])
    data: tuple[str, ...] | None = Field(
        None, min_length=1, description="Which values a contact (or rangefinder) sensor reports, in MuJoCo's "
        "order: found, force, torque, dist, pos, normal, tangent, ... For a contact: found is the number of "
        "matching contacts MuJoCo lists, which includes pairs within the geoms' margin that carry no force; "
        "force and torque are what the element exerts on `with:`, in the contact frame ([normal, tangent 1, "
        "tangent 2]: the normal force is positive while the contact pushes), or in the world frame with reduce "
        "netforce (a foot pressing on the floor reads negative z); normal points from the element to `with:`, "
        "pos, normal and tangent are in world coordinates; absent contacts read 0.",
        examples=[["found", "force"]])
    reduce: str | None = Field(None, description="How a contact sensor combines the contacts it matches: none, "
                               "mindist, maxforce (the `num` strongest, strongest first), netforce (one "
                               "sum in the world frame, as a force on `with:`).", examples=["maxforce"])
    num: int | None = Field(None, ge=1, strict=True, description="Contacts a contact sensor reports (default 1).",
                            examples=[1])
    cutoff: float | None = Field(None, gt=0, description="Largest distance geomdist/geomnormal/geomfromto look "
                                 "for (m); default 10.", examples=[1.0])
    scan: ScanConfig | None = Field(None, description="The ray pattern of a 'heightscan' sensor.",
                                    examples=[{"pattern": "grid", "size": [1.6, 1.0], "resolution": 0.1}])
    interval: Interval | None = _shared("interval")
    delay: Delay | None = _shared("delay")
    buffer: int | None = _shared("buffer")
    aggregator: AggregatorName | None = _shared("aggregator")
    enabled: bool | None = _shared("enabled")
    noise: tuple[NoiseStage, ...] | None = _shared("noise")
    twin: str | bool | None = _shared("twin")


class OptionsConfig(BaseModel):
    """Settings of the Updater that runs the suite."""

    model_config = _FROZEN
    pad_with_initial_value: bool = Field(
        False, strict=True, description="Fill a buffer that is not yet full with the first sample instead of zeros.",
        examples=[False])
    strip_singleton_buffer_dim: bool = Field(
        False, strict=True, description="Drop the buffer axis of observations whose buffer is 1.", examples=[True])
    control_interval: ControlInterval | None = Field(
        None, description="Physics steps per control step (as steps, a duration or a rate); default 1.",
        examples=[10, "20ms", "50Hz"])
    keyframe: Annotated[int, Field(ge=0, strict=True)] | Annotated[str, StringConstraints(min_length=1)] | None = Field(
        None, description="The model keyframe every episode starts from: its name or its index (default: the "
        "model's reset state). `sensorcfg run --keyframe` and the environments' `keyframe=` override it.",
        examples=["home", 0])


class SuiteConfig(BaseModel):
    """A sensor suite: the observations a robot's sensing produces, declared once."""

    model_config = ConfigDict(frozen=True, extra="forbid", title="sensorcfg sensor suite")
    version: Literal[1] = Field(1, description="Version of the suite format.", examples=[1])
    model: str | None = Field(
        None, description="Default MJCF model, relative to this file and inside the folder tree of the suite "
        "being loaded (--extends-root / extends_root allows more); 'package://<package>/<path>' for a file "
        "shipped inside an installed Python package; 'menagerie://<robot folder>/<file>' for a MuJoCo "
        "Menagerie robot, through the mujoco-menagerie package (which honours MENAGERIE_ROOT).",
        examples=["../models/arm.xml", "package://sensorcfg/assets/robot.xml", "menagerie://unitree_go2/scene.xml"])
    extends: str | None = Field(
        None, description="Another suite (relative to this file) to start from; this file overrides it key by "
        "key, and `null` removes an inherited key.", examples=["base.yaml"])
    options: OptionsConfig = Field(default_factory=OptionsConfig,  # type: ignore[arg-type]
                                   description="Updater settings.", examples=[{"strip_singleton_buffer_dim": True}])
    defaults: DefaultsConfig = Field(default_factory=DefaultsConfig,  # type: ignore[arg-type]
                                     description="Applied to every sensor that does not say otherwise.",
                                     examples=[{"buffer": 1, "interval": "4ms"}])
    cameras: dict[SensorName, MountedCameraConfig] = Field(
        default_factory=dict, description="Cameras added to the model when the suite compiles it (validate, "
        "spec, run and both environments), by name: read them as 'camera:<name>'. A name the model already "
        "has is an error.", examples=[{"wrist_cam": {"element": "body:hand", "pos": [0.0, 0.0, 0.05],
                                                        "quat": [0.0, 1.0, 0.0, 0.0], "fovy": 58.0}}])
    groups: dict[SensorName, tuple[Annotated[str, StringConstraints(min_length=1, max_length=200)], ...]] = Field(
        default_factory=dict, description="Observation groups (a policy's, a critic's), by name: each a list of the "
        "suite's observations (sensor or clean twin names, or globs of them) concatenated into one vector per "
        "simulation. Columns follow the list; a glob adds its matches in the order the suite returns them, "
        "leaving out those already in the group, disabled sensors and camera images. Each observation is "
        "flattened in C order (buffer axis first); `sensorcfg spec` prints which columns each one fills.",
        examples=[{"policy": ["base_ang_vel", "projected_gravity", "joint_*"], "critic": ["*_clean", "joint_*"]}])
    sensors: dict[SensorName, SensorConfig] = Field(
        max_length=MAX_SENSORS, description="The observations, by name, in the order they are returned.",
        examples=[{"joint_pos": {"kind": "qpos", "element": "joint:*"}}])
