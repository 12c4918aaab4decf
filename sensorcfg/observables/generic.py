"""An observable defined by any `callable(physics)`; and `BatchedGeneric`, one whose callable takes every
world of the Warp engine at once.

Its values are checked as they come, since nothing else knows what the callable returns: each must be an
array of numbers (bool, integer or float) with the shape of the observable's first value (whichever
episode or binding took it: an environment's spec comes from that value), and a dtype that value's dtype
holds without loss (an integer sensor may not start returning fractions). A
value that breaks this is a SuiteError naming the sensor (at its suite line when built from a suite),
rather than a numpy error deep inside a buffer.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from ..errors import Problem, SuiteError
from ..refusals import batch_refusal
from .base import Observable

__all__ = ["BatchedGeneric", "Generic"]

_NUMERIC_KINDS = "biuf"  # bool, signed and unsigned integers, floats


class Generic(Observable):
    """Wraps `raw_observation_callable(physics) -> value`.

    `origin` says where errors about its values are reported: a `Problem` (its file, line, column and
    location are used) for a sensor built from a suite; None names the callable instead.
    """

    def __init__(self, raw_observation_callable: Callable[[Any], Any], update_interval: Any = 1,
                 buffer_size: int | None = None, delay: Any = None, aggregator: Any = None,
                 corruptor: Callable[..., Any] | None = None, *, origin: Problem | None = None):
        """Wrap the callable; its first value fixes the shape and dtype every later value keeps.

        Args:
            raw_observation_callable: `fn(physics) -> value`, a number or an array of numbers.
            update_interval, buffer_size, delay, aggregator, corruptor: The schedule settings of every
                observable (`Observable`).
            origin: Where problems of its values are reported (the suite line of a sensor built from a
                suite); None: they name the callable.

        Raises:
            TypeError: `raw_observation_callable` is not callable.
            SuiteError: A setting that is not one an observable takes.
        """
        if not callable(raw_observation_callable):
            raise TypeError(f"Generic needs a callable, got {type(raw_observation_callable).__name__}")
        self._raw_callable = raw_observation_callable
        self._origin = origin
        self._first: list[np.ndarray] = []  # the first value ever: the shape and dtype every value keeps
        super().__init__(update_interval, buffer_size, delay, aggregator, corruptor)

    def __repr__(self) -> str:
        return f"Generic({getattr(self._raw_callable, '__qualname__', self._raw_callable)!r})"

    def _error(self, message: str) -> SuiteError:
        return _error(self._origin, repr(self), message)

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


def _error(origin: Problem | None, label: str, message: str) -> SuiteError:
    """A problem of a generic sensor's values: at its suite line (`origin`), else naming it by `label`."""
    if origin is None:
        return SuiteError(f"{label}: {message}")
    name = origin.loc.split(".")[1] if origin.loc.count(".") >= 1 else origin.loc
    return SuiteError(dataclasses.replace(origin, message=f"generic sensor {name!r}: {message}"))


class OwnValues(NamedTuple):
    """What a `BatchedGeneric` is bound to on the Warp engine: the plan field of its own values (`field`, an
    (nworld, `size`) float32 array the engine fills from its callable: `sensorcfg.warp.generic`)."""

    field: str
    size: int


class _OwnReader:
    """A channel's sampler that names where its values are (the plan's source: `field`, positions `index`),
    as a feature's reader does; the engine computes them, so it is never called."""

    __slots__ = ("field", "index")

    def __init__(self, own: OwnValues):
        self.field, self.index = own.field, np.arange(own.size)

    def __call__(self) -> Any:
        raise RuntimeError(f"{self.field} is computed by the Warp engine, not sampled")


class BatchedGeneric(Observable):
    """A generic sensor whose callable takes every world at once (`batched: true`): `fn(model, data)` with
    MuJoCo Warp's `Model` and `Data` of all worlds, returning an (nworld, ...) float32 Warp array on the
    engine's device (docs/warp.md). Only the Warp engine runs it (`sensorcfg.warp.generic` calls it, finds its
    value's shape by one call and builds `noise_stages` for that shape); the CPU engines refuse it at its
    origin when they bind it.

    `noise_stages`: noise stage configs (as `build_noise` takes them) for its values; `origin` the suite
    line errors about its values are reported at (the callable's; None names the callable); `locate(key,
    message)` the problem at a key below the sensor's entry (`noise.0.std`), for a suite."""

    batched = True

    def __init__(self, fn: Callable[[Any, Any], Any], update_interval: Any = 1, buffer_size: int | None = None,
                 delay: Any = None, aggregator: Any = None, *, noise_stages: Sequence[Any] = (),
                 origin: Problem | None = None, locate: Callable[[tuple[str | int, ...], str], Problem] | None = None):
        if not callable(fn):
            raise TypeError(f"BatchedGeneric needs a callable, got {type(fn).__name__}")
        self.fn, self.noise_stages, self.origin, self.locate = fn, tuple(noise_stages), origin, locate
        self.shape: tuple[int, ...] | None = None  # its value's, once the Warp engine has called it
        super().__init__(update_interval, buffer_size, delay, aggregator)

    def __repr__(self) -> str:
        return f"BatchedGeneric({getattr(self.fn, '__qualname__', self.fn)!r})"

    @property
    def array_spec(self) -> Any:
        from dm_env import specs

        return None if self.shape is None else specs.Array(self.shape, np.float64)

    def error(self, message: str, name: str | None = None) -> SuiteError:
        """A problem of its callable or values, at its origin (else naming it as sensor `name`)."""
        return _error(self.origin, repr(self) if name is None else f"generic sensor {name!r}", message)

    def _callable(self, physics: Any) -> Callable[[], Any]:
        if isinstance(physics, OwnValues):
            return _OwnReader(physics)
        raise self.error(batch_refusal("batched generic"))


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
