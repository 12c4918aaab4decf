"""The physics handle that observables receive.

sensorcfg observables accept either our own small `Physics` holder or a dm_control Physics (which exposes
the raw MuJoCo structs as `.model.ptr` and `.data.ptr`), so the same observable runs in both worlds.
"""

from __future__ import annotations

import os

import mujoco

from .mujoco_structs import structs_of

__all__ = ["Physics", "raw_structs", "read_model"]


class Physics:
    """A holder of one `mujoco.MjModel` and one `mujoco.MjData`."""

    __slots__ = ("model", "data")

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData | None = None):
        """Hold `model` and its data.

        Args:
            model: The compiled MuJoCo model.
            data: Its MjData; None: a new one (`mujoco.MjData(model)`).

        Raises:
            TypeError: `model` is not a `mujoco.MjModel`.
        """
        if not isinstance(model, mujoco.MjModel):
            raise TypeError(f"Physics needs a mujoco.MjModel, got {type(model).__name__}")
        self.model = model
        self.data = mujoco.MjData(model) if data is None else data

    @classmethod
    def from_xml_path(cls, path: str) -> Physics:
        return cls(mujoco.MjModel.from_xml_path(str(path)))

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    def step(self, nstep: int = 1) -> None:
        mujoco.mj_step(self.model, self.data, nstep)

    def forward(self) -> None:
        mujoco.mj_forward(self.model, self.data)

    def __repr__(self) -> str:
        return f"Physics(nbody={self.model.nbody}, nq={self.model.nq}, t={self.data.time:.4f})"


def read_model(path: str | os.PathLike[str]) -> mujoco.MjModel:
    """The MjModel in a file: MJCF XML, or a compiled MJB by its suffix. MuJoCo's ValueError on failure, and
    a ValueError before MuJoCo opens anything that is not a regular file (a FIFO would block it forever)."""
    from .config.files import irregular

    path = os.fspath(path)
    why = irregular(path)
    if why:
        raise ValueError(why)
    if path.lower().endswith(".mjb"):
        return mujoco.MjModel.from_binary_path(path)
    return mujoco.MjModel.from_xml_path(path)


def raw_structs(physics: object) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The raw (MjModel, MjData) of a sensorcfg or dm_control physics handle."""
    return structs_of(physics)
