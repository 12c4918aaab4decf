"""MuJoCo's own sensor types as suite kinds: one row per type, saying what each one reads and accepts.

A native kind is added to the model as a MuJoCo sensor (through `mujoco.MjSpec`) for every selected
element, and read from `sensordata`. The row says which element types the sensor reads (`objects`),
whether a body stands for a site added at the body's frame (`body_site`: MuJoCo attaches these types to
a site), whether it takes a reference frame (`frame:`, MuJoCo's reftype/refname), what `with:` names (the
second object: the other side of a contact, the site of `insidesite`, the other geom of `geomdist`, the
camera of `camprojection`) and which of the options `data`, `reduce`, `num`, `cutoff` apply. What MuJoCo's
compiler requires of a selected joint or tendon (its joint type, a limit) is in the row too, so that
`additions` reports it at the suite's line before compiling, instead of MuJoCo refusing the sensor.

Where a kind is also an attribute of the element type (an actuator's `force`), the attribute wins: the
element type decides (`kind: force, element: actuator:knee` reads `actuator_force`; on a site or a body it
is MuJoCo's force sensor). Types that read no object (`clock`, `e_potential`, `e_kinetic`) and `user` /
`plugin` sensors are not kinds. A type this MuJoCo does not have is a problem at the sensor's `kind`.

Signs and frames, as MuJoCo computes them (docs/recipes.md, "Signs and frames"; the config's field
descriptions say the same to the schema): velocimeter and gyro read the site's velocity in the site's own
frame; accelerometer the site's acceleration minus gravity in its frame (+9.81 up at rest; MuJoCo 3.x reads it, and
framelinacc, as 0 on a body welded to the world: refused there, `additions._welded_zero`); framexaxis /
frameyaxis / framezaxis an axis of the element in the world frame, or in `frame:`'s; `gravity` (not a type
of its own) the unit vector along the model's gravity in the element's frame, [0, 0, -1] upright. A contact
sensor's force and torque are what the element (object 1) exerts on `with:` (object 2): in each contact's
frame ([normal, tangent 1, tangent 2], normal from the element to `with:`, the normal force positive while
pushing) for reduce none / mindist / maxforce, summed in the world frame for netforce (a foot pressing on
the floor reads negative z); `found` counts the matching contacts MuJoCo lists, those within the margin
that carry no force included.
"""

from __future__ import annotations

import dataclasses

import mujoco

__all__ = ["Added", "NATIVE", "NativeType", "OBJ", "available", "data_fields", "REDUCE"]

# How a suite's element type is written in a sensor's objtype / reftype. A body is its frame (MuJoCo's
# "xbody"): the frame a site added to the body sits at; `subtree*` sensors take MuJoCo's "body".
OBJ = {"body": "XBODY", "geom": "GEOM", "site": "SITE", "camera": "CAMERA", "joint": "JOINT",
       "tendon": "TENDON", "actuator": "ACTUATOR"}

_FRAMES = ("body", "geom", "site", "camera")


@dataclasses.dataclass(frozen=True)
class NativeType:
    kind: str  # as written in a suite: "velocimeter"
    sensor: str  # the mjtSensor member without its prefix: "VELOCIMETER"
    objects: tuple[str, ...]  # the element types `element:` may select
    body_site: bool = False  # a body selects a site added at the body's frame
    frame: bool = False  # takes `frame:` (reftype / refname)
    with_: tuple[str, ...] = ()  # the element types `with:` may name
    with_required: bool = False
    options: tuple[str, ...] = ()  # of "data", "reduce", "num", "cutoff"
    body_obj: str = "XBODY"  # the objtype a selected body is given
    joint_types: tuple[str, ...] = ()  # the mjtJoint members (without prefix) a selected joint must be
    limited: bool = False  # a selected joint or tendon must be limited


