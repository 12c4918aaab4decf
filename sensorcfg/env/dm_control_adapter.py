"""Suites inside dm_control: observables that dm_control's own Updater runs.

sensorcfg observables already take a dm_control Physics (they read `.model.ptr` / `.data.ptr`). What
dm_control's Updater does not know about is a sensor's noise pipeline, which our Updater applies and seeds
per sensor. The adapter folds that pipeline into the observation callable: on each episode (dm_control binds
observables at every reset) the pipeline is reseeded from dm_control's random state and the sensor's name,
and each sample is corrupted with the simulated time read from the physics. The suite's observables share
one episode entropy, drawn as our Updater draws it, and noise is counter-based (a sample's numbers depend
on its time only), so stateless stages and random walks give a sample exactly what our Updater gives it;
stateful ones (low-pass, dropout holding, custom) see the samples dm_control takes, which skips
samples no read can see, where our Updater feeds them every sample of the schedule.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..physics import raw_structs
from ..draws import episode_entropy, sensor_key, takes_random_state

__all__ = ["dm_control_observables", "BridgedObservable"]


class _EpisodeEntropy:
    """The episode entropy a suite's adapted observables share, drawn as our Updater draws it: once per
    episode from the episode's random state, before anything else draws from it. dm_control binds every
    enabled observable at reset, in order, before drawing any delay: the first enabled noisy one draws."""

    def __init__(self) -> None:
        self.members: list[BridgedObservable] = []
        self.value: list[int] = []

    def get(self, member: BridgedObservable, random_state: Any) -> list[int]:
        first = next((m for m in self.members if m.enabled and m._observable.noise is not None), member)
        if first is member:
            self.value = episode_entropy(random_state)
        return self.value


class BridgedObservable:
    """Delegates to a sensorcfg observable; applies its noise inside `observation_callable`."""

    def __init__(self, name: str, observable: Any, entropy: _EpisodeEntropy | None = None):
        self._name = name
        self._observable = observable
        self._random_state: Any = None
        self._entropy = entropy if entropy is not None else _EpisodeEntropy()
        self._entropy.members.append(self)

    def _schedule(self, value: Any) -> Any:
        """dm_control passes its random state only to its own Variations; a callable that requires one gets
        the episode's too (the Updater's rule, `takes_random_state`), and any other is called bare."""
        if callable(value) and takes_random_state(value):
            return lambda: value(random_state=self._random_state)
        return value

    @property
    def update_interval(self) -> Any:
        return self._schedule(self._observable.update_interval)

    @property
    def delay(self) -> Any:
        return self._schedule(self._observable.delay)

    def __getattr__(self, attr: str) -> Any:
        return getattr(self._observable, attr)

    def __setattr__(self, attr: str, value: Any) -> None:
        if attr.startswith("_"):
            object.__setattr__(self, attr, value)
        else:
            setattr(self._observable, attr, value)

    @property
    def enabled(self) -> bool:
        return self._observable.enabled

    @enabled.setter
    def enabled(self, value: bool) -> None:
        self._observable.enabled = value

    def observation_callable(self, physics: Any, random_state: Any = None) -> Callable[[], Any]:
        self._random_state = random_state  # dm_control binds each observable before reading its schedule
        sample = self._observable.observation_callable(physics, random_state)
        noise = self._observable.noise
        if noise is None:
            return sample
        interval = self._observable.update_interval
        stride = int(interval) if interval and not callable(interval) else 1  # as our Updater numbers samples
        noise.reset(sensor_key(self._entropy.get(self, random_state), self._name), stride)
        model, data = raw_structs(physics)
        timestep = float(model.opt.timestep)

        def noisy() -> Any:
            return noise(np.asarray(sample()), int(round(data.time / timestep)))

        return noisy

    def __call__(self, physics: Any, random_state: Any = None) -> Any:
        return self.observation_callable(physics, random_state)()


def dm_control_observables(suite: Any, physics: Any) -> dict[str, Any]:
    """Observables for a dm_control Physics, ready for a composer task or dm_control's Updater.

    `suite` is a `sensorcfg.Suite` or a path; units are converted with the physics' own timestep. Disabled
    sensors come back disabled, as in dm_control. For example, in a composer task::

        for name, obs in sensorcfg.dm_control_observables("suite.yaml", physics).items():
            self._task_observables[name] = obs

    Args:
        suite: A `Suite`, or a suite file's path.
        physics: The dm_control Physics they read; its model must carry the suite's MuJoCo sensors and
            cameras (`Suite.compile` makes one that does).

    Returns:
        The observables by sensor name, in the suite's order.

    Raises:
        SuiteError: Every problem of the suite against the physics' model, each at its line.
    """
    if not hasattr(suite, "build"):
        from .. import load

        suite = load(suite)
    model, _ = raw_structs(physics)
    entropy = _EpisodeEntropy()
    return {name: BridgedObservable(name, obs, entropy) for name, obs in suite.build(model).items()}
