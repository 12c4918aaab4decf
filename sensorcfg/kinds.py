"""Which attributes (`kind`s) each MuJoCo element type has, and where each one lives.

The names are those of dm_control's `physics.bind(element).<kind>`: every mjData and mjModel array whose
first dimension counts elements of that type, with the type's prefix stripped (`site_xpos` -> `xpos`,
`actuator_force` -> `force`, `jnt_range` -> `range`). The table is derived from MuJoCo's own struct
metadata (`mujoco.introspect`), so a field that a MuJoCo release adds or drops shows up here by itself.

Fields addressed per element through an address array ("ragged": `qpos` of a free joint is 7 values, a
sensor's `sensordata` is `sensor_dim` values) are flattened and concatenated, as dm_control does.
"""

from __future__ import annotations

import dataclasses
import functools
import re

import mujoco
from mujoco.introspect import structs as _introspect

__all__ = ["ELEMENT_TYPES", "ElementType", "FieldSpec", "kinds_of", "element_type", "offered_kinds", "state_twin",
           "read_type", "ON_DEMAND", "OnDemand"]


@dataclasses.dataclass(frozen=True)
class ElementType:
    name: str  # as written in a suite: "joint"
    obj: int  # mujoco.mjtObj value used for name look-ups
    count: str  # the mjModel size that counts these elements: "njnt"
    sizes: tuple[str, ...]  # array first dimensions that belong to this type
    strip: tuple[str, ...]  # prefixes that dm_control strips from field names


def _obj(name: str) -> int:
    return int(getattr(mujoco.mjtObj, f"mjOBJ_{name}"))


# One row per element type: the sizes of its arrays and the prefixes dm_control strips.
_TYPE_ROWS = (
    ("body", "BODY", "nbody", ("nbody", "nmocap"), ("body",)),
    ("joint", "JOINT", "njnt", ("nq", "nv", "njnt"), ("jnt", "dof")),
    ("geom", "GEOM", "ngeom", ("ngeom",), ("geom",)),
    ("site", "SITE", "nsite", ("nsite",), ("site",)),
    ("camera", "CAMERA", "ncam", ("ncam",), ("cam",)),
    ("light", "LIGHT", "nlight", ("nlight",), ("light",)),
    ("actuator", "ACTUATOR", "nu", ("na", "nu", "nout", "nactuator"), ("actuator",)),
    ("sensor", "SENSOR", "nsensor", ("nsensor", "nsensordata"), ("sensor",)),
    ("tendon", "TENDON", "ntendon", ("ntendon",), ("tendon", "ten")),
    ("equality", "EQUALITY", "neq", ("neq",), ("eq",)),
    ("hfield", "HFIELD", "nhfield", ("nhfield",), ("hfield",)),
    ("material", "MATERIAL", "nmat", ("nmat",), ("mat",)),
    ("mesh", "MESH", "nmesh", ("nmesh",), ("mesh",)),
    ("texture", "TEXTURE", "ntex", ("ntex",), ("tex",)),
    ("numeric", "NUMERIC", "nnumeric", ("nnumeric", "nnumericdata"), ("numeric",)),
    ("tuple", "TUPLE", "ntuple", ("ntuple",), ("tuple",)),
    ("key", "KEY", "nkey", ("nkey",), ("key",)),
    ("skin", "SKIN", "nskin", ("nskin",), ("skin",)),
    ("flex", "FLEX", "nflex", ("nflex",), ("flex",)),
    ("pair", "PAIR", "npair", ("npair",), ("pair",)),
    ("exclude", "EXCLUDE", "nexclude", ("nexclude",), ("exclude",)),
)

ELEMENT_TYPES: dict[str, ElementType] = {
    name: ElementType(name, _obj(obj), count, sizes, strip)
    for name, obj, count, sizes, strip in _TYPE_ROWS
    if hasattr(mujoco.mjtObj, f"mjOBJ_{obj}")
}

# Ragged sizes: (address field, width) per element. A width given as a tuple is indexed by `jnt_type`.
_FREE, _BALL = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)
_JOINT_QPOS_WIDTH = {_FREE: 7, _BALL: 4}
_JOINT_DOF_WIDTH = {_FREE: 6, _BALL: 3}
RAGGED: dict[str, tuple[str, str]] = {
    "nq": ("jnt_qposadr", "qpos"),
    "nv": ("jnt_dofadr", "dof"),
    "nsensordata": ("sensor_adr", "sensor_dim"),
    "na": ("actuator_actadr", "actuator_actnum"),
    "nu": ("actuator_ctrladr", "actuator_ctrlnum"),
    "nout": ("actuator_outadr", "actuator_outnum"),
    "nnumericdata": ("numeric_adr", "numeric_size"),
    "nmocap": ("body_mocapid", "one"),  # mocap_pos, mocap_quat: a mocap body's row; other bodies have none
}


