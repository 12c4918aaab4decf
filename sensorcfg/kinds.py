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

__all__ = ["ELEMENT_TYPES", "ElementType", "FieldSpec", "kinds_of", "element_type"]


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
