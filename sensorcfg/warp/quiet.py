"""Warp's info lines (its greeting, a `Module ... load on device ... took ... ms` line per module), quieted
while the engine builds and runs its own work.

Warp prints one line per module the first time a process loads it, and a `WarpEnvironment` loads dozens
(MuJoCo Warp specialises its kernels per model) across its construction, its first reset and its first step.
`quiet` runs a method with `wp.config.log_level` at least `wp.LOG_WARNING` and gives the user's setting back
afterwards (also when the method raises); a user who set Warp's debug level keeps every line.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar, cast

import warp as wp

__all__ = ["quiet", "quiet_loads"]

F = TypeVar("F", bound=Callable[..., Any])


@contextmanager
def quiet_loads() -> Iterator[None]:
    """Warp's info lines off inside the block (unless the user asked for its debug lines), restored after."""
    level = wp.config.log_level
    if level > wp.LOG_DEBUG:
        wp.config.log_level = max(level, wp.LOG_WARNING)
    try:
        yield
    finally:
        wp.config.log_level = level


def quiet(method: F) -> F:
    """`method` run inside `quiet_loads` (its signature and type unchanged)."""
    @functools.wraps(method)
    def run(*args: Any, **kwargs: Any) -> Any:
        with quiet_loads():
            return method(*args, **kwargs)
    return cast(F, run)