# Ragged sizes that dm_control indexes like plain per-element arrays when every selected element has
# exactly one entry (an actuator's `ctrl`, `force` or `act` of one actuator is a scalar there).
SOFT_RAGGED = frozenset({"na", "nu", "nout", "nmocap"})


# dm_control's bind treats these mjData kinds as inputs: writing one (a walker's `bind(actuators).ctrl = a`)
# marks a dm_control Physics dirty, and reading any other mjData kind, or one of the purely visual
# mjModel kinds, while it is dirty runs mj_forward first (dm_control.mjcf.constants:
# MJDATA_TRIGGERS_DIRTY and MJMODEL_DOESNT_TRIGGER_DIRTY).
INPUT_KINDS = frozenset({"qpos", "qvel", "act", "ctrl", "qfrc_applied", "xfrc_applied"})
VISUAL_MODEL_KINDS = frozenset({"rgba", "matid", "emission", "specular", "shininess", "reflectance", "needstage"})


def forwards_when_dirty(struct: str, kind: str) -> bool:
    """Whether dm_control's bind runs mj_forward on a dirty physics before reading this kind."""
    return kind not in INPUT_KINDS if struct == "data" else kind in VISUAL_MODEL_KINDS


@dataclasses.dataclass(frozen=True)
class FieldSpec:
    """Where one kind of one element type lives."""

    kind: str  # the attribute name users write
    struct: str  # "data" or "model"
    field: str  # the mjData / mjModel attribute
    size: str  # its first dimension: "nbody", "nq", ...
    doc: str

    @property
    def ragged(self) -> bool:
        return self.size in RAGGED

    @property
    def role(self) -> str:
        """STATE (changes with the simulation), CONSTANT (a model value) or INTERNAL (MuJoCo's bookkeeping)."""
        if any(p.search(self.kind) for p, _ in _INTERNAL):
            return INTERNAL
        return CONSTANT if self.struct == "model" else STATE


# What a kind is to a suite. STATE changes with the simulation: what a sensor reads. CONSTANT is a model
# value (a body's `mass`, a joint's `range`, a body's compiled `pos` in its parent): a suite reads one only
# when it says so (`constant: true`), since a constant read as a sensor is silently wrong data. INTERNAL
# fields are MuJoCo's own addresses, sizes and solver scratch: never offered, listed or suggested
# (dm_control's bind still has them, and so has the Python `Feature`, for parity).
STATE, CONSTANT, INTERNAL = "state", "constant", "internal"
_INTERNAL: tuple[tuple[re.Pattern[str], str], ...] = tuple((re.compile(p), why) for p, why in (
    (r"adr\Z", "an address into another array"),
    (r"(num|nnz)\Z", "a count of entries in another array"),
    (r"\Aname_", "an address into the names buffer"),
    (r"\A(efm|map)_", "solver scratch"),
    (r"\A[BDJM](_|0\Z|adr\Z)", "a sparse-matrix layout"),
    (r"Diag(Inv)?\Z", "a factorisation of the mass matrix"),
    (r"\A(awake_ind|parent_awake_ind|island|qacc_warmstart|hessian_valid)\Z", "solver or sleeping scratch"),
    (r"\A(plugin|sameframe|simple|needstage|signature)\Z", "a compiler flag"),
))

# A constant that has a simulated counterpart, suggested instead of it: `x` + kind (`pos` -> `xpos`,
# `quat` -> `xquat`), the kind without a trailing 0 (`qpos0` -> `qpos`), or a row of this table.
_TWINS = {("joint", "pos"): "xanchor", ("joint", "axis"): "xaxis", ("joint", "qpos_spring"): "qpos",
          ("camera", "mat0"): "xmat", ("light", "dir0"): "xdir", ("camera", "pos0"): "xpos",
          ("light", "pos0"): "xpos"}


def offered_kinds(type_name: str, role: str) -> list[str]:
    """The kinds of a type with this role, sorted: what messages list and "did you mean" offers."""
    return sorted(k for k, spec in kinds_of(type_name).items() if spec.role == role)


def state_twin(type_name: str, kind: str) -> str | None:
    """The state kind a user most likely meant by a constant one (`quat` of a body -> `xquat`), or None."""
    table = kinds_of(type_name)
    for candidate in (_TWINS.get((type_name, kind)), "x" + kind, kind.rstrip("0")):
        if candidate and candidate != kind and candidate in table and table[candidate].role == STATE:
            return candidate
    return None


