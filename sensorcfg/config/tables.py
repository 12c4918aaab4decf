"""The names the config layer checks against, read from the tables that own them.

`sensorcfg.observables` imports lazily, so reading its aggregator table (numpy only) does not import
mujoco. The image kinds mirror `sensorcfg.observables.camera.MODES` (which needs mujoco); a test checks
they agree.
"""

from __future__ import annotations

from ..observables.aggregators import AGGREGATORS

__all__ = ["GLOB_CHARS", "IMAGE_KINDS", "GENERIC_KIND", "HEIGHTSCAN_KIND", "NATIVE_KINDS", "aggregator_names"]

IMAGE_KINDS: tuple[str, ...] = ("rgb", "depth", "segmentation")  # == tuple(camera.MODES), tested
GLOB_CHARS = frozenset("*?[")  # a name holding one of these is a pattern (fnmatch's): element selectors, groups
GENERIC_KIND = "generic"
HEIGHTSCAN_KIND = "heightscan"
# MuJoCo sensor types a suite adds to the model: the rows of `sensorcfg.native.table.NATIVE` (tested).
NATIVE_KINDS: tuple[str, ...] = (
    "accelerometer", "velocimeter", "gyro", "force", "torque", "magnetometer", "touch", "rangefinder",
    "camprojection", "jointpos", "jointvel", "jointactfrc", "jointlimitpos", "jointlimitvel", "jointlimitfrc",
    "ballquat", "ballangvel", "tendonpos", "tendonvel", "tendonactfrc", "tendonlimitpos", "tendonlimitvel",
    "tendonlimitfrc", "actuatorpos", "actuatorvel", "actuatorfrc", "framepos", "framequat", "framexaxis",
    "frameyaxis", "framezaxis", "framelinvel", "frameangvel", "framelinacc", "frameangacc", "subtreecom",
    "subtreelinvel", "subtreeangmom", "insidesite", "contact", "tactile", "gravity", "geomdist", "geomnormal",
    "geomfromto")


def aggregator_names() -> tuple[str, ...]:
    """The names of the built-in aggregators."""
    return tuple(AGGREGATORS)
