"""Observation groups laid out: which columns of a group's vector each observation fills, and the one
concatenation every engine uses (numpy arrays on the CPU engines, torch tensors or Warp arrays on the GPU).

The suite's `groups:` (`config.groups`: names in column order) and the observations' shapes give each group
its `Column`s: observation `name` fills columns `start:stop` of the group's vector, flattened in C order
(buffer axis first), for each simulation. A group's vector is float32 when every member is (the Warp engine),
else float64.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["Column", "Group", "layout"]


@dataclasses.dataclass(frozen=True)
class Column:
    """Where one observation lies in its group's vector: columns `start:stop`, its `shape` flattened (C order)."""

    name: str
    start: int
    stop: int
    shape: tuple[int, ...]  # of one simulation's observation


@dataclasses.dataclass(frozen=True)
class Group:
    """One observation group: its columns in order, `width` values per simulation."""

    name: str
    columns: tuple[Column, ...]

    @property
    def width(self) -> int:
        return self.columns[-1].stop if self.columns else 0

    def concatenate(self, observation: Mapping[str, Any], batch_dims: int = 0) -> Any:
        """The group's vector from an observation dict: (width,) for one simulation, (n, width) with
        `batch_dims=1`. numpy arrays give a numpy array; torch tensors or Warp arrays a torch tensor (a Warp
        array is viewed with `wp.to_torch`, no copy), on their device."""
        values = [observation[c.name] for c in self.columns]
        if type(values[0]).__module__.startswith("warp"):
            import warp as wp

            values = [wp.to_torch(v) for v in values]
        if type(values[0]).__module__.startswith("torch"):
            import torch

            dtype = torch.float32 if all(v.dtype == torch.float32 for v in values) else torch.float64
            lead = tuple(values[0].shape[:batch_dims])
            return torch.cat([v.reshape(*lead, -1).to(dtype) for v in values], dim=-1)
        arrays = [np.asarray(v) for v in values]
        dtype = np.float32 if all(a.dtype == np.float32 for a in arrays) else np.float64
        lead = arrays[0].shape[:batch_dims]
        return np.concatenate([a.reshape(*lead, -1).astype(dtype, copy=False) for a in arrays], axis=-1)

    def describe(self) -> list[dict[str, Any]]:
        """The columns as plain data (`sensorcfg spec --format json`)."""
        return [{"name": c.name, "columns": [c.start, c.stop], "shape": list(c.shape)} for c in self.columns]


def layout(groups: Mapping[str, tuple[str, ...]], shapes: Mapping[str, tuple[int, ...]]) -> dict[str, Group]:
    """Each group's columns, from the observations' shapes (of one simulation)."""
    out = {}
    for group, names in groups.items():
        columns, start = [], 0
        for name in names:
            shape = tuple(int(n) for n in shapes[name])
            stop = start + math.prod(shape)
            columns.append(Column(name, start, stop, shape))
            start = stop
        out[group] = Group(group, tuple(columns))
    return out
