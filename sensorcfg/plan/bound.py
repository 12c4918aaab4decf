"""One enabled observable bound to a model: what every engine needs of it, decided once (`bind_sensor`).

Binding gives the observable's sampler (a feature reader: the mjData `field` and `positions` it reads), its
shape and dtype, how a read lays out its buffer (`strip_singleton_buffer_dim`), its aggregator, its noise
pipeline (keyed for the episode) and its timing as the plan's schedule objects: a fixed `Schedule`, a `Drawn`
schedule (sensorcfg's own draws, `draws.planned`), or None for intervals and delays drawn by other callables
(dm_control's planning: the single-simulation Updater's `RandomChannel`). The plan compiles from these
records (`plan/compile.py`); the Updater builds its channels from them (`runtime/channels.make_channel`).

Which bound observables are plain features (read together by a bank, a batch or the Warp engine) is decided
here too: `plain_refusal`.
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple, Protocol, cast

import numpy as np
import numpy.typing as npt

from ..draws import DEFAULT_BUFFER_SIZE, DEFAULT_DELAY, DEFAULT_UPDATE_INTERVAL, drawer, planned, sensor_key
from ..errors import SuiteError
from ..observables.aggregators import builtin
from .drawn import Drawn, drawn_of
from .records import Source
from .schedule import Schedule

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline
    from ..observables.base import Observable
    from ..observables.generic import OwnValues
    from ..physics import Physics

    DType = np.dtype[np.generic[object]]
    Values = npt.NDArray[np.generic[object]]  # a sample, or a read's window of them

__all__ = ["Entry", "FieldReader", "Plain", "aggregator_name", "bind_sensor", "buffered_shape", "every_sample",
           "field_reader", "plain_refusal"]

Sampler = Callable[[], object]
Aggregator = Callable[["Values"], object]
Timing = Schedule | Drawn | None  # None: drawn by other callables, dm_control's planning (`RandomChannel`)


class FieldReader(Protocol):
    """The sampler of a plain feature: a feature reader of values `index` of one mjData `field`."""

    field: str
    index: npt.NDArray[np.intp]

    def __call__(self) -> npt.NDArray[np.float64]: ...


def field_reader(sampler: Sampler) -> FieldReader:
    """A plain feature's sampler as its field reader (`plain_refusal` made sure it is one)."""
    return cast(FieldReader, sampler)


def every_sample(noise: object) -> bool:
    """Stateful noise (low-pass, dropout holding, a custom callable) sees every sample of the schedule."""
    return noise is not None and bool(getattr(noise, "stateful", False))


def has_buffer_dim(buffer: int, strip: bool) -> bool:
    """Whether a read keeps its buffer axis: always, but for a buffer of 1 with `strip_singleton_buffer_dim`."""
    return not (strip and buffer == 1)


def buffered_shape(shape: tuple[int, ...], buffer: int, strip: bool) -> tuple[int, ...]:
    """A read's shape before any aggregator: (buffer, *shape), or shape when the buffer axis is stripped."""
    return ((buffer,) if has_buffer_dim(buffer, strip) else ()) + tuple(shape)


def aggregator_name(aggregator: object) -> str | None:
    """A plain feature's aggregator's name (None: none): a built-in, as `plain_refusal` made sure."""
    if aggregator is None:
        return None
    found = builtin(aggregator)
    if found is None:
        raise ValueError(f"{aggregator!r} is not a built-in aggregator: it cannot reduce a bank's read")
    return found.name


class Plain(Protocol):
    """What `plain_refusal` reads of a bound observable (an `Entry`) or of a channel built from one."""

    @property
    def sampler(self) -> Sampler: ...
    @property
    def dtype(self) -> DType: ...
    @property
    def aggregator(self) -> Aggregator | None: ...
    @property
    def builtin_aggregator(self) -> bool: ...
    @property
    def has_buffer_dim(self) -> bool: ...


def plain_refusal(sensor: Plain) -> str | None:
    """Why a bound observable cannot be read as a plain feature (its values gathered from mjData, reduced by a
    built-in aggregator on a buffer or not at all), as a rule's key: "constant" (an mjModel field), "generic"
    (not a feature reader), "dtype" (not float64), "aggregator" (a custom one, or none of a buffer); None when
    it can. The one membership rule of the feature banks (`runtime/bank.bank_member`), the batch and the Warp
    engine (`plan.bind.check_plain`)."""
    sampler = sensor.sampler
    struct = getattr(sampler, "struct", None)
    if struct != "data" or not hasattr(sampler, "index"):
        return "constant" if struct == "model" else "generic"
    if sensor.dtype != np.float64:
        return "dtype"
    if sensor.aggregator is not None and not (sensor.builtin_aggregator and sensor.has_buffer_dim
                                              and builtin(sensor.aggregator) is not None):
        return "aggregator"
    return None


