"""The names the config layer checks against, read from the tables that own them.

The config layer must not import mujoco, and `sensorcfg.observables` (which owns the aggregator table)
imports mujoco in its package `__init__`. So the aggregator table is read from its own module file,
which imports numpy only. (If `sensorcfg.observables.aggregators` is already imported, that module is
used.) The image kinds mirror `sensorcfg.observables.camera.MODES`; a test checks they agree.
"""

from __future__ import annotations

import functools
import importlib.util
import sys
from pathlib import Path

__all__ = ["IMAGE_KINDS", "GENERIC_KIND", "aggregator_names"]

IMAGE_KINDS: tuple[str, ...] = ("rgb", "depth", "segmentation")  # == tuple(camera.MODES), tested
GENERIC_KIND = "generic"


@functools.cache
def aggregator_names() -> tuple[str, ...]:
    """The names of `sensorcfg.observables.aggregators.AGGREGATORS`, without importing mujoco."""
    module = sys.modules.get("sensorcfg.observables.aggregators")
    if module is None:
        path = Path(__file__).resolve().parent.parent / "observables" / "aggregators.py"
        spec = importlib.util.spec_from_file_location("_sensorcfg_aggregator_table", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    return tuple(module.AGGREGATORS)
