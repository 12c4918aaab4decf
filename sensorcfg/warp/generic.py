"""Batched generic sensors on the Warp engine: a callable that takes every world at once (`batched: true`).

The contract (docs/warp.md, `SensorConfig.batched`): `f(model, data)` is called with MuJoCo Warp's `Model`
and `Data` of all worlds after every physics step (and after a restart's forward, for the reset sample) and
returns an (nworld, ...) float32 Warp array on the engine's device (float32 vectors and matrices count as
their components), the same array each call or a new one. It runs inside the control step's CUDA graph: device
work only (Warp kernels; no copy to the host, no Python branching on values).

- At build (`Generics`), each callable is called once on the worlds as built: its value's shape is what it
  returns without the world axis. What is not an array of that contract is a SuiteError at the sensor's
  line (its `callable`), naming what it returned. Its noise is built for that shape (problems at the suite's
  lines) and checked as the engine checks every sensor's (`support.refusals`).
- In the suite plan it is a feature whose source is its own values (`generic_field(name)`: an (nworld,
  values) float32 array this module fills, `values`), so schedules, delays, buffers, aggregators, noise and
  reads treat it as they treat an mjData field.
- `run()` after each physics step: every callable is called and what it returns is copied into its values
  (one device copy; its type, dtype and shape are checked on the host, which reads no device memory).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np
import warp as wp

from ..errors import Problem, SuiteError
from ..noise import build_noise
from ..noise.level import leveled
from ..observables.generic import BatchedGeneric, OwnValues
from ..plan.bind import Bound, _check_drawn
from ..plan.bound import bind_sensor
from ..plan.schedule import Schedule
from .support import refusals
from .worlds import Worlds

__all__ = ["Generics", "generic_field", "split"]


def generic_field(name: str) -> str:
    """The plan's source field of batched generic sensor `name`: its own values (no mjData field has a colon)."""
    return f"generic:{name}"


def split(observables: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, BatchedGeneric]]:
    """The observables other than the batched generic ones, and the enabled batched generic ones."""
    others = {n: o for n, o in observables.items() if not isinstance(o, BatchedGeneric)}
    return others, {n: o for n, o in observables.items() if isinstance(o, BatchedGeneric) and o.enabled}


def _problem(name: str, observable: BatchedGeneric, key: tuple[str | int, ...], message: str) -> Problem:
    """A problem at a key below the sensor's entry: at the suite's line, or by its path for Python."""
    if observable.locate is not None:
        return observable.locate(key, message)
    return Problem(message, ".".join(map(str, ("sensors", name, *key))))


def _what(value: Any) -> str:
    """What a callable returned, in words."""
    if isinstance(value, np.ndarray):
        return f"a numpy array {value.shape} {value.dtype} (host memory)"
    kind = type(value)
    text = repr(value)
    return f"{kind.__module__}.{kind.__qualname__} {text if len(text) <= 40 else text[:37] + '...'}"


def _contract_problem(value: Any, nworld: int, device: wp.Device) -> str | None:
    """Why `value` is not what a batched callable returns, or None."""
    wanted = (f"a batched callable returns an ({nworld}, ...) float32 Warp array on the engine's device "
              f"({device}), filled by Warp kernels")
    if not isinstance(value, wp.array):
        return f"returned {_what(value)}; {wanted}"
    scalar = getattr(value.dtype, "_wp_scalar_type_", value.dtype)
    if scalar != wp.float32:
        return f"returned a Warp array of {wp.types.type_repr(value.dtype)} values; {wanted} (convert in its kernel)"
    if value.device != device:
        return f"returned a Warp array on {value.device}; {wanted}"
    shape = tuple(value.shape)
    if shape[0] != nworld:
        return f"returned a Warp array of shape {shape}, whose first axis is not the {nworld} worlds; {wanted}"
    if math.prod(_value_shape(value)) == 0:
        return f"returned a Warp array of shape {shape}: no values per world; {wanted}"
    return None


def _value_shape(value: wp.array) -> tuple[int, ...]:
    """One world's value's shape: the array's axes after the first, then its vector's or matrix's."""
    return (*value.shape[1:], *getattr(value.dtype, "_shape_", ()))


class _Sensor:
    """One batched generic sensor: its callable, and its values (a copy of what the callable returned, and
    a flat (nworld, values) float32 view of them)."""

    def __init__(self, name: str, observable: BatchedGeneric, first: wp.array, nworld: int):
        self.name, self.observable = name, observable
        self.shape, self.dtype = tuple(first.shape), first.dtype
        self.values = wp.empty(self.shape, dtype=first.dtype, device=first.device)
        self.size = math.prod(_value_shape(first))
        self.flat = wp.array(ptr=self.values.ptr, dtype=wp.float32, shape=(nworld, self.size), device=first.device,
                             copy=False)


