"""An observable defined by any `callable(physics)`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .base import Observable

__all__ = ["Generic"]


class Generic(Observable):
    """Wraps `raw_observation_callable(physics) -> value`."""

    def __init__(self, raw_observation_callable: Callable[[Any], Any], update_interval: Any = 1,
                 buffer_size: int | None = None, delay: Any = None, aggregator: Any = None,
                 corruptor: Callable[..., Any] | None = None):
        if not callable(raw_observation_callable):
            raise TypeError(f"Generic needs a callable, got {type(raw_observation_callable).__name__}")
        self._raw_callable = raw_observation_callable
        super().__init__(update_interval, buffer_size, delay, aggregator, corruptor)

    def __repr__(self) -> str:
        return f"Generic({getattr(self._raw_callable, '__qualname__', self._raw_callable)!r})"

    def _callable(self, physics: Any) -> Callable[[], Any]:
        raw = self._raw_callable
        return lambda: raw(physics)
