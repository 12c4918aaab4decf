"""How the commands describe an enabled observation: `SensorRow`, one line of `sensorcfg spec`.

The same rows feed the spec table, the run's summary and JSON sidecar, and the plot's labels, so a number
is computed once: element counts from the model, shapes and dtypes from the Updater's dm_env specs,
intervals and delays in steps with their Hz and ms, and the noise stages in order.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

__all__ = ["SensorRow", "describe", "describe_bounds", "describe_schedule", "noise_summary", "naive_samples"]


@dataclasses.dataclass(frozen=True)
class SensorRow:
    """One enabled observation as `sensorcfg spec` shows it."""

    name: str
    kind: str
    elements: int | None  # None for generic callables
    shape: tuple[int, ...]
    dtype: str
    interval: str  # steps, e.g. '2' or '1..3' or '{2,4}'
    rate_hz: str
    delay: str
    delay_ms: str
    buffer: int
    aggregator: str | None
    noise: str
    interval_steps: int | None  # fixed schedules only (None when drawn per sample)
    delay_steps: int | None
    buffer_axis: bool  # whether the observation's first axis is the buffer (no aggregator, not stripped)
    bounds: str = "-"  # the spec's 'minimum..maximum' (after noise: sensorcfg.noise.bounds), '-' when unbounded

    def as_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["shape"] = list(self.shape)
        return d


def _g(x: float) -> str:
    return f"{x:.4g}"


def describe_schedule(value: Any, default: int, timestep: float, *, rate: bool) -> tuple[str, str, int | None]:
    """(steps, Hz or ms, fixed steps or None) for an interval or delay: an int, UniformSteps or ChoiceSteps."""
    from ..draws import ChoiceSteps, UniformSteps

    value = getattr(value, "draw", value)  # a run's timing Recorder: describe what it draws from

    def unit(steps: float) -> str:
        if rate:
            return _g(1.0 / (steps * timestep)) if steps else "inf"
        return _g(steps * timestep * 1e3)

    if value is None or isinstance(value, int):
        steps = default if value is None else int(value)
        return str(steps), unit(steps), steps
    if isinstance(value, UniformSteps):
        lo, hi = (unit(value.high), unit(value.low)) if rate else (unit(value.low), unit(value.high))
        return f"{value.low}..{value.high}", f"{lo}..{hi}", None
    if isinstance(value, ChoiceSteps):
        return "{" + ",".join(map(str, value.values)) + "}", "{" + ",".join(unit(v) for v in value.values) + "}", None
    return "drawn", "?", None


def noise_summary(stages: Sequence[Any]) -> str:
    """'gaussian(std=0.01) > quantize(step=0.001)' from the sensor's noise stage configs."""
    parts = []
    for stage in stages:
        # (warnings=False: a per-value list is held as a tuple, which pydantic warns about while dumping it as is)
        params = stage.model_dump(exclude_defaults=True, exclude={"type"}, warnings=False)
        text = ", ".join(f"{k}={_compact(v)}" for k, v in params.items())
        parts.append(f"{stage.type}({text})" if text else stage.type)
    return " > ".join(parts) or "-"


def _compact(value: Any) -> str:
    if isinstance(value, float):
        return _g(value)
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(_compact(v) for v in value) + "]" if len(value) <= 4 else f"[{len(value)} values]"
    return str(value)


def describe(suite: Any, observables: dict[str, Any], spec: dict[str, Any], model: Any) -> list[SensorRow]:
    """A row per enabled observation, in suite order, from the built observables and the dm_env specs."""
    from ..selection import select

    timestep = float(model.opt.timestep)
    rows = []
    for name, obs in observables.items():
        if not obs.enabled or name not in spec:
            continue
        cfg = suite.sensors[name]
        if cfg.kind == "generic":
            elements = None
        elif cfg.element is None:
            elements = 0
        else:
            elements = len(select(model, cfg.element, cfg.within, kind=cfg.kind).ids)
        interval, hz, interval_steps = describe_schedule(obs.update_interval, 1, timestep, rate=True)
        delay, ms, delay_steps = describe_schedule(obs.delay, 0, timestep, rate=False)
        buffer = obs.buffer_size or 1
        buffer_axis = cfg.aggregator is None and not (suite.options.strip_singleton_buffer_dim and buffer == 1)
        rows.append(SensorRow(name, cfg.kind, elements, tuple(spec[name].shape), str(spec[name].dtype),
                              interval, hz, delay, ms, buffer, cfg.aggregator, noise_summary(cfg.noise or ()),
                              interval_steps, delay_steps, buffer_axis, describe_bounds(spec[name], obs)))
    return rows


def describe_bounds(spec: Any, observable: Any = None) -> str:
    """'0..255', '0..inf', '[0,-1]..[1,1]' (per value), '-' for an unbounded spec, '- (noise)' when the
    observable's own bounds were dropped because its noise can leave them."""
    import numpy as np

    if not hasattr(spec, "minimum"):
        own = getattr(observable, "array_spec", None)
        dropped = hasattr(own, "minimum") and getattr(observable, "noise", None) is not None
        return "- (noise)" if dropped else "-"

    def one(value: Any) -> str:
        flat = np.unique(np.asarray(value))
        return _compact(flat.item() if flat.size == 1 else flat.tolist())

    return f"{one(spec.minimum)}..{one(spec.maximum)}"


def naive_samples(row: SensorRow, physics_steps: int) -> int | None:
    """Samples an every-interval schedule takes in `physics_steps` (the reset sample included)."""
    if row.interval_steps is None:
        return None
    return physics_steps // row.interval_steps + 1
