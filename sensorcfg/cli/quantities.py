"""What each value of an observation measures, for the plot: its quantity, its SI unit and a label.

A plot that draws a gyro's rad/s and an accelerometer's m/s² on one axis, or a hinge's radians beside a
slide's metres, shows numbers without meaning. So the values of one observation are split into groups of
one quantity and unit (one axis each), each value labelled by its element and component. The tables below
say what MuJoCo's sensors and fields hold; a value they do not describe (a `generic` callable, an `index`
that picks values out of order) is one group of plain "values".
"""

from __future__ import annotations

from typing import Any, NamedTuple

import mujoco

__all__ = ["UNKNOWN_UNIT", "ValueGroup", "value_groups", "SENSOR_QUANTITIES", "KIND_QUANTITIES"]


class ValueGroup(NamedTuple):
    """Values of one observation that share a quantity and a unit: one axis of the plot."""

    quantity: str
    unit: str  # '' when the values have none (a quaternion, a control); UNKNOWN_UNIT when it is not known
    columns: tuple[int, ...]  # positions in the observation's flattened value (one sample)
    labels: tuple[str, ...]  # one per column


UNKNOWN_UNIT = "unit not known"  # a generic callable's values, or values picked by `index`
_POSITION, _LINVEL, _ANGVEL = ("position", "m"), ("linear velocity", "m/s"), ("angular velocity", "rad/s")
_QUAT, _FORCE_OR_TORQUE = ("orientation (quaternion)", ""), ("force or torque", "N or N·m")
_AXIS = ("direction (unit vector)", "")

# MuJoCo sensor type (mjtSensor without 'mjSENS_', lower case; also the suite's MuJoCo sensor kinds) ->
# (quantity, unit)
SENSOR_QUANTITIES: dict[str, tuple[str, str]] = {
    "accelerometer": ("linear acceleration", "m/s²"), "velocimeter": _LINVEL, "gyro": _ANGVEL,
    "force": ("force", "N"), "torque": ("torque", "N·m"), "magnetometer": ("magnetic field", "T"),
    "touch": ("normal force", "N"), "rangefinder": ("distance", "m"), "camprojection": ("image position", "px"),
    "jointpos": ("joint position", "rad or m"), "jointvel": ("joint velocity", "rad/s or m/s"),
    "jointactfrc": _FORCE_OR_TORQUE, "jointlimitpos": ("limit distance", "rad or m"),
    "jointlimitvel": ("limit velocity", "rad/s or m/s"), "jointlimitfrc": _FORCE_OR_TORQUE,
    "ballquat": _QUAT, "ballangvel": _ANGVEL,
    "tendonpos": ("tendon length", "m"), "tendonvel": ("tendon velocity", "m/s"), "tendonactfrc": ("force", "N"),
    "tendonlimitpos": ("limit distance", "m"), "tendonlimitvel": ("limit velocity", "m/s"),
    "tendonlimitfrc": ("force", "N"),
    "actuatorpos": ("actuator length", "rad or m"), "actuatorvel": ("actuator velocity", "rad/s or m/s"),
    "actuatorfrc": _FORCE_OR_TORQUE,
    "framepos": _POSITION, "framequat": _QUAT, "framexaxis": _AXIS, "frameyaxis": _AXIS, "framezaxis": _AXIS,
    "framelinvel": _LINVEL, "frameangvel": _ANGVEL, "framelinacc": ("linear acceleration", "m/s²"),
    "frameangacc": ("angular acceleration", "rad/s²"), "subtreecom": _POSITION, "subtreelinvel": _LINVEL,
    "subtreeangmom": ("angular momentum", "kg·m²/s"), "geomdist": ("distance", "m"), "geomnormal": _AXIS,
    "geomfromto": _POSITION, "clock": ("time", "s"), "e_potential": ("energy", "J"), "e_kinetic": ("energy", "J"),
    "gravity": _AXIS,  # (a suite kind, MuJoCo's framezaxis of a site along gravity: `native.gravity`)
}

# attribute kind -> (quantity, unit), for kinds whose unit does not depend on the element (qpos and qvel do)
KIND_QUANTITIES: dict[str, tuple[str, str]] = {
    "xpos": _POSITION, "xipos": _POSITION, "site_xpos": _POSITION, "geom_xpos": _POSITION, "xanchor": _POSITION,
    "subtree_com": _POSITION, "cam_xpos": _POSITION, "light_xpos": _POSITION, "xquat": _QUAT,
    "xaxis": _AXIS, "ctrl": ("control", ""), "act": ("actuator activation", ""),
    "force": _FORCE_OR_TORQUE, "length": ("actuator length", "rad or m"),
    "velocity": ("actuator velocity", "rad/s or m/s"), "qfrc_applied": _FORCE_OR_TORQUE,
    "qfrc_actuator": _FORCE_OR_TORQUE, "qfrc_bias": _FORCE_OR_TORQUE, "qfrc_passive": _FORCE_OR_TORQUE,
    "qfrc_constraint": _FORCE_OR_TORQUE, "qfrc_smooth": _FORCE_OR_TORQUE, "qacc": ("joint acceleration", ""),
    "ten_length": ("tendon length", "m"), "ten_velocity": ("tendon velocity", "m/s"), "time": ("time", "s"),
    "subtree_linvel": _LINVEL, "subtree_angmom": ("angular momentum", "kg·m²/s"),
}

