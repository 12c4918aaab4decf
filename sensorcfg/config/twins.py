"""Clean twins: a sensor delivered a second time, without noise and latency, under another key.

`twin: name` on a sensor (or `defaults.twin: "{name}_clean"`, `twin: false` to opt out) adds the twin
right after its sensor: the same kind, elements and options, no noise, no delay; with a buffer of 1 it
samples every step, so its one sample is taken at the read; a longer buffer keeps the sensor's interval
(its history's spacing) and aggregator. A twin of a MuJoCo sensor kind reads the sensor its source adds.
"""

from __future__ import annotations

import re

from ..errors import Problem
from .locate import problem_at
from .models import SENSOR_NAME_PATTERN, SensorConfig
from .source import Doc

__all__ = ["with_twins"]


def _twin_of(cfg: SensorConfig) -> SensorConfig:
    """The clean twin of a sensor: no noise, no delay; with a buffer of 1 it samples every step, so its one
    sample is taken at the read; a longer buffer keeps the sensor's interval (its history's spacing)."""
    interval = 1 if (cfg.buffer or 1) == 1 else cfg.interval
    return cfg.model_copy(update={"noise": (), "delay": 0, "interval": interval, "twin": None, "enabled": True})


def with_twins(sensors: dict[str, SensorConfig], doc: Doc,
               problems: list[Problem]) -> tuple[dict[str, SensorConfig], dict[str, str]]:
    """Each sensor followed by its clean twin, when it has one (`twin:`, or `defaults.twin` with '{name}')."""
    out: dict[str, SensorConfig] = {}
    twins: dict[str, str] = {}
    for name, cfg in sensors.items():
        out[name] = cfg
        if cfg.twin is None or cfg.twin is False:
            continue
        own = cfg.twin if isinstance(cfg.twin, str) else None
        where = ("sensors", name, "twin") if doc.pos(("sensors", name, "twin")) else ("defaults", "twin")
        twin = own.replace("{name}", name) if own is not None else None
        if twin is None or not re.match(SENSOR_NAME_PATTERN, twin):
            problems.append(problem_at(doc, where, f"twin takes the name of the clean copy (letters, digits, _ - /; "
                                       f"'{{name}}' stands for the sensor's name); got {cfg.twin!r}"))
            continue
        if twin in sensors or twin in out:
            problems.append(problem_at(doc, where, f"twin {twin!r} is already a sensor's name; choose another"))
            continue
        out[twin] = _twin_of(cfg)
        twins[twin] = name
    return out, twins
