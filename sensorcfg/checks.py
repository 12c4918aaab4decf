"""Checks of one sensor against the model's tables: whether its `kind` is state (or a constant it asks
for); with its value's shape, what `Environment` would refuse or read wrongly at its first step; and
(asked for with `batch=True`) what `BatchEnvironment` cannot run.

Each rule returns (key, message) pairs; binding reports them at the key's line (the sensor's own key, or
`defaults`), all at once. The batch rules mirror the checks `BatchUpdater` makes on observables built in
Python, for suites, where a line can be named.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from typing import Any

import mujoco
import numpy as np

from .config.models import ChoiceDraw, SensorConfig, UniformDraw
from .config.tables import GENERIC_KIND, HEIGHTSCAN_KIND, IMAGE_KINDS
from .errors import did_you_mean
from .refusals import batch_refusal, per_simulation_refusal
from .kinds import CONSTANT, INTERNAL, STATE, kinds_of, offered_kinds, state_twin
from .observables.feature import batch_on_demand_problem

__all__ = ["constant_problem", "render_cost", "kind_problems", "sensor_problems", "batch_problems", "batch_refusal",
           "per_simulation_refusal"]

Found = list[tuple[tuple[str | int, ...], str]]  # (key path inside the sensor, message)

_PER_SIMULATION_WHAT = {"aggregator": "an aggregator", "interval": "a drawn interval", "delay": "a drawn delay"}


def kind_problems(type_name: str, kind: str, constant: bool, native: Sequence[str] = ()) -> Found:
    """A kind the type does not offer (internal fields included), a constant read without `constant: true`,
    or `constant: true` on state; "did you mean" prefers state kinds, then MuJoCo sensor types (`native`)."""
    spec = kinds_of(type_name).get(kind)
    role = spec.role if spec is not None else INTERNAL
    if role == INTERNAL:
        states, constants = offered_kinds(type_name, STATE), offered_kinds(type_name, CONSTANT)
        hint = did_you_mean(kind, states + (list(IMAGE_KINDS) if type_name == "camera" else []) + list(native))
        if not hint and did_you_mean(kind, constants):
            hint = did_you_mean(kind, constants)[:-2] + ", a model constant read with 'constant: true'?)"
        what = f" ({spec.field} is MuJoCo's internal bookkeeping, not a value to sense)" if spec else ""
        extra = f"; a camera image is kind {', '.join(IMAGE_KINDS)}" if type_name == "camera" else ""
        sensors = f"; MuJoCo sensors on a {type_name}: {', '.join(native)}" if native else ""
        return [(("kind",), f"a {type_name} has no kind {kind!r}{what}{hint}; {type_name} kinds: "
                 f"{', '.join(states) or '(none that change with the simulation)'}{sensors}{extra}")]
    assert spec is not None  # only INTERNAL covers a kind the type lacks
    if role == CONSTANT and not constant:
        twin = state_twin(type_name, kind)
        instead = f"for the simulated value read {twin!r}, or " if twin else ""
        return [(("kind",), f"a {type_name}'s {kind!r} is a model constant ({spec.field}), not simulation state; "
                 f"{instead}add 'constant: true' to read the constant")]
    if role == STATE and constant:
        return [(("constant",), f"{kind!r} changes with the simulation; 'constant: true' is for model constants: "
                 "remove it")]
    return []


def constant_problem(what: str) -> str:
    """`constant` on a sensor that reads no model field: `what` says what it reads instead."""
    return f"'constant' is for features of model fields; {what} is not one: remove it"


def sensor_problems(cfg: SensorConfig, shape: tuple[int, ...] | None, strip: bool) -> Found:
    """An aggregator needs a buffer axis to reduce (decided by the options alone, whatever the value: a generic
    callable's shape is not known until it is called) and values to reduce (with the value's shape)."""
    if cfg.aggregator is None or cfg.kind in IMAGE_KINDS:
        return []
    buffer = cfg.buffer or 1
    if strip and buffer == 1:
        axis = f"the value's own first axis (shape {shape})" if shape is not None else "the value's own first axis"
        return [(("aggregator",), f"with options.strip_singleton_buffer_dim and a buffer of 1 there is no buffer axis, "
                 f"so {cfg.aggregator!r} would reduce {axis}; remove the aggregator, or use a buffer of 2 or more")]
    if shape is not None and 0 in shape:
        return [(("aggregator",), f"the value has no entries (shape {shape}), so {cfg.aggregator!r} has nothing "
                 "to reduce (min and max raise, mean and median give nan); remove the aggregator or select "
                 "elements that have this value")]
    return []


def _drawn(value: Any) -> bool:
    return isinstance(value, (UniformDraw, ChoiceDraw))


def batch_problems(cfg: SensorConfig, dtype: Any, field: str | None, model: mujoco.MjModel) -> Found:
    """What `BatchEnvironment` cannot run, by key; `field`: the mjData / mjModel field the sensor was bound
    to read (None for MuJoCo sensor kinds, height scans, cameras, callables, and one that did not bind)."""
    found: Found = []
    if cfg.kind in IMAGE_KINDS or cfg.kind == HEIGHTSCAN_KIND:  # sampled per simulation; noise runs per simulation
        for key, present in (("aggregator", cfg.aggregator is not None),
                             ("interval", _drawn(cfg.interval)), ("delay", _drawn(cfg.delay))):
            if present:
                found.append(((key,), per_simulation_refusal(cfg.kind in IMAGE_KINDS, _PER_SIMULATION_WHAT[key])))
        return found
    if cfg.kind == GENERIC_KIND and not cfg.batched:  # (a batched one: binding refuses it off the Warp engine)
        return [(("kind",), batch_refusal("generic"))]
    if cfg.constant and field is not None:  # (`constant` where there is no model field: the binder's problem)
        found.append((("constant",), batch_refusal("constant")))
    elif dtype is not None and np.dtype(dtype) != np.float64:
        found.append((("kind",), batch_refusal("dtype", what=cfg.kind, dtype=str(np.dtype(dtype)))))
    problem = batch_on_demand_problem(model, field) if field else None
    if problem:
        found.append((("kind",), problem))
    for i, stage in enumerate(cfg.noise or ()):
        if stage.type == "custom":
            found.append((("noise", i), batch_refusal("noise stage", kind="custom", detail="")))
    return found


def _names(model: mujoco.MjModel, kind: mujoco.mjtObj, ids: np.ndarray, what: str) -> str:
    """'light 'sun'' or 'lights 'a', 'b', 'c' and 2 more'."""
    names = [mujoco.mj_id2name(model, kind, int(i)) or f"#{int(i)}" for i in ids]
    listed = ", ".join(repr(n) for n in names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
    return f"{what}{'s' if len(names) > 1 else ''} {listed}"


def render_cost(model: mujoco.MjModel, scene: Mapping[str, bool]) -> str | None:
    """What a camera with these scene flags renders on `model` that can cost most of a frame (MuJoCo's
    default look, kept unless switched off): shadows of its lights that cast them, reflections of its
    reflective materials. A note, not a problem: the image is MuJoCo's (and dm_control's) by default."""
    found: list[tuple[str, str]] = []
    if scene.get("shadow", True):
        lights = np.flatnonzero(model.light_castshadow & model.light_active)
        if lights.size:
            found.append(("shadow", f"shadows (of {_names(model, mujoco.mjtObj.mjOBJ_LIGHT, lights, 'light')})"))
    if scene.get("reflection", True):
        used = np.unique(model.geom_matid[model.geom_matid >= 0])
        shiny = used[model.mat_reflectance[used] > 0]
        if shiny.size:
            found.append(("reflection",
                          f"reflections (in {_names(model, mujoco.mjtObj.mjOBJ_MATERIAL, shiny, 'material')})"))
    if not found:
        return None
    off = ", ".join(f"{flag}: false" for flag, _ in found)
    return (f"this camera renders {' and '.join(what for _, what in found)}, MuJoCo's default look, which can make a "
            "frame many times slower (Menagerie ALOHA's overhead camera at 640x480: 3.2 s against 0.27 s without "
            f"them, software EGL); camera: {{scene: {{{off}}}}} turns them off, for a different image")
