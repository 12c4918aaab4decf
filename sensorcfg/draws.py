"""Seeding and schedule callables: every rule about who draws what, from which stream, in one place.

- `UniformSteps` / `ChoiceSteps`: intervals and delays drawn per sample (`{uniform: [lo, hi]}`,
  `{choice: [...], p: [...]}` in steps). Frozen, compare by value, accept a numpy `RandomState` (as
  dm_control passes) or a `Generator`.
- `takes_random_state`: which schedule callables are given the episode's random state (dm_control's rule).
- `drawer`: an interval or delay setting as an int or a validated zero-argument draw.
- `episode_entropy` / `sensor_key`: each sensor's own noise streams per episode, keyed by a hash of the
  episode's random state and the sensor's name.
- `root_seed` / `sim_seed`: a batch's seed, and simulation (or world) i's within it: every many-simulation
  engine seeds its simulations so, and `Environment(seed=sim_seed(seed, i))` reproduces simulation i.

The Updater, the batch and the dm_control adapter all call these; none restates them.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import numbers
from collections.abc import Callable, Sequence
from typing import Any, cast

import numpy as np

from .errors import ArgumentError, SuiteError

__all__ = ["UniformSteps", "ChoiceSteps", "takes_random_state", "drawer", "episode_entropy", "sensor_key",
           "sensor_keys", "as_draw", "planned", "root_seed", "sim_seed", "DEFAULT_UPDATE_INTERVAL", "DEFAULT_DELAY",
           "DEFAULT_BUFFER_SIZE"]

DEFAULT_BUFFER_SIZE = 1
DEFAULT_UPDATE_INTERVAL = 1
DEFAULT_DELAY = 0


def _integers(random_state: Any, low: int, high_exclusive: int) -> int:
    if isinstance(random_state, np.random.RandomState):
        return int(random_state.randint(low, high_exclusive))
    return int(random_state.integers(low, high_exclusive))


@dataclasses.dataclass(frozen=True)
class UniformSteps:
    """An integer number of physics steps drawn uniformly from low..high, both inclusive."""

    low: int
    high: int

    @property
    def minimum(self) -> int:
        """The smallest value a draw can give: the Updater checks it once, not every draw."""
        return self.low if isinstance(self.low, int) and self.low <= self.high else -1

    def __call__(self, random_state: Any) -> int:
        return _integers(random_state, self.low, self.high + 1)

    @property
    def largest(self) -> int:
        return int(self.high)

    def of_uniform(self, u: np.ndarray) -> np.ndarray:
        """Draws from uniforms u in [0, 1) of 32 bits (the planned schedules' stream rule): low + floor(u n),
        n = high - low + 1 (exact in float64; n / 2^32 from uniform at most)."""
        return self.low + np.floor(u * (self.high - self.low + 1)).astype(np.int64)


@dataclasses.dataclass(frozen=True)
class ChoiceSteps:
    """One of `values` (physics steps), with probabilities `p` (uniform when None)."""

    values: tuple[int, ...]
    p: tuple[float, ...] | None = None

    @property
    def minimum(self) -> int:
        """The smallest value a draw can give: the Updater checks it once, not every draw."""
        return min(self.values) if self.values and all(isinstance(v, int) for v in self.values) else -1

    def __call__(self, random_state: Any) -> int:
        if self.p is None:
            return self.values[_integers(random_state, 0, len(self.values))]
        return self.values[int(random_state.choice(len(self.values), p=self.p))]

    @property
    def largest(self) -> int:
        return int(max(self.values))

    def of_uniform(self, u: np.ndarray) -> np.ndarray:
        """Draws from uniforms u in [0, 1) of 32 bits (the planned schedules' stream rule): value k where u
        falls in [P_(k-1), P_k) of the cumulative probabilities (floor(u n) when uniform)."""
        values = np.asarray(self.values, np.int64)
        if self.p is None:
            return values[np.floor(u * len(values)).astype(np.intp)]
        cumulative = np.cumsum(self.p)
        return values[np.minimum(np.searchsorted(cumulative, u, side="right"), len(values) - 1)]


def sensor_key(entropy: Sequence[int], name: str) -> np.ndarray:
    """A sensor's own episode key (two 64-bit words, the key of its counter-based noise streams): a hash of
    the episode's entropy and the sensor's name. Adding, removing or reordering other sensors leaves it
    unchanged."""
    return sensor_keys(entropy, [name])[0]


def sensor_keys(entropy: Sequence[int], names: Sequence[str]) -> np.ndarray:
    """`sensor_key` of several sensors of one episode, (len(names), 2)."""
    prefix = np.asarray(list(entropy), np.uint64).tobytes()
    digests = b"".join(hashlib.blake2b(prefix + name.encode(), digest_size=16).digest() for name in names)
    return np.frombuffer(digests, np.uint64).reshape(len(names), 2).copy()


def episode_entropy(random_state: Any) -> list[int]:
    """Four words drawn from the episode's random state (numpy's global one for None), seeding every
    sensor's noise streams of the episode (`sensor_key`)."""
    if isinstance(random_state, np.random.Generator):
        return [int(x) for x in random_state.integers(0, 2**32, size=4, dtype=np.uint64)]
    if random_state is None:
        random_state = np.random.mtrand._rand  # numpy's global RandomState, as dm_control would use
    return [int(x) for x in random_state.randint(0, 2**32, size=4, dtype=np.uint64)]


def root_seed(seed: int | np.random.SeedSequence | None) -> np.random.SeedSequence:
    """A batch's root seed as a SeedSequence (an integer is its entropy: any non-negative integer)."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if not (seed is None or (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0)):
        raise ArgumentError(f"seed must be None, a non-negative integer or a numpy SeedSequence; got {seed!r}")
    return np.random.SeedSequence(seed)


def sim_seed(seed: int | np.random.SeedSequence | None, i: int) -> np.random.SeedSequence:
    """Simulation i's seed in a batch seeded with `seed`: the SeedSequence child with spawn key i.

    `Environment(model, suite, seed=sim_seed(seed, i))` reproduces simulation i of the batch.
    """
    root = root_seed(seed)
    return np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, int(i)), pool_size=root.pool_size)


def takes_random_state(value: Callable[..., Any]) -> bool:
    """Whether a schedule callable is given the episode's random_state.

    dm_control passes it to its Variations only, and calls any other callable with no arguments, even one
    with an optional `random_state` (which then draws from its own generator). We do the same, and also
    pass it to callables that require it (`lambda random_state: ...`), which dm_control cannot call.
    """
    if any(c.__name__ == "Variation" and c.__module__.startswith("dm_control.") for c in type(value).__mro__):
        return True
    try:
        param = inspect.signature(value).parameters.get("random_state")
    except (TypeError, ValueError):
        return False
    return (param is not None and param.default is param.empty
            and param.kind in (param.POSITIONAL_OR_KEYWORD, param.KEYWORD_ONLY))


def drawer(owner: str, attr: str, value: Any, default: int, random_state: Any) -> int | Callable[[], int]:
    """An int, or a zero-argument function drawing validated ints (dm_control Variations get random_state)."""
    if not value:
        return default
    lowest = 0 if attr == "delay" else 1
    if not callable(value):
        if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < lowest:
            raise SuiteError(f"observable {owner!r}: {attr} must be a "
                             f"{'non-negative' if attr == 'delay' else 'positive'} integer, got {value!r}")
        return int(value)
    if isinstance(value, (UniformSteps, ChoiceSteps)) and value.minimum >= lowest:
        # sensorcfg's own draws give integers >= their minimum: no check per draw. A closure, not the
        # partial: copies of a channel (deepcopy) must keep drawing from the episode's random state.
        return lambda: value(random_state)
    draw = functools.partial(value, random_state=random_state) if takes_random_state(value) else value

    def checked() -> int:
        drawn = draw()
        # (typeshed's numbers.Real declares neither >= nor __int__: cast to the float it behaves as)
        if isinstance(drawn, numbers.Real) and float(drawn).is_integer() and cast(float, drawn) >= lowest:
            return int(cast(float, drawn))
        raise SuiteError(f"observable {owner!r}: its {attr} callable drew {drawn!r}; "
                         f"it must draw integers >= {lowest} (physics steps)")

    return checked


def planned(interval: Any, delay: Any) -> bool:
    """Whether a schedule follows the planned-schedule stream rule (`plan/drawn.py`): sensorcfg's own draws
    (`{uniform}`, `{choice}`: UniformSteps, ChoiceSteps) giving valid values, with an int or another such
    draw for the other setting. Any other callable keeps dm_control's planning and draw order."""
    settings = [(interval or DEFAULT_UPDATE_INTERVAL, 1), (delay or DEFAULT_DELAY, 0)]
    if not any(isinstance(v, (UniformSteps, ChoiceSteps)) for v, _ in settings):
        return False
    return all((isinstance(v, (UniformSteps, ChoiceSteps)) and v.minimum >= lowest)
               or (isinstance(v, numbers.Integral) and not isinstance(v, bool) and int(v) >= lowest)
               for v, lowest in settings)


def as_draw(value: int | Callable[[], int]) -> Callable[[], int]:
    """A `drawer` result as a zero-argument function (a constant becomes one)."""
    return value if callable(value) else (lambda: value)
