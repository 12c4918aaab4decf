"""A native kind on a model that carries its sensors: a `sensordata` feature of the sensors it added.

The observation of one element is its sensor's values (`(dim,)`); of several, `(n, dim)` (`(n,)` when
each has one value; sensors of different sizes, such as tactile sensors of different meshes, are
concatenated). `index` selects within that. Values are MuJoCo's own, read like any other feature, so
schedules, noise and the batch treat a native kind as they treat `sensordata`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from ..config.models import SensorConfig
from ..errors import SuiteError
from ..observables import Feature
from ..observables.feature import indexed
from ..selection import select
from .additions import Report, sensor_additions

__all__ = ["bind_native", "carry_hint"]


def carry_hint(kind: str) -> str:
    return (f"kind {kind!r} is a MuJoCo sensor that the suite adds to the model, and this model does not "
            "carry it: give the model as a path (or an MjSpec) so that the suite compiles it, or pass "
            "`suite.compile(path)`")


def bind_native(model: mujoco.MjModel, name: str, cfg: SensorConfig, timing: dict[str, Any], report: Report,
                refused: Mapping[str, str], index: Any) -> tuple[Feature, Any, Any] | None:
    """The feature reading the sensors suite sensor `name` added to `model` (problems reported)."""
    here = ("sensors", name)
    records = sensor_additions(model, name, cfg, report)
    if records is None:
        return None
    if name in refused:
        report(here + ("kind",), refused[name])
        return None
    ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, added.name) for added in records]
    expected = [int(getattr(mujoco.mjtSensor, f"mjSENS_{added.sensor}")) for added in records]
    if any(i < 0 or int(model.sensor_type[i]) != t for i, t in zip(ids, expected)):
        report(here + ("kind",), carry_hint(cfg.kind))
        return None
    dims = [int(model.sensor_dim[i]) for i in ids]
    positions: np.ndarray = np.arange(sum(dims), dtype=np.intp)
    batched = select(model, cfg.element or (), cfg.within).batched
    if batched and len(set(dims)) == 1:
        positions = positions.reshape(len(dims), dims[0]) if dims[0] > 1 else positions
    if index is not None:
        try:
            positions = indexed(positions, index, cfg.kind, cfg.element, len(records))
        except SuiteError as e:
            for p in e.problems:
                report(here + ("index",), p.message)
            return None
    elements = [f"sensor:{added.name}" for added in records]
    feature = Feature("sensordata", elements, index=positions, **timing)
    return feature, positions.shape, np.dtype(np.float64)
