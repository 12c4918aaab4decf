"""The Updater: dm_control's observation Updater API and semantics, with a precomputed sampling plan.

Per physics step, `update()` looks up the channels due at this step's phase of a precomputed periodic
plan (no per-observable checks, no name look-ups); `get_observation()` reads each channel's window.
Observables are duck-typed: dm_control's own observables work unchanged.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Union, cast

import numpy as np
from dm_env import specs

from ..draws import (DEFAULT_BUFFER_SIZE, DEFAULT_DELAY, DEFAULT_UPDATE_INTERVAL, as_draw, drawer, episode_entropy,
                     sensor_rng)
from ..errors import SuiteError
from ..observables.aggregators import builtin, preserves_bounds
from .mujoco_structs import structs_of as raw_structs
from .bank import BankMember, FeatureBank, qualifies
from .channels import FixedChannel, RandomChannel

__all__ = ["Updater"]

_MAX_PLAN_PERIOD = 1 << 16

_Task = Callable[[int], None]  # one sampling task of the plan, called with the step
_Reader = Union[FixedChannel, RandomChannel, BankMember]  # what the layout holds per observable


class Updater:
    """Samples, delays, buffers, aggregates and corrupts observables inside the physics loop."""

    # set by `reset` (and `_build_plan`)
    _channels: list[FixedChannel | RandomChannel]
    _bank: FeatureBank | None
    _reads: list[tuple[type, list[tuple[str, int, _Reader]]]]
    _random: list[tuple[int, RandomChannel]]
    _period: int
    _plan: list[tuple[_Task, ...]]
    _orders: list[tuple[int, ...]]
    _slow: list[tuple[int, frozenset[int], int, _Task]]

    def __init__(self, observables: Mapping[str, Any] | Sequence[Mapping[str, Any]],
                 physics_steps_per_control_step: int = 1, strip_singleton_buffer_dim: bool = False,
                 pad_with_initial_value: bool = False):
        nested = isinstance(observables, (list, tuple))
        valid = all(isinstance(o, Mapping) for o in observables) if nested else isinstance(observables, Mapping)
        if not valid:
            raise SuiteError("`observables` must be a dict, or a list or tuple of dicts, of observables; "
                             f"got {type(observables).__name__}")
        n = physics_steps_per_control_step
        if not isinstance(n, numbers.Integral) or isinstance(n, bool) or n < 1:
            raise SuiteError(f"physics_steps_per_control_step must be a positive integer, got {n!r}")
        self._observables: Any = observables
        self._nested: bool = nested
        self._n: int = int(n)
        self._strip: bool = bool(strip_singleton_buffer_dim)
        self._pad: bool = bool(pad_with_initial_value)
        self._step: int = 0
        self._layout: list[tuple[type, list[tuple[str, _Reader]]]] | None = None

    @property
    def physics_steps_per_control_step(self) -> int:
        return self._n

    # -- reset ------------------------------------------------------------------------------------

    def reset(self, physics: Any, random_state: Any) -> None:
        """Bind every enabled observable, take the reset samples, and precompute the sampling plan."""
        dicts = list(self._observables) if self._nested else [self._observables]
        noisy = any(getattr(o, "noise", None) is not None for d in dicts for o in d.values() if o.enabled)
        entropy = episode_entropy(random_state) if noisy else None
        layout: list[tuple[type, list[tuple[str, FixedChannel | RandomChannel]]]] = []
        for index, obs_dict in enumerate(dicts):
            entries: list[tuple[str, FixedChannel | RandomChannel]] = []
            for name, observable in obs_dict.items():
                if observable.enabled:
                    label = f"{index}/{name}" if self._nested else str(name)
                    entries.append((name, self._channel(label, observable, physics, random_state, entropy)))
            layout.append((type(obs_dict), entries))
        self._channels = [ch for _, entries in layout for _, ch in entries]
        self._bank = self._make_bank(physics)
        positions = {id(m.channel): m for m in self._bank.members()} if self._bank else {}
        self._layout = [(kind, [(name, positions.get(id(ch), ch)) for name, ch in entries])
                        for kind, entries in layout]
        self._reads = [(kind, [(name, cast(BankMember, m).position if id(ch) in positions else -1, m)
                               for (name, ch), (_, m) in zip(entries, self._layout[i][1])])
                       for i, (kind, entries) in enumerate(layout)]
        self._step = 0
        synced = False
        for ch in self._channels:  # dm_control's order: per observable, its delay draw then its sample
            if id(ch) not in positions:
                ch.start(0)
            elif not synced and getattr(ch.sampler, "sync", None) is not None:
                cast(Any, ch.sampler).sync()  # where dm_control's read would bring a dirty physics up to date
                synced = True
        if self._bank:
            self._bank.start()
        self._build_plan()
        first_kind, first_reads = self._reads[0]
        self._all_banked = (not self._nested and self._bank is not None
                            and [pos for _, pos, _ in first_reads] == list(range(len(first_reads))))
        self._dict_type, self._names = first_kind, [name for name, _, _ in first_reads]

    def _make_bank(self, physics: Any) -> FeatureBank | None:
        members = [ch for ch in self._channels if qualifies(ch)]
        if not members:
            return None
        data = raw_structs(physics)[1]
        key = FeatureBank.key(members, data, self._n, self._pad)
        cached = getattr(self, "_bank_cache", None)
        if cached is not None and cached[0] == key:  # same sensors: keep the layout and its read plans
            cached[1].rebind(members)
            return cached[1]
        try:
            bank = FeatureBank(members, data, self._n, self._pad)
        except ValueError:  # fields outside MjData's main buffer: read them one by one
            return None
        self._bank_cache = (key, bank)
        return bank

    def _channel(self, label: str, observable: Any, physics: Any, random_state: Any,
                 entropy: list[int] | None) -> FixedChannel | RandomChannel:
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
        if noise is not None:
            noise.reset(sensor_rng(entropy or [], label))
        read_into = getattr(sampler, "read_into", None)
        aggregator = observable.aggregator
        args = (label, sampler, read_into, shape, dtype, int(buffer_size), self._strip, self._pad, self._n,
                aggregator, builtin(aggregator) is not None, noise)
        if callable(interval) or callable(delay):
            return RandomChannel(*args, interval=as_draw(interval), delay=as_draw(delay))
        return FixedChannel(*args, interval=interval, delay=delay)

    def _build_plan(self) -> None:
        """One table over the common period: which sampling tasks run at each step's phase."""
        # Tasks carry the position of their observable: samplers may have side effects (a corruptor
        # drawing from the episode's random_state), so within a step they run in dm_control's order,
        # the observables' order. The bank's snapshot is a pure read and goes first.
        banked = {id(m.channel) for m in self._bank.members()} if self._bank else set()
        tasks = [(ch.period(), ch.needed_phases(), order, ch.sample) for order, ch in enumerate(self._channels)
                 if isinstance(ch, FixedChannel) and id(ch) not in banked]
        if self._bank:  # snapshots and noise draws: pure reads of the state, before any sampler
            tasks[:0] = [(p, phases, -1, task) for p, phases, task in self._bank.tasks()]
        syncing = [m.channel for m in self._bank.members() if getattr(m.channel.sampler, "sync", None)] \
            if self._bank else []
        if syncing:  # on a dirty dm_control physics, mj_forward before a step's derived reads (as its bind does)
            rows, sync = cast(FeatureBank, self._bank).rows, cast(Any, syncing[0].sampler).sync
            steps = sorted({t for ch in syncing for p in ch.needed_phases() for t in range(p, rows, ch.period())})
            tasks[:0] = [(rows, steps, -2, lambda step: sync())]
        self._random = [(order, ch) for order, ch in enumerate(self._channels) if isinstance(ch, RandomChannel)]
        period = math.lcm(*(p for p, _, _, _ in tasks)) if tasks else 1
        if period > _MAX_PLAN_PERIOD:  # pathological interval mixes: each task checks its own phase
            self._period, self._plan, self._orders = 1, [()], [()]
            self._slow = [(p, frozenset(phases), order, task) for p, phases, order, task in tasks]
            return
        self._slow = []
        plan: list[list[tuple[int, _Task]]] = [[] for _ in range(period)]
        for task_period, phases, order, task in tasks:
            for phase in phases:
                for t in range(phase, period, task_period):
                    plan[t].append((order, task))
        for entries in plan:
            entries.sort(key=lambda entry: entry[0])
        self._period = period
        self._plan = [tuple(task for _, task in entries) for entries in plan]
        self._orders = [tuple(order for order, _ in entries) for entries in plan]

    # -- the physics loop -------------------------------------------------------------------------

    def prepare_for_next_control_step(self) -> None:
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `prepare_for_next_control_step`.")
        for _, ch in self._random:
            ch.plan(self._step)

    def update(self) -> None:
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `update`.")
        step = self._step = self._step + 1
        tasks = self._plan[step % self._period]
        if self._slow or self._random:
            tasks = self._merge_irregular(step, tasks)
        for sample in tasks:
            sample(step)

    def _merge_irregular(self, step: int, tasks: tuple[_Task, ...]) -> Any:
        """This step's tasks with the due random channels and off-plan tasks, in observable order."""
        extra = [(order, task) for period, phases, order, task in self._slow if step % period in phases]
        extra += [(order, ch.sample) for order, ch in self._random if ch.due(step)]
        if not extra:
            return tasks
        merged = sorted([*zip(self._orders[step % self._period], tasks), *extra], key=lambda entry: entry[0])
        return [task for _, task in merged]

    def get_observation(self) -> Any:
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `get_observation`.")
        step = self._step
        if self._all_banked:  # the common case: one gather, then a dict in file order
            return self._dict_type(zip(self._names, cast(FeatureBank, self._bank).read(step)))
        banked = self._bank.read(step) if self._bank else ()
        out = [kind((name, banked[pos] if pos >= 0 else ch.read(step)) for name, pos, ch in entries)
               for kind, entries in self._reads]
        return type(self._observables)(out) if self._nested else out[0]

    # -- specs and counters -----------------------------------------------------------------------

    def observation_spec(self) -> Any:
        """dm_env specs of the observations; BoundedArray where bounds survive the aggregator."""
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `observation_spec`.")
        dicts = list(self._observables) if self._nested else [self._observables]
        out = []
        for obs_dict, (kind, entries) in zip(dicts, self._layout):
            out.append(kind((name, _spec(name, obs_dict[name], ch)) for name, ch in entries))
        return type(self._observables)(out) if self._nested else out[0]

    def samples_taken(self) -> Any:
        """How many samples each enabled observable has taken since reset (the reset sample included)."""
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `samples_taken`.")
        step = self._step
        out = [kind((name, ch.samples_at(step) if hasattr(ch, "samples_at") else ch.samples)
                    for name, ch in entries) for kind, entries in self._layout]
        return type(self._observables)(out) if self._nested else out[0]

    @property
    def step_count(self) -> int:
        """Physics steps since the last reset."""
        return self._step


def _spec(name: str, observable: Any, ch: _Reader) -> specs.Array:
    array_spec = observable.array_spec
    aggregator = observable.aggregator
    if aggregator is None and array_spec is not None:
        return array_spec.replace(name=name, shape=ch.buffered_shape)
    bounds = None
    if isinstance(array_spec, specs.BoundedArray):
        bounds = (array_spec.minimum, array_spec.maximum)
    shape, dtype = ch.buffered_shape, ch.dtype
    if aggregator is not None:
        aggregated = np.asarray(aggregator(np.zeros(ch.buffered_shape, dtype=ch.dtype)))
        shape, dtype = aggregated.shape, aggregated.dtype
        if not preserves_bounds(aggregator):
            bounds = None
    if bounds is not None:
        return specs.BoundedArray(shape=shape, dtype=dtype, minimum=bounds[0], maximum=bounds[1], name=name)
    return specs.Array(shape=shape, dtype=dtype, name=name)
