"""An observable defined by any `callable(physics)`.

Its values are checked as they come, since nothing else knows what the callable returns: each must be an
array of numbers (bool, integer or float) with the shape of the observable's first value (whichever
episode or binding took it: an environment's spec comes from that value), and a dtype that value's dtype
holds without loss (an integer sensor may not start returning fractions). A
value that breaks this is a SuiteError naming the sensor (at its suite line when built from a suite),
rather than a numpy error deep inside a buffer.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import Problem, SuiteError
from .base import Observable

__all__ = ["Generic"]

_NUMERIC_KINDS = "biuf"  # bool, signed and unsigned integers, floats


class Generic(Observable):
    """Wraps `raw_observation_callable(physics) -> value`.

    `origin` says where errors about its values are reported: a `Problem` (its file, line, column and
    location are used) for a sensor built from a suite; None names the callable instead.
    """

    def __init__(self, raw_observation_callable: Callable[[Any], Any], update_interval: Any = 1,
                 buffer_size: int | None = None, delay: Any = None, aggregator: Any = None,
                 corruptor: Callable[..., Any] | None = None, *, origin: Problem | None = None):
        if not callable(raw_observation_callable):
            raise TypeError(f"Generic needs a callable, got {type(raw_observation_callable).__name__}")
        self._raw_callable = raw_observation_callable
        self._origin = origin
        self._first: list[np.ndarray] = []  # the first value ever: the shape and dtype every value keeps
        super().__init__(update_interval, buffer_size, delay, aggregator, corruptor)

    def __repr__(self) -> str:
        return f"Generic({getattr(self._raw_callable, '__qualname__', self._raw_callable)!r})"

    def _error(self, message: str) -> SuiteError:
        origin = self._origin
        if origin is None:
            return SuiteError(f"{self!r}: {message}")
        name = origin.loc.split(".")[1] if origin.loc.count(".") >= 1 else origin.loc
        return SuiteError(dataclasses.replace(origin, message=f"generic sensor {name!r}: {message}"))

    def _callable(self, physics: Any) -> Callable[[], Any]:
        raw = self._raw_callable
        first = self._first

        def sample() -> np.ndarray:
            value = raw(physics)
            try:
                array = np.asarray(value)
            except (TypeError, ValueError) as e:
                raise self._error(f"returned {_short(value)}, which is not an array of numbers ({e})") from None
            if array.dtype.kind not in _NUMERIC_KINDS:
                raise self._error(f"returned {_short(value)} ({array.dtype} values); a sensor returns numbers "
                                  "(a float, an int, a bool, or an array of them)")
            if not first:
                first.append(array)
            elif array.shape != first[0].shape:
                raise self._error(f"returned shape {array.shape}, but its first value had shape "
                                  f"{first[0].shape}; a sensor's value keeps one shape")
            elif not np.can_cast(array.dtype, first[0].dtype, casting="same_kind"):
                raise self._error(f"returned {array.dtype} values, but its first value was {first[0].dtype}, "
                                  f"which cannot hold them; return {array.dtype} from the first value on")
            return array

        return sample


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
