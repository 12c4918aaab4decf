"""Binding a suite's observables for an engine that runs many simulations: one bound record per enabled
observable (`plan.bound.bind_sensor`, as the Updater binds them), checked for what such an engine cannot run,
and sorted into fixed-schedule features, drawn-schedule features and per-simulation sensors (cameras, height
scans)."""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import TYPE_CHECKING, NamedTuple, cast

import numpy as np

from ..refusals import batch_refusal, per_simulation_refusal
from ..draws import DEFAULT_DELAY, DEFAULT_UPDATE_INTERVAL, ChoiceSteps, UniformSteps
from ..errors import SuiteError
from ..observables.aggregators import AGGREGATORS
from ..observables.feature import batch_on_demand_problem
from .bound import Entry, Plain, bind_sensor, plain_refusal
from .compile import compile_plan
from .drawn import Drawn
from .records import Source, SuitePlan
from .schedule import Schedule

if TYPE_CHECKING:
    from ..observables.base import Observable
    from ..physics import Physics

__all__ = ["Bound", "Entry", "bind", "check_per_simulation", "check_plain", "per_simulation", "plan_suite"]


class Bound(NamedTuple):
    """Every enabled observable in the suite's order (`entries`), and the same sorted by how it runs."""

    entries: list[Entry]
    cameras: list[Entry]  # per simulation: cameras and height scans
    fixed: list[Entry]
    drawn: list[Entry]

    def sources(self) -> list[Source]:
        """Where each feature's values are (fixed-schedule ones first, then drawn ones)."""
        return [e.source for e in (*self.fixed, *self.drawn)]


def _largest(label: str, attr: str, value: object, default: int) -> int:
    """The largest value an interval or delay setting can take (drawn ones must say, to size the history)."""
    if not value:
        return default
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, UniformSteps):
        return int(value.high)
    if isinstance(value, ChoiceSteps):
        return int(max(value.values))
    raise SuiteError(f"sensor {label!r}: its {attr} is a callable ({value!r}) that cannot be vectorised across "
                     "simulations: the batch must know its largest value; use {uniform: [lo, hi]} or "
                     "{choice: [...]}")


def _check_drawn(entry: Entry) -> None:
    """A drawn schedule must say its largest values and follow the planned stream rule (`Drawn`)."""
    _largest(entry.name, "update_interval", entry.observable.update_interval, DEFAULT_UPDATE_INTERVAL)
    _largest(entry.name, "delay", entry.observable.delay, DEFAULT_DELAY)
    if not isinstance(entry.schedule, Drawn):
        raise SuiteError(f"sensor {entry.name!r}: its drawn interval or delay can give values below the least "
                         "allowed (interval 1, delay 0 steps)")


def per_simulation(obs: Observable) -> bool:
    """Observables that need a simulation's whole MjData (cameras, height scans): run per simulation."""
    return hasattr(obs, "camera_id") or getattr(obs, "per_simulation", False)


def check_plain(name: str, obs: Observable, ch: Plain) -> None:
    """A feature must be a plain float64 mjData feature with a built-in aggregator (or none)."""
    if getattr(obs, "corruptor", None) is not None:
        raise SuiteError(f"sensor {name!r}: {batch_refusal('corruptor')}")
    rule = plain_refusal(ch)
    if rule in ("constant", "generic"):
        raise SuiteError(f"sensor {name!r} ({type(obs).__name__}): {batch_refusal(cast(str, rule))}")
    if rule == "dtype":
        raise SuiteError(f"sensor {name!r}: {batch_refusal('dtype', what=type(obs).__name__, dtype=str(ch.dtype))}")
    if rule == "aggregator":
        raise SuiteError(f"sensor {name!r}: its aggregator cannot be vectorised across simulations: use one of "
                         f"{', '.join(AGGREGATORS)} on a buffer (a custom callable would run per simulation)")


def check_per_simulation(entry: Entry) -> None:
    """Cameras and height scans run per simulation: no corruptor, aggregator or drawn schedule."""
    name, obs = entry.name, entry.observable
    what = ("a corruptor" if getattr(obs, "corruptor", None) is not None
            else "an aggregator" if entry.aggregator is not None
            else "a drawn interval or delay" if not isinstance(entry.schedule, Schedule) else None)
    if what:
        camera = hasattr(obs, "camera_id")
        raise SuiteError(f"{'camera' if camera else 'height scan'} {name!r}: {per_simulation_refusal(camera, what)}")


def bind(observables: Mapping[str, Observable], physics: Physics, substeps: int, strip: bool) -> Bound:
    """Each enabled observable bound to `physics` (a single-simulation physics of the model), as the
    single-simulation Updater binds them; each simulation's episode later draws its own schedules and noise.
    Raises SuiteError for what a batch cannot run (a field MuJoCo computes on demand cannot be computed between
    physics steps unless the model's sensors compute it)."""
    random_state = np.random.RandomState(0)
    entries = [bind_sensor(name, obs, physics, random_state, None, substeps, strip)
               for name, obs in observables.items() if obs.enabled]
    model = physics.model if not hasattr(physics.model, "ptr") else physics.model.ptr
    cameras = [e for e in entries if per_simulation(e.observable)]
    features = [e for e in entries if not per_simulation(e.observable)]
    for entry in cameras:
        check_per_simulation(entry)
    for entry in features:
        check_plain(entry.name, entry.observable, entry)
        problem = batch_on_demand_problem(model, entry.source.field)
        if problem:
            raise SuiteError(f"sensor {entry.name!r}: {problem}")
    drawn = [e for e in features if not isinstance(e.schedule, Schedule)]
    for entry in drawn:
        _check_drawn(entry)
    return Bound(entries, cameras, [e for e in features if isinstance(e.schedule, Schedule)], drawn)


def _fields(physics: Physics, sources: list[Source]) -> dict[str, tuple[int, ...]]:
    """The mjData fields the sources read, in order of first use, with their shapes."""
    data = physics.data if not hasattr(physics.data, "ptr") else physics.data.ptr
    fields: dict[str, tuple[int, ...]] = {}
    for source in sources:
        fields.setdefault(source.field, tuple(getattr(data, source.field).shape))
    return fields


def plan_suite(bound: Bound, physics: Physics, sources: list[Source], nsim: int, substeps: int, pad: bool) -> SuitePlan:
    """The suite plan of bound features reading `sources` (`bound.sources()`, or relayed ones)."""
    model = physics.model if not hasattr(physics.model, "ptr") else physics.model.ptr
    return compile_plan(bound.fixed, bound.drawn, sources, _fields(physics, sources), nsim, substeps,
                        float(model.opt.timestep), pad)
