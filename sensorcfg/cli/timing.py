"""When each sensor's samples were taken and delivered during a run, for the timing panels of `--plot`.

Fixed schedules are closed-form: sample k at `k * interval`, delivered `delay` steps later. Drawn schedules
are recorded: each drawn interval or delay is captured as the run makes it (`Recorder`), then replayed into
a shadow Updater whose observables return their own sampling step. The shadow plans, drops and delivers
exactly as the real one did (the same Updater code on the same draws), and it is read at every physics
step, so each sample's delivery step is seen directly, with nothing read from the Updater's internals.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

__all__ = ["Recorder", "Timing", "record_draws", "clear_draws", "timings"]


class Recorder:
    """Wraps a drawn schedule (a callable taking `random_state`) and keeps every value it draws."""

    def __init__(self, draw: Any):
        self.draw = draw
        self.values: list[int] = []

    def __call__(self, random_state: Any) -> int:  # required: the Updater passes it only then
        value = int(self.draw(random_state=random_state))
        self.values.append(value)
        return value


class _Replay:
    """Returns the recorded draws in order (takes no random state, so the Updater passes none)."""

    def __init__(self, values: list[int]):
        self.values = iter(values)

    def __call__(self) -> int:
        return next(self.values)


@dataclasses.dataclass
class Timing:
    """Sample and delivery steps of one sensor (equal lengths; delivery >= sample, possibly after the run),
    and which samples some read shows (the others the Updater never takes)."""

    sampled: np.ndarray
    delivered: np.ndarray
    visible: np.ndarray


def record_draws(observables: dict[str, Any]) -> None:
    """Wrap the drawn intervals and delays of enabled observables in Recorders (in place, before the run)."""
    for obs in observables.values():
        if not obs.enabled:
            continue
        for attr in ("update_interval", "delay"):
            value = getattr(obs, attr)
            if callable(value):
                setattr(obs, attr, Recorder(value))


def clear_draws(observables: dict[str, Any]) -> None:
    """Forget what was drawn so far (the Environment resets once to learn its specs before the episode)."""
    for obs in observables.values():
        for attr in ("update_interval", "delay"):
            value = getattr(obs, attr)
            if isinstance(value, Recorder):
                value.values.clear()


def timings(observables: dict[str, Any], physics_steps: int, substeps: int) -> dict[str, Timing]:
    """Sample and delivery steps of every enabled observable over `physics_steps` steps after reset."""
    out: dict[str, Timing] = {}
    drawn = {}
    for name, obs in observables.items():
        if not obs.enabled:
            continue
        interval, delay = obs.update_interval or 1, obs.delay or 0
        if isinstance(interval, Recorder) or isinstance(delay, Recorder):
            drawn[name] = obs
            continue
        sampled = np.arange(0, physics_steps + 1, int(interval))  # delivery may fall after the run
        out[name] = Timing(sampled, sampled + int(delay),
                           _visible(sampled, int(interval), int(delay), substeps, obs.buffer_size or 1))
    if drawn:
        out.update(_replay(drawn, physics_steps, substeps))
    return {name: out[name] for name in observables if name in out}


def _replay(observables: dict[str, Any], physics_steps: int, substeps: int) -> dict[str, Timing]:
    from ..observables import Generic
    from ..runtime.updater import Updater

    clock = [0]
    shadows = {}
    for name, obs in observables.items():
        schedule = {attr: _Replay(v.values) if isinstance(v, Recorder) else v
                    for attr, v in (("update_interval", obs.update_interval), ("delay", obs.delay))}
        shadow = Generic(lambda _physics: np.float64(clock[0] + 1), buffer_size=obs.buffer_size,
                         update_interval=schedule["update_interval"], delay=schedule["delay"])
        shadow.enabled = True
        shadows[name] = shadow
    updater = Updater(shadows, substeps)
    updater.reset(None, None)
    seen: dict[str, dict[int, int]] = {name: {} for name in shadows}  # tag -> delivery step
    _collect(updater.get_observation(), seen, 0)
    for step in range(1, physics_steps + 1):
        if (step - 1) % substeps == 0:
            updater.prepare_for_next_control_step()
        clock[0] = step
        try:
            updater.update()
        except StopIteration:  # the real run ended (diverged) before drawing this far
            break
        _collect(updater.get_observation(), seen, step)
    return {name: Timing(np.array([t - 1 for t in tags], dtype=np.int64), np.array(list(tags.values()), np.int64),
                         np.ones(len(tags), bool)) for name, tags in seen.items()}


def _visible(sampled: np.ndarray, interval: int, delay: int, substeps: int, buffer: int) -> np.ndarray:
    """Whether sample k (taken at k * interval) is still among the newest `buffer` at its first read
    (dm_control's semantics in closed form: `plan.schedule`)."""
    from ..plan.schedule import Schedule

    return Schedule(interval, delay, buffer, substeps).visible(sampled // interval)


def _collect(observation: dict[str, np.ndarray], seen: dict[str, dict[int, int]], step: int) -> None:
    for name, window in observation.items():
        for tag in np.asarray(window).reshape(-1):
            tag = int(tag)
            if tag and tag not in seen[name]:
                seen[name][tag] = step
