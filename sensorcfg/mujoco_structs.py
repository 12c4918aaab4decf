"""The raw MuJoCo structs behind a physics handle, found by duck typing (no mujoco import here).

A sensorcfg `Physics` holds `model` and `data` directly; a dm_control Physics wraps them and exposes the
raw structs as `.model.ptr` and `.data.ptr`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mujoco import MjData, MjModel

__all__ = ["structs_of"]


def _is_raw(obj: object, name: str) -> bool:
    return type(obj).__name__ == name and type(obj).__module__.startswith("mujoco")


def structs_of(physics: object) -> tuple[MjModel, MjData]:
    """(MjModel, MjData) of a sensorcfg or dm_control physics handle; TypeError for anything else."""
    model, data = getattr(physics, "model", None), getattr(physics, "data", None)
    if _is_raw(model, "MjModel") and _is_raw(data, "MjData"):
        return model, data
    model, data = getattr(model, "ptr", None), getattr(data, "ptr", None)
    if _is_raw(model, "MjModel") and _is_raw(data, "MjData"):
        return model, data
    raise TypeError("expected a sensorcfg.Physics or a dm_control Physics (with .model.ptr and .data.ptr), "
                    f"got {type(physics).__name__}")