class Entry(NamedTuple):
    """An enabled observable bound to a model (`bind_sensor`)."""

    name: str
    observable: Observable
    sampler: Sampler  # a feature's: its `FieldReader`
    shape: tuple[int, ...]
    dtype: DType
    buffer_size: int
    has_buffer_dim: bool
    aggregator: Aggregator | None  # the observable's
    builtin_aggregator: bool
    noise: NoisePipeline | None  # reset for the episode keyed by `key`
    schedule: Timing
    interval: int | Callable[[], int]  # as `draws.drawer` gives them: a constant, or a validated draw
    delay: int | Callable[[], int]
    key: npt.NDArray[np.uint64]  # the sensor's episode key (`draws.sensor_key`): its noise streams and drawn schedule

    @property
    def buffered_shape(self) -> tuple[int, ...]:
        """A read's shape before any aggregator."""
        return buffered_shape(self.shape, self.buffer_size, not self.has_buffer_dim)

    @property
    def every_sample(self) -> bool:
        return every_sample(self.noise)

    @property
    def aggregator_name(self) -> str | None:
        """The built-in aggregator's name of a plain feature (None: none)."""
        return aggregator_name(self.aggregator)

    @property
    def source(self) -> Source:
        """Where a plain feature's values are: its reader's field and positions."""
        reader = field_reader(self.sampler)
        return Source(reader.field, reader.index)


def bind_sensor(label: str, observable: Observable, physics: Physics | OwnValues,
                random_state: np.random.RandomState | None, entropy: list[int] | None, substeps: int,
                strip: bool) -> Entry:
    """Bind `observable` to `physics` (or to the values of its own a batched generic sensor reads,
    `observables.generic.OwnValues`) for an episode: the one way every engine binds an observable. `entropy`
    keys the sensor's noise streams and drawn schedule (`draws.sensor_key`); `random_state` is the episode's,
    given to the observable and to schedule callables that take it."""
    try:
        sampler = observable.observation_callable(physics, random_state)
    except SuiteError as e:  # binding to the model (unknown element, camera, ...): say which observable
        raise SuiteError([p if p.loc else dataclasses.replace(p, message=f"observable {label!r}: {p.message}")
                          for p in e.problems]) from None
    interval = drawer(label, "update_interval", observable.update_interval, DEFAULT_UPDATE_INTERVAL, random_state)
    delay = drawer(label, "delay", observable.delay, DEFAULT_DELAY, random_state)
    buffer_size = observable.buffer_size or DEFAULT_BUFFER_SIZE
    if not isinstance(buffer_size, numbers.Integral) or isinstance(buffer_size, bool) or buffer_size < 1:
        raise SuiteError(f"observable {label!r}: buffer_size must be a positive integer, got {buffer_size!r}")
    spec = observable.array_spec
    if spec is None:  # infer shape and dtype from one sample, as dm_control does
        probe = np.asarray(sampler())
        shape, dtype = probe.shape, probe.dtype
    else:
        shape, dtype = spec.shape, spec.dtype
    noise = getattr(observable, "noise", None)
    key = sensor_key(entropy or [], label)  # its noise streams and planned schedule
    if noise is not None:  # sample j of a constant interval is the j-th nominal sample
        noise.reset(key, 1 if callable(interval) else interval)
    aggregator = observable.aggregator
    buffer = int(buffer_size)
    stateful = every_sample(noise)
    timing: Timing
    if planned(observable.update_interval, observable.delay):  # the stream rule (`plan/drawn.py`)
        timing = drawn_of(observable.update_interval, observable.delay, buffer, substeps, stateful)
    elif callable(interval) or callable(delay):
        timing = None
    else:
        timing = Schedule(interval, delay, buffer, substeps, stateful)
    return Entry(label, observable, sampler, tuple(shape), np.dtype(dtype), buffer, has_buffer_dim(buffer, strip),
                 aggregator, builtin(aggregator) is not None, noise, timing, interval, delay, key)
