"""The names the config layer checks against, read from the tables that own them.

`sensorcfg.observables` imports lazily, so reading its aggregator table (numpy only) does not import
mujoco. The image kinds mirror `sensorcfg.observables.camera.MODES` (which needs mujoco); a test checks
they agree.
"""

from __future__ import annotations

from ..observables.aggregators import AGGREGATORS

__all__ = ["IMAGE_KINDS", "GENERIC_KIND", "aggregator_names"]

IMAGE_KINDS: tuple[str, ...] = ("rgb", "depth", "segmentation")  # == tuple(camera.MODES), tested
GENERIC_KIND = "generic"


def aggregator_names() -> tuple[str, ...]:
    """The names of the built-in aggregators."""
    return tuple(AGGREGATORS)