# mjData fields that MuJoCo computes on demand only (when the model's own sensors need them): the function
# that fills them and the mjData flag it sets until the next step clears it. A feature of one of these
# calls the function before it samples, once per physics step (the flag says whether it ran already).
@dataclasses.dataclass(frozen=True)
class OnDemand:
    function: str  # mujoco.<function>(model, data)
    flag: str  # mjData flag set by the function, cleared by mj_step / mj_forward
    # Whether it reads `qvel`: after mj_step that is the velocity the step ended with, while every other
    # input is from the step's start (the kinematics); MuJoCo's in-step call used the starting velocity.
    reads_qvel: bool


_RNE_POST = OnDemand("mj_rnePostConstraint", "flg_rnepost", reads_qvel=True)  # cacc += cdof_dot * qvel
_SUBTREE_VEL = OnDemand("mj_subtreeVel", "flg_subtreevel", reads_qvel=False)  # from cvel
ON_DEMAND: dict[str, OnDemand] = {"cacc": _RNE_POST, "cfrc_ext": _RNE_POST, "cfrc_int": _RNE_POST,
                                  "subtree_linvel": _SUBTREE_VEL, "subtree_angmom": _SUBTREE_VEL}


def _array_fields(struct_name: str, cls: type) -> list[tuple[str, str, str]]:
    out = []
    for f in _introspect.STRUCTS[struct_name].fields:
        extent = getattr(f, "array_extent", None)
        if not extent or not isinstance(extent[0], str):
            continue
        if any(not isinstance(e, int) for e in extent[1:]):
            continue  # e.g. sparse matrices sized by two counts: not per element
        if not hasattr(cls, f.name):
            continue
        out.append((f.name, extent[0], (getattr(f, "doc", "") or "").strip()))
    return out


@functools.cache
def kinds_of(type_name: str) -> dict[str, FieldSpec]:
    """The kinds of one element type, resolving name clashes as dm_control's `bind` does.

    Two fields can strip to one kind (`jnt_bodyid` and `dof_bodyid` are both a joint's `bodyid`).
    dm_control walks its size table (sorted by field name), data before model, and the last one wins:
    model over data, and within a struct the alphabetically later name (`jnt_bodyid` over `dof_bodyid`).
    """
    et = ELEMENT_TYPES[type_name]
    strip = re.compile(r"\A({})_".format("|".join(et.strip)))
    table: dict[str, FieldSpec] = {}
    for struct, struct_name, cls in (("data", "mjData", mujoco.MjData), ("model", "mjModel", mujoco.MjModel)):
        for field, size, doc in sorted(_array_fields(struct_name, cls)):
            if size in et.sizes:
                kind = strip.sub("", field)
                table[kind] = FieldSpec(kind, struct, field, size, doc)
    return table


def read_type(type_name: str, kind: str) -> str:
    """The element type whose attribute `kind` a selector of `type_name` reads: its own, except that an
    actuator selector on an attribute joints have and actuators lack (`qpos`, `qvel`, `qfrc_actuator`, ...)
    reads the joint each actuator's transmission drives, in actuator order (`selection.resolve` maps the ids),
    so that a policy's joint observations line up with its actions whatever order the model lists joints in.
    An attribute both have (`force`, `armature`, ...) is the actuator's: the element type decides."""
    if type_name == "actuator" and kind not in kinds_of("actuator") and kind in kinds_of("joint"):
        return "joint"
    return type_name


def element_type(name: str) -> ElementType:
    return ELEMENT_TYPES[name]


def ragged_slices(model: mujoco.MjModel, spec: FieldSpec, ids: list[int]) -> list[range]:
    """Per element, the range of flat positions a ragged field occupies."""
    adr_field, width_field = RAGGED[spec.size]
    if not hasattr(model, adr_field):  # older MuJoCo: one entry per element, in element order
        return [range(i, i + 1) for i in ids]
    adr = getattr(model, adr_field)
    out = []
    for i in ids:
        start = int(adr[i])
        if width_field == "qpos":
            width = _JOINT_QPOS_WIDTH.get(int(model.jnt_type[i]), 1)
        elif width_field == "dof":
            width = _JOINT_DOF_WIDTH.get(int(model.jnt_type[i]), 1)
        elif width_field == "one":
            width = 1
        else:
            width = int(getattr(model, width_field)[i])
        out.append(range(start, start + width) if start >= 0 else range(0))
    return out
