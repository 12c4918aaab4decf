"""`gravity`: the direction of the model's gravity in an element's frame, computed by MuJoCo.

A locomotion policy's "projected gravity" is the unit vector along gravity expressed in the base (or
IMU) frame: [0, 0, -1] when that frame is upright under MuJoCo's default gravity (0, 0, -9.81). MuJoCo
has no sensor for it, and `framezaxis` of `body:world` in that frame reads the opposite vector (up:
[0, 0, 1] upright). So the suite adds a site to the world body whose z axis points along the model's
gravity, and MuJoCo's `framezaxis` sensor of that site with the element as its reference frame: the value
is MuJoCo's own, read from `sensordata` like every native kind (schedules, noise, twins and the batch
treat it alike).

The direction is that of `opt.gravity` when the suite compiles the model. A model whose gravity is zero
has none: a problem at the sensor's kind, not a made-up vector.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np

from .table import Added

__all__ = ["KIND", "along_gravity", "gravity_quat"]

KIND = "gravity"


def gravity_quat(model: mujoco.MjModel) -> tuple[float, float, float, float] | None:
    """The orientation (w, x, y, z) of a world frame whose z axis points along the model's gravity; None
    where the gravity is zero (or not finite)."""
    g = np.asarray(model.opt.gravity, dtype=np.float64)
    norm = float(np.linalg.norm(g))
    if not (np.isfinite(norm) and norm > 0):
        return None
    quat = np.zeros(4)
    mujoco.mju_quatZ2Vec(quat, g / norm)
    w, x, y, z = (float(v) for v in quat)
    return (w, x, y, z)


def along_gravity(model: mujoco.MjModel, records: Sequence[Added], report: Callable[[tuple[Any, ...], str], None],
                  here: tuple[Any, ...]) -> list[Added] | None:
    """The records of a `gravity` sensor: each planned as the element's own frame sensor, turned into the
    z axis of a gravity-aligned world site read in the element's frame. None after reporting a model
    without gravity."""
    quat = gravity_quat(model)
    if quat is None:
        g = ", ".join(f"{v:g}" for v in model.opt.gravity)
        report(here + ("kind",), f"the model's gravity is ({g}), which has no direction; give the model a "
               "gravity (<option gravity=...>) or read the frame's axes with framexaxis/frameyaxis/framezaxis")
        return None
    return [dataclasses.replace(r, objtype="SITE", objname=r.name, reftype=r.objtype, refname=r.objname,
                                site_body=0, site_quat=quat) for r in records]
