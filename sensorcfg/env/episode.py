"""When an episode ends, and with which discount: one rule for `Environment` and `BatchEnvironment`.

A diverged simulation or a `termination_fn` ends the episode with discount 0 (termination); otherwise the
time limit ends it with discount 1 (truncation); otherwise it goes on (discount 1). Elementwise: the single
environment passes scalars, the batch one value per simulation.
"""

from __future__ import annotations

from typing import Any

__all__ = ["episode_end"]


def episode_end(diverged: Any, terminated: Any, control_steps: Any, step_limit: int | None) -> tuple[Any, Any]:
    """(last, discount): whether this step ends the episode, and its discount (bools and numbers for
    scalars, arrays for arrays: plain operators, no numpy call on the single environment's path)."""
    terminal = diverged | terminated
    last = terminal if step_limit is None else terminal | (control_steps >= step_limit)
    return last, 1.0 - terminal
