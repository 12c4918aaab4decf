"""The observable base class: what to sample, and how the Updater should schedule it.

It has dm_control's observable interface (`update_interval`, `buffer_size`, `delay`, `aggregator`,
`corruptor`, `enabled`, `array_spec`, `observation_callable`, `__call__`, `configure`), so the Updater
accepts dm_control observables and dm_control accepts ours. Two additions: settings are validated when
set (a mistake fails at configuration time, not deep inside a step), and `noise`, a sensorcfg noise
pipeline that the Updater seeds per sensor and applies to each sample.
"""

from __future__ import annotations

import abc
import numbers
from collections.abc import Callable
from typing import Any, cast

import numpy as np
from dm_env import specs

from ..errors import SuiteError
from .aggregators import get_aggregator

__all__ = ["Observable", "check_setting"]

Schedule = int | Callable[..., int]


def check_setting(attr: str, value: Any, owner: str) -> Any:
    """Validate interval / delay / buffer values; callables are drawn per sample and checked then."""
    if value is None or (callable(value) and attr != "buffer_size"):
        return value
    lowest = 0 if attr == "delay" else 1
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool) and cast(int, value) >= lowest
    if not ok:
        what = {"update_interval": "a positive integer number of physics steps (or a callable drawing one)",
                "delay": "a non-negative integer number of physics steps (or a callable drawing one)",
                "buffer_size": "a positive integer"}[attr]
        raise SuiteError(f"{owner}: {attr} must be {what}, got {value!r}")
    return int(value)


class Observable(metaclass=abc.ABCMeta):
    """Abstract observable; subclasses implement `_callable(physics) -> () -> value`."""

    def __init__(self, update_interval: Schedule | None = 1, buffer_size: int | None = None,
                 delay: Schedule | None = None, aggregator: Any = None,
                 corruptor: Callable[..., Any] | None = None):
        """The schedule settings every observable has (dm_control's), checked now.

        Args:
            update_interval: Physics steps between samples (a positive integer), or a callable drawing one
                per sample (as dm_control's).
            buffer_size: Samples each observation holds (a positive integer); None: 1.
            delay: Physics steps between a sample and the first read that shows it (a non-negative integer),
                or a callable drawing one per sample; None: 0.
            aggregator: A reduction of the buffer axis: a name of `AGGREGATORS` ("mean", "max", ...), any
                callable, or None.
            corruptor: dm_control's `corruptor(value, random_state=...) -> value`, applied to each sample;
                None: none.

        Raises:
            SuiteError: A setting that is not one of the above (an interval of 0, an unknown aggregator).
        """
        self._update_interval = check_setting("update_interval", update_interval, repr(self))
        self._buffer_size = check_setting("buffer_size", buffer_size, repr(self))
        self._delay = check_setting("delay", delay, repr(self))
        self._aggregator = get_aggregator(aggregator, repr(self))
        self._corruptor = corruptor
        self._enabled = False
        self._noise: Any = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    @property
    def update_interval(self) -> Schedule | None:
        return self._update_interval

    @update_interval.setter
    def update_interval(self, value: Schedule | None) -> None:
        self._update_interval = check_setting("update_interval", value, repr(self))

    @property
    def buffer_size(self) -> int | None:
        return self._buffer_size

    @buffer_size.setter
    def buffer_size(self, value: int | None) -> None:
        self._buffer_size = check_setting("buffer_size", value, repr(self))

    @property
    def delay(self) -> Schedule | None:
        return self._delay

    @delay.setter
    def delay(self, value: Schedule | None) -> None:
        self._delay = check_setting("delay", value, repr(self))

    @property
    def aggregator(self) -> Callable[[np.ndarray], Any] | None:
        return self._aggregator

    @aggregator.setter
    def aggregator(self, value: Any) -> None:
        self._aggregator = get_aggregator(value, repr(self))

    @property
    def corruptor(self) -> Callable[..., Any] | None:
        return self._corruptor

    @corruptor.setter
    def corruptor(self, value: Callable[..., Any] | None) -> None:
        self._corruptor = value

    @property
    def enabled(self) -> bool:
        return self._enabled

    @enabled.setter
    def enabled(self, value: bool) -> None:
        self._enabled = bool(value)

    @property
    def noise(self) -> Any:
        """A sensorcfg noise pipeline (`reset(rng)`, `__call__(value, step)`), or None."""
        return self._noise

    @noise.setter
    def noise(self, value: Any) -> None:
        self._noise = value

    @property
    def array_spec(self) -> specs.Array | None:
        """Shape and dtype of one sample, or None to let the Updater infer it from a sample."""
        return None

    @abc.abstractmethod
    def _callable(self, physics: Any) -> Callable[[], Any]:
        """A zero-argument callable returning one raw sample from `physics`."""

    def observation_callable(self, physics: Any, random_state: Any = None) -> Callable[[], Any]:
        """A zero-argument callable returning one (possibly corrupted) sample."""
        raw = self._callable(physics)
        corruptor = self._corruptor
        if corruptor is None:
            return raw
        return lambda: corruptor(raw(), random_state=random_state)

    def __call__(self, physics: Any, random_state: Any = None) -> Any:
        return self.observation_callable(physics, random_state)()

    def configure(self, **kwargs: Any) -> None:
        """Set several attributes at once; unknown names raise AttributeError."""
        for key, value in kwargs.items():
            if not hasattr(self, key):
                raise AttributeError(f"{type(self).__name__} has no attribute {key!r} to configure")
            setattr(self, key, value)