# (element type, kind) -> (quantity, unit), where a kind's name means another thing on that element type
_BY_TYPE: dict[tuple[str, str], tuple[str, str]] = {("actuator", "force"): _FORCE_OR_TORQUE}

_AXES = {3: "xyz", 4: "wxyz"}
_JOINT = mujoco.mjtJoint
# joint type -> the (quantity, unit, width) runs of its qpos, and of its qvel
_QPOS = {_JOINT.mjJNT_FREE: ((_POSITION, 3), (_QUAT, 4)), _JOINT.mjJNT_BALL: ((_QUAT, 4),),
         _JOINT.mjJNT_SLIDE: ((("joint position", "m"), 1),), _JOINT.mjJNT_HINGE: ((("joint angle", "rad"), 1),)}
_QVEL = {_JOINT.mjJNT_FREE: ((_LINVEL, 3), (_ANGVEL, 3)), _JOINT.mjJNT_BALL: ((_ANGVEL, 3),),
         _JOINT.mjJNT_SLIDE: ((("joint velocity", "m/s"), 1),), _JOINT.mjJNT_HINGE: ((_ANGVEL, 1),)}
_JOINT_RUNS = {"qpos": _QPOS, "qvel": _QVEL}


class _Run(NamedTuple):
    quantity: tuple[str, str]
    labels: tuple[str, ...]


def _components(name: str, width: int) -> tuple[str, ...]:
    if width == 1:
        return (name,)
    axes = _AXES.get(width)
    return tuple(f"{name}.{axes[i]}" if axes else f"{name}[{i}]" for i in range(width))


def _sensor_type(model: mujoco.MjModel, i: int) -> str:
    return mujoco.mjtSensor(int(model.sensor_type[i])).name.removeprefix("mjSENS_").lower()


def _runs(model: mujoco.MjModel, cfg: Any, width: int) -> list[_Run] | None:
    """The values' runs of one quantity, in order; None when the layout is not known."""
    from ..selection import select

    if cfg.kind == "generic" or cfg.element is None or cfg.index is not None:
        return None
    selection = select(model, cfg.element, cfg.within, kind=cfg.kind)
    type_name, ids = selection.type, list(selection.ids)
    # each selected element's label, as the selection gives it: `ids` index the compiled model, whose lists
    # hold the sites and sensors the suite added among the file's own
    names = selection.names
    if cfg.kind == "sensordata" and type_name == "sensor":
        return [_Run(SENSOR_QUANTITIES.get(_sensor_type(model, i), ("value", UNKNOWN_UNIT)),
                     _components(name, int(model.sensor_dim[i]))) for i, name in zip(ids, names)]
    if cfg.kind in _JOINT_RUNS and type_name == "joint":
        runs = []
        for i, name in zip(ids, names):
            parts = _JOINT_RUNS[cfg.kind][_JOINT(int(model.jnt_type[i]))]
            for k, (quantity, n) in enumerate(parts):
                suffix = "" if len(parts) == 1 else (".pos", ".quat", ".lin", ".ang")[k + 2 * (cfg.kind == "qvel")]
                runs.append(_Run(quantity, _components(name + suffix, n)))
        return runs
    found = _BY_TYPE.get((type_name, cfg.kind)) or SENSOR_QUANTITIES.get(cfg.kind) or KIND_QUANTITIES.get(cfg.kind)
    if found is None or not ids or width % len(ids):
        return None
    return [_Run(found, _components(name, width // len(ids))) for name in names]


def value_groups(model: mujoco.MjModel, cfg: Any, width: int) -> tuple[ValueGroup, ...]:
    """The values of one sample (`width` of them, flattened) grouped by quantity and unit, in the order of
    their first value; one group of plain values when the layout is not known."""
    runs = _runs(model, cfg, width)
    if runs is None or sum(len(r.labels) for r in runs) != width:
        return (ValueGroup("value", UNKNOWN_UNIT, tuple(range(width)), tuple(f"[{i}]" for i in range(width))),)
    columns: dict[tuple[str, str], list[int]] = {}
    labels: dict[tuple[str, str], list[str]] = {}
    start = 0
    for run in runs:
        columns.setdefault(run.quantity, []).extend(range(start, start + len(run.labels)))
        labels.setdefault(run.quantity, []).extend(run.labels)
        start += len(run.labels)
    return tuple(ValueGroup(q, u, tuple(columns[(q, u)]), tuple(labels[(q, u)])) for q, u in columns)


