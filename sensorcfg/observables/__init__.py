"""Observable types: what one sample is.

Imported lazily (PEP 562): `sensorcfg.observables.aggregators` is numpy only, and the config layer reads
its table without importing mujoco, which the feature and camera modules need.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # for type checkers and editors; at run time each module loads on first use
    from .aggregators import AGGREGATORS
    from .base import Observable
    from .camera import Camera
    from .feature import Feature
    from .generic import BatchedGeneric, Generic

__all__ = ["AGGREGATORS", "BatchedGeneric", "Camera", "Feature", "Generic", "Observable"]

_HOMES = {"AGGREGATORS": "aggregators", "Observable": "base", "Camera": "camera", "Feature": "feature",
          "Generic": "generic", "BatchedGeneric": "generic"}


def __getattr__(name: str) -> Any:
    if name in _HOMES:
        return getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