class Generics:
    """The batched generic sensors of `observables` (enabled `BatchedGeneric`s, by name) over `worlds`: each
    called once (its value's shape, checked), its noise built for that shape (`model`'s timestep)."""

    def __init__(self, observables: Mapping[str, BatchedGeneric], worlds: Worlds, model: mujoco.MjModel):
        self._worlds = worlds
        self._nworld, self._device = worlds.nworld, worlds.device
        self._sensors: list[_Sensor] = []
        problems: list[Problem] = []
        for name, observable in observables.items():
            first = self._call(name, observable)
            problem = _contract_problem(first, self._nworld, self._device)
            if problem:
                raise observable.error(problem, name)
            self._sensors.append(_Sensor(name, observable, first, self._nworld))
            observable.shape = _value_shape(first)
            problems += self._noise(name, observable, model)
        if problems:
            raise SuiteError(problems)
        self.values = {generic_field(s.name): s.flat for s in self._sensors}  # plan field -> (nworld, values)
        self.sizes = {generic_field(s.name): s.size for s in self._sensors}

    def _call(self, name: str, observable: BatchedGeneric) -> Any:
        try:
            with wp.ScopedDevice(self._device):
                return observable.fn(self._worlds.model, self._worlds.data)
        except Exception as e:  # noqa: BLE001 - user code: its failure is the user's to see, at the sensor
            raise observable.error(f"calling it with MuJoCo Warp's Model and Data raised {type(e).__name__}: "
                                   f"{e}", name) from e

    @staticmethod
    def _noise(name: str, observable: BatchedGeneric, model: mujoco.MjModel) -> list[Problem]:
        """Its noise, built for its value's shape and checked as every sensor's; problems at their keys."""
        if not observable.noise_stages:
            return []
        assert observable.shape is not None
        try:
            observable.noise = build_noise(observable.noise_stages, observable.shape, np.float64,
                                           float(model.opt.timestep))
        except SuiteError as e:  # at `noise.<i>.<field>`
            return [_problem(name, observable, tuple(int(s) if s.isdigit() else s for s in p.loc.split(".") if s),
                             p.message) for p in e.problems]
        leveled({name: observable})
        return [_problem(name, observable, key, message) for key, message in refusals(observable, None, model)]

    def bind(self, bound: Bound, order: Sequence[str], substeps: int, strip: bool) -> Bound:
        """`bound` with these sensors added as features of their own values (in `order`, the suite's)."""
        mine = []
        for sensor in self._sensors:
            own = OwnValues(generic_field(sensor.name), sensor.size)
            entry = bind_sensor(sensor.name, sensor.observable, own, np.random.RandomState(0), None, substeps, strip)
            if entry.aggregator is not None and not (entry.builtin_aggregator and entry.has_buffer_dim):
                raise SuiteError(f"sensor {sensor.name!r}: its aggregator cannot be vectorised across worlds: use "
                                 "one of min, max, sum, mean, median on a buffer")
            if not isinstance(entry.schedule, Schedule):
                _check_drawn(entry)
            mine.append(entry)
        if not mine:
            return bound
        rank = {name: i for i, name in enumerate(order)}
        entries = sorted([*bound.entries, *mine], key=lambda e: rank[e.name])
        return bound._replace(entries=entries,
                              fixed=[*bound.fixed, *(e for e in mine if isinstance(e.schedule, Schedule))],
                              drawn=[*bound.drawn, *(e for e in mine if not isinstance(e.schedule, Schedule))])

    def run(self) -> None:
        """After a physics step (or a restart's forward): each callable's values into its own array."""
        model, data = self._worlds.model, self._worlds.data
        for sensor in self._sensors:
            with wp.ScopedDevice(self._device):
                value = sensor.observable.fn(model, data)
            if not isinstance(value, wp.array) or tuple(value.shape) != sensor.shape or value.dtype != sensor.dtype \
                    or value.device != self._device:
                problem = _contract_problem(value, self._nworld, self._device) or (
                    f"returned a Warp array of shape {tuple(value.shape)} {wp.types.type_repr(value.dtype)}, but "
                    f"its first had shape {sensor.shape} {wp.types.type_repr(sensor.dtype)}; a sensor's value "
                    "keeps one shape")
                raise sensor.observable.error(problem, sensor.name)
            wp.copy(sensor.values, value)
