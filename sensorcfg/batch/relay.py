"""Relays: MuJoCo sensors that copy, for a batch, the few values it reads of a wide mjData field.

`Batch.rollout` records whole fields. A suite that reads one body's orientation at every substep makes it
record every body's (xquat: 4 x nbody values per substep), and one site's frame every site's (site_xmat:
9 x nsite). A frame sensor (or a subtree-com sensor) on that element copies exactly the values read into
`sensordata` during the step, so the batch records `sensordata` instead of the field: for the benchmark
humanoid, half of what a control step records.

A relay is an exact copy, not an approximation: the sensors copy the field's doubles (frame position and
axes of a body, inertial frame, geom, site or camera; the quaternion of a body's frame; a subtree's
center of mass), and `exact` checks on the compiled model, by stepping it from a perturbed state, that
every relayed value equals its field's bit for bit; the batch then uses them, or none. With the RK4
integrator the fields hold the last of its four evaluations while sensors hold the first: no relays.

A field is relayed when every sensor reading it can be, and when the sensors cost less than recording the
field (`SENSOR_COST`). Their names start with `selection.ADDED_PREFIX`, so no suite selects them. Relays
change no dynamics (sensors are outputs only) and only add sensors at the end of the model's, so the
model's own `sensordata` indices stay as they were. They need the model as a path or an MjSpec (an
MjModel cannot take sensors).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import NamedTuple

import mujoco
import numpy as np

from ..native.table import Added
from ..selection import ADDED_PREFIX
from ..plan import Source

__all__ = ["RELAYS", "SENSOR_COST", "Relays", "choose", "exact", "positions", "relayed"]

# What MuJoCo spends on one more sensor per step, in recorded values (a sensor's loop step and copy against
# the copy of one double by `rollout`): benchmarks/batch_floor.py's "native physics" (181 sensors added
# to the humanoid) against its recorded fields.
SENSOR_COST = 4


class _Relay(NamedTuple):
    objtype: str  # the mjtObj member (without prefix) the sensors are attached to
    names: str  # the mjtObj member whose names the field's elements have
    size: str  # the MjModel size that counts them
    width: int  # values per element in the field
    sensors: tuple[tuple[str, tuple[int, ...]], ...]  # mjtSensor member, the element's values it copies in order


_POS = (("FRAMEPOS", (0, 1, 2)),)
_AXES = (("FRAMEXAXIS", (0, 3, 6)), ("FRAMEYAXIS", (1, 4, 7)), ("FRAMEZAXIS", (2, 5, 8)))  # xmat's columns

RELAYS: dict[str, _Relay] = {
    "xpos": _Relay("XBODY", "BODY", "nbody", 3, _POS),
    "xmat": _Relay("XBODY", "BODY", "nbody", 9, _AXES),
    "xquat": _Relay("XBODY", "BODY", "nbody", 4, (("FRAMEQUAT", (0, 1, 2, 3)),)),
    "xipos": _Relay("BODY", "BODY", "nbody", 3, _POS),
    "ximat": _Relay("BODY", "BODY", "nbody", 9, _AXES),
    "subtree_com": _Relay("BODY", "BODY", "nbody", 3, (("SUBTREECOM", (0, 1, 2)),)),
    "geom_xpos": _Relay("GEOM", "GEOM", "ngeom", 3, _POS),
    "geom_xmat": _Relay("GEOM", "GEOM", "ngeom", 9, _AXES),
    "site_xpos": _Relay("SITE", "SITE", "nsite", 3, _POS),
    "site_xmat": _Relay("SITE", "SITE", "nsite", 9, _AXES),
    "cam_xpos": _Relay("CAMERA", "CAMERA", "ncam", 3, _POS),
    "cam_xmat": _Relay("CAMERA", "CAMERA", "ncam", 9, _AXES),
}


_Copies = list[tuple[str, tuple[int, ...]]]  # (sensor name, the field positions it copies, in order)


class Relays(NamedTuple):
    """The sensors to add, and per relayed field which of its positions each one copies."""

    records: list[Added]
    copies: dict[str, _Copies]  # per field


def _name(field: str, element: int, sensor: str) -> str:
    return f"{ADDED_PREFIX}relay:{field}:{element}:{sensor}"


def _field_relays(model: mujoco.MjModel, field: str, positions: np.ndarray) -> tuple[list[Added], _Copies] | None:
    """The sensors relaying `positions` of `field`, or None when an element has no name to attach them to."""
    relay = RELAYS[field]
    records: list[Added] = []
    copies: _Copies = []
    for element in np.unique(positions // relay.width).tolist():
        objname = mujoco.mj_id2name(model, getattr(mujoco.mjtObj, f"mjOBJ_{relay.names}"), element)
        if not objname:
            return None
        for sensor, within in relay.sensors:
            name = _name(field, element, sensor)
            records.append(Added(name=name, sensor=sensor, objtype=relay.objtype, objname=objname))
            copies.append((name, tuple(element * relay.width + k for k in within)))
    return records, copies


def _size(model: mujoco.MjModel, field: str) -> int:
    relay = RELAYS[field]
    return relay.width * int(getattr(model, relay.size))


def choose(model: mujoco.MjModel, sources: Sequence[Source], recorded: Mapping[str, int],
           substeps: int) -> Relays | None:
    """The relays worth adding for a batch that records each field of `recorded` after that many substeps
    of a control step of `substeps`, reading `sources`; None when none pays.

    A field pays when its relays' sensors (computed at every substep) and values (recorded with
    `sensordata`) cost less than recording it; with them all, `sensordata` itself, if it was recorded
    after fewer substeps or not at all."""
    if (model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
            or model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_SENSOR):
        return None
    records: list[Added] = []
    copies: dict[str, _Copies] = {}
    gain, before = 0, recorded.get("sensordata", 0)
    after = before
    for field, steps in sorted(recorded.items()):  # (the fields in a fixed order: the same model in every process)
        read = [s.positions.ravel() for s in sources if s.field == field]
        found = _field_relays(model, field, np.concatenate(read)) if field in RELAYS and read else None
        if found is None:
            continue
        cost = len(found[0]) * SENSOR_COST * substeps + sum(len(w) for _, w in found[1]) * steps
        if cost < _size(model, field) * steps:
            records += found[0]
            copies[field] = found[1]
            gain += _size(model, field) * steps - cost
            after = max(after, steps)
    gain -= model.nsensordata * (after - before)
    return Relays(records, copies) if records and gain > 0 else None


def positions(model: mujoco.MjModel, relays: Relays) -> dict[str, dict[int, int]]:
    """Per relayed field: its position -> the position in `sensordata` that copies it, on the compiled model."""
    out: dict[str, dict[int, int]] = {}
    for field, copies in relays.copies.items():
        at = out.setdefault(field, {})
        for name, within in copies:
            adr = int(model.sensor(name).adr[0])
            at.update({p: adr + k for k, p in enumerate(within)})
    return out


def relayed(sources: Iterable[Source], where: Mapping[str, Mapping[int, int]]) -> list[Source]:
    """`sources` with relayed fields read from `sensordata`."""
    out = []
    for s in sources:
        if s.field in where:
            lookup = where[s.field]
            s = Source("sensordata", np.vectorize(lookup.__getitem__, otypes=[np.intp])(s.positions))
        out.append(s)
    return out


def exact(model: mujoco.MjModel, where: Mapping[str, Mapping[int, int]], steps: int = 3) -> bool:
    """Whether every relayed value equals its field's, bit for bit, after steps of the model from its
    reset state with every velocity perturbed (seeded) and random controls."""
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    data.qvel[:] = rng.normal(0.0, 0.3, model.nv)
    lo, hi = model.actuator_ctrlrange.T if model.nu else (np.zeros(0), np.zeros(0))
    for _ in range(steps):
        limited = model.actuator_ctrllimited.astype(bool)
        data.ctrl[:] = np.where(limited, rng.uniform(lo, hi), rng.normal(0.0, 1.0, model.nu))
        mujoco.mj_step(model, data)
        for field, lookup in where.items():
            field_pos = np.fromiter(lookup.keys(), np.intp)
            copied = data.sensordata[np.fromiter(lookup.values(), np.intp)]
            if not np.array_equal(getattr(data, field).ravel()[field_pos].view(np.int64), copied.view(np.int64)):
                return False
    return True
