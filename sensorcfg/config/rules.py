"""After the schema: `defaults` filled into each sensor, and which keys belong to which kinds.

The schema checks each key alone; these rules check keys against each other (an `element` on a generic
sensor, a camera without `element`) and give each sensor its effective settings: its own, else
`defaults`, else the built-ins. Camera settings merge field by field.
"""

from __future__ import annotations

from typing import Any

from ..errors import Problem
from .locate import problem_at
from .models import CameraConfig, ScanConfig, SensorConfig, SuiteConfig
from .source import Doc, Path_, dotted
from .tables import GENERIC_KIND, HEIGHTSCAN_KIND, IMAGE_KINDS, NATIVE_KINDS

__all__ = ["effective"]


def _is_feature(kind: str) -> bool:
    return kind not in IMAGE_KINDS and kind not in (GENERIC_KIND, HEIGHTSCAN_KIND)


def _is_native(kind: str) -> bool:
    return kind in NATIVE_KINDS


_NATIVE_ONLY = "MuJoCo sensor kinds (velocimeter, framepos, contact, ...)"


# key -> (which kinds may have it, what to call them in a message)
_ONLY_FOR = {
    "element": (lambda k: k != GENERIC_KIND, "sensors that read model elements, not 'generic' ones"),
    "within": (_is_feature, "sensors that read an attribute of model elements"),
    "index": (_is_feature, "sensors that read an attribute of model elements"),
    "camera": (lambda k: k in IMAGE_KINDS, "image sensors (kind rgb, depth or segmentation)"),
    "callable": (lambda k: k == GENERIC_KIND, "kind 'generic'"),
    "batched": (lambda k: k == GENERIC_KIND, "kind 'generic'"),
    "frame": (_is_native, _NATIVE_ONLY),
    "with_": (_is_native, _NATIVE_ONLY),
    "data": (_is_native, _NATIVE_ONLY),
    "reduce": (_is_native, _NATIVE_ONLY),
    "num": (_is_native, _NATIVE_ONLY),
    "cutoff": (_is_native, _NATIVE_ONLY),
    "scan": (lambda k: k == HEIGHTSCAN_KIND, f"kind {HEIGHTSCAN_KIND!r}"),
}
# key -> (which kinds need it, an example)
_NEEDS = {
    "element": (lambda k: k != GENERIC_KIND, "element: 'joint:*'"),
    "callable": (lambda k: k == GENERIC_KIND, "callable: 'my_pkg.sensors:distance'"),
}
_IMAGE_EXAMPLE = "element: 'camera:wrist'"
_FROM_DEFAULTS = ("interval", "delay", "buffer", "aggregator", "enabled", "noise", "twin")


def effective(name: str, sensor: SensorConfig, config: SuiteConfig, doc: Doc) -> tuple[SensorConfig, list[Problem]]:
    """A sensor with `defaults` filled in, and the problems of keys that do not fit its kind."""
    problems = []
    here = ("sensors", name)
    for key, (allowed, who) in _ONLY_FOR.items():
        if getattr(sensor, key) is not None and not allowed(sensor.kind):
            label = key.rstrip("_")
            problems.append(problem_at(doc, here + (label,), f"{label!r} is only for {who}; this sensor's kind "
                                       f"is {sensor.kind!r}: remove it or change the kind", key=True))
    for key, (needed, example) in _NEEDS.items():
        if getattr(sensor, key) is None and needed(sensor.kind):
            example = _IMAGE_EXAMPLE if sensor.kind in IMAGE_KINDS and key == "element" else example
            problems.append(Problem(f"a sensor of kind {sensor.kind!r} needs {key!r}, for example {example}",
                                    dotted(here + (key,)), *_key_where(doc, here)))
    if config.cameras:
        problems += _camera_ids(sensor, doc, here)
    defaults = config.defaults
    update: dict[str, Any] = {}
    for field in _FROM_DEFAULTS:
        if getattr(sensor, field) is None and getattr(defaults, field) is not None:
            update[field] = getattr(defaults, field)
    if sensor.kind in IMAGE_KINDS:
        update["camera"] = _merge_camera(defaults.camera, sensor.camera)
    if sensor.kind == HEIGHTSCAN_KIND and sensor.scan is None:
        update["scan"] = ScanConfig.model_validate({})
    if update.get("enabled", sensor.enabled) is None:
        update["enabled"] = True
    if update.get("noise", sensor.noise) is None:
        update["noise"] = ()
    return sensor.model_copy(update=update), problems


def _camera_ids(sensor: SensorConfig, doc: Doc, here: Path_) -> list[Problem]:
    """A camera selected by id (`camera:#1`) in a suite that adds cameras: MuJoCo numbers cameras by their
    place in the body tree, so an added camera can take the id of one of the model's own, and the sensor
    would read another camera than the one the id meant without the suite's cameras (a base suite that a
    child extending it gives cameras)."""
    found = []
    for key in ("element", "frame", "with"):
        value = getattr(sensor, "with_" if key == "with" else key, None)
        entries = [(value, (key,))] if isinstance(value, str) else [(v, (key, i)) for i, v in enumerate(value or ())]
        for text, where in entries:
            type_name, _, name = text.partition(":")
            if type_name.strip() == "camera" and name.strip().startswith("#"):
                found.append(problem_at(doc, here + where, (
                    f"{text!r} selects a camera by id, and this suite adds cameras ('cameras:'), which MuJoCo numbers "
                    "with the model's own by their place in the body tree, so an id can name another camera than "
                    "without them: name the camera ('camera:<name>')")))
    return found


def _key_where(doc: Doc, path: Path_) -> tuple[str | None, int | None, int | None]:
    pos = doc.pos(path, key=True)
    return (pos.file, pos.line, pos.col) if pos else (None, None, None)


def _merge_camera(default: CameraConfig | None, own: CameraConfig | None) -> CameraConfig:
    """Camera settings field by field: the sensor's own, then `defaults.camera`, then the built-ins."""
    fields: dict[str, Any] = {}
    for source in (default, own):
        if source is not None:
            fields.update({f: getattr(source, f) for f in source.model_fields_set})
    return CameraConfig.model_validate(fields)