def _rows() -> tuple[NativeType, ...]:
    site_types = ("accelerometer", "velocimeter", "gyro", "force", "torque", "magnetometer")
    scalar = ("SLIDE", "HINGE")  # what MuJoCo's compiler requires of each sensor's joint or tendon
    rows = [NativeType(k, k.upper(), ("site", "body"), body_site=True) for k in site_types]
    rows += [NativeType("touch", "TOUCH", ("site",)),
             NativeType("rangefinder", "RANGEFINDER", ("site", "body", "camera"), body_site=True, options=("data",)),
             NativeType("camprojection", "CAMPROJECTION", ("site", "body"), body_site=True, with_=("camera",),
                        with_required=True)]
    rows += [NativeType(k, k.upper(), ("joint",), joint_types=scalar) for k in ("jointpos", "jointvel", "jointactfrc")]
    rows += [NativeType(k, k.upper(), ("joint",), limited=True)
             for k in ("jointlimitpos", "jointlimitvel", "jointlimitfrc")]
    rows += [NativeType(k, k.upper(), ("joint",), joint_types=("BALL",)) for k in ("ballquat", "ballangvel")]
    rows += [NativeType(k, k.upper(), ("tendon",)) for k in ("tendonpos", "tendonvel", "tendonactfrc")]
    rows += [NativeType(k, k.upper(), ("tendon",), limited=True) for k in ("tendonlimitpos", "tendonlimitvel",
                                                                            "tendonlimitfrc")]
    rows += [NativeType(k, k.upper(), ("actuator",)) for k in ("actuatorpos", "actuatorvel", "actuatorfrc")]
    rows += [NativeType(k, k.upper(), _FRAMES, frame=True) for k in (
        "framepos", "framequat", "framexaxis", "frameyaxis", "framezaxis", "framelinvel", "frameangvel")]
    rows += [NativeType(k, k.upper(), _FRAMES) for k in ("framelinacc", "frameangacc")]
    rows += [NativeType(k, k.upper(), ("body",), body_obj="BODY") for k in ("subtreecom", "subtreelinvel",
                                                                              "subtreeangmom")]
    rows += [NativeType("insidesite", "INSIDESITE", _FRAMES, with_=("site",), with_required=True),
             NativeType("contact", "CONTACT", ("geom", "body", "site"), with_=("geom", "body"),
                        options=("data", "reduce", "num"), body_obj="BODY"),
             NativeType("tactile", "TACTILE", ("geom",))]
    # not a MuJoCo type of its own: framezaxis of a world site along gravity, in the element's frame (`gravity`)
    rows += [NativeType("gravity", "FRAMEZAXIS", _FRAMES)]
    rows += [NativeType(k, k.upper(), ("geom", "body"), with_=("geom", "body"), with_required=True,
                        options=("cutoff",), body_obj="BODY") for k in ("geomdist", "geomnormal", "geomfromto")]
    return tuple(rows)


NATIVE: dict[str, NativeType] = {row.kind: row for row in _rows()}

# `reduce` of a contact sensor: MuJoCo's values of intprm[1].
REDUCE = {"none": 0, "mindist": 1, "maxforce": 2, "netforce": 3}


def available(row: NativeType) -> bool:
    """Whether this MuJoCo has the sensor type."""
    return hasattr(mujoco.mjtSensor, f"mjSENS_{row.sensor}")


def data_fields(kind: str) -> tuple[str, ...]:
    """The names `data:` takes for a kind, in MuJoCo's order (its bit order in intprm[0])."""
    enum = {"contact": ("mjtConDataField", "mjCONDATA_"), "rangefinder": ("mjtRayDataField", "mjRAYDATA_")}.get(kind)
    if enum is None or not hasattr(mujoco, enum[0]):
        return ()
    members = getattr(mujoco, enum[0]).__members__
    return tuple(m[len(enum[1]):].lower() for m in members if m.startswith(enum[1]))

@dataclasses.dataclass(frozen=True)
class Added:
    """One MuJoCo sensor a suite sensor adds for one of its elements (and the site it may need)."""

    name: str  # the sensor's name in the model (and the added site's, when `site_body` is set)
    sensor: str  # mjtSensor member without its prefix
    objtype: str  # mjtObj member without its prefix
    objname: str
    reftype: str | None = None
    refname: str | None = None
    intprm: tuple[int, int, int] = (0, 0, 0)
    cutoff: float = 0.0
    site_body: int | None = None  # add a site named `name` at the frame of the body of this id, and read it
    site_quat: tuple[float, float, float, float] | None = None  # that site's orientation in the body; None: none
