"""The Updater: dm_control's observation Updater API and semantics, with a precomputed sampling table.

Per physics step, `update()` looks up the channels due at this step's phase of a precomputed periodic
table (no per-observable checks, no name look-ups); `get_observation()` reads each channel's window.
Observables are duck-typed: dm_control's own observables work unchanged.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Collection, Hashable, Mapping, Sequence
from typing import Any, NamedTuple, Union, cast

import numpy as np

from ..draws import episode_entropy, planned
from ..errors import ArgumentError
from ..plan.spec import observation_spec
from ..mujoco_structs import structs_of as raw_structs
from .bank import BankMember, FeatureBank, buffer_view, fields_of, qualifies
from .channels import DrawnChannel, FixedChannel, RandomChannel, make_channel
from .planned import DrawnBank, DrawnMember, joins

__all__ = ["Updater"]

_MAX_TABLE_PERIOD = 1 << 16

_Task = Callable[[int], None]  # one sampling task of the table, called with the step
# what the layout holds per observable
_Reader = Union[FixedChannel, RandomChannel, DrawnChannel, BankMember, DrawnMember]

SYNC_ORDER = -2  # `SamplingTask.order` of bringing a dirty dm_control physics up to date: before anything
BANK_ORDER = -1  # of the bank's snapshots and noise draws: pure reads of the state, before any sampler
NOT_BANKED = -1  # bank position of an observable read from its own channel


class SamplingTask(NamedTuple):
    """One task of the periodic sampling table: `run(step)` at the steps whose phase (step mod `period`) is
    in `phases`; within a step, tasks run by `order` (the observables' order, dm_control's)."""

    period: int
    phases: Collection[int]  # a set when tasks check their own phase
    order: int
    run: _Task


class Read(NamedTuple):
    """Where an observation comes from: its bank position (`NOT_BANKED`: its own `reader`)."""

    name: str
    position: int
    reader: _Reader


def _table(tasks: list[SamplingTask], period: int) -> list[list[tuple[int, _Task]]]:
    """Per step of the period: (order, run) of every task due then, sorted by order."""
    table: list[list[tuple[int, _Task]]] = [[] for _ in range(period)]
    for task in tasks:
        for phase in task.phases:
            for t in range(phase, period, task.period):
                table[t].append((task.order, task.run))
    for entries in table:
        entries.sort(key=lambda entry: entry[0])
    return table


class Updater:
    """Samples, delays, buffers, aggregates and corrupts observables inside the physics loop."""

    # set by `reset` (and `_build_phase_tasks`)
    _channels: list[FixedChannel | RandomChannel | DrawnChannel]
    _bank: FeatureBank | None
    _drawn: DrawnBank | None
    _reads: list[tuple[type, list[Read]]]
    _random: list[tuple[int, RandomChannel | DrawnChannel]]
    _period: int
    _phase_tasks: list[tuple[_Task, ...]]
    _orders: list[tuple[int, ...]]
    _slow: list[SamplingTask]
    _irregular: bool

    def __init__(self, observables: Mapping[str, Any] | Sequence[Mapping[str, Any]],
                 physics_steps_per_control_step: int = 1, strip_singleton_buffer_dim: bool = False,
                 pad_with_initial_value: bool = False):
        """dm_control's Updater settings; nothing is bound until `reset(physics, random_state)`.

        Args:
            observables: The observables by name (only the enabled ones are sampled), or a list or tuple of
                such dicts (the observation is then nested alike).
            physics_steps_per_control_step: Physics steps per control step: `update` is called after each,
                `get_observation` once per control step.
            strip_singleton_buffer_dim: Drop the buffer axis of observations whose buffer is 1.
            pad_with_initial_value: Fill a buffer that is not yet full with the first sample instead of zeros.

        Raises:
            ArgumentError: `observables` is not a dict (or a list or tuple of dicts), or the steps per
                control step are not a positive integer.
        """
        nested = isinstance(observables, (list, tuple))
        valid = all(isinstance(o, Mapping) for o in observables) if nested else isinstance(observables, Mapping)
        if not valid:
            raise ArgumentError("`observables` must be a dict, or a list or tuple of dicts, of observables; "
                             f"got {type(observables).__name__}")
        substeps = physics_steps_per_control_step
        if not isinstance(substeps, numbers.Integral) or isinstance(substeps, bool) or substeps < 1:
            raise ArgumentError(f"physics_steps_per_control_step must be a positive integer, got {substeps!r}")
        self._observables: Any = observables
        self._nested: bool = nested
        self._substeps: int = int(substeps)
        self._strip: bool = bool(strip_singleton_buffer_dim)
        self._pad: bool = bool(pad_with_initial_value)
        self._step: int = 0
        self._layout: list[tuple[type, list[tuple[str, _Reader]]]] | None = None
        # the last banks, reused for the same sensors (by `FeatureBank.key`, `DrawnBank.key`)
        self._bank_cache: tuple[tuple[Hashable, ...], FeatureBank] | None = None
        self._drawn_cache: tuple[tuple[Hashable, ...], DrawnBank] | None = None

    @property
    def physics_steps_per_control_step(self) -> int:
        return self._substeps

    # -- reset ------------------------------------------------------------------------------------

    def reset(self, physics: Any, random_state: np.random.RandomState | None) -> None:
        """Bind every enabled observable, take the reset samples, and precompute the sampling table."""
        layout = self._bind(physics, random_state)
        self._channels = [ch for _, entries in layout for _, ch in entries]
        self._bank = self._make_bank(physics)
        self._drawn = self._make_drawn_bank(physics)
        members = self._members()
        self._layout = [(kind, [(name, members.get(id(ch), ch)) for name, ch in entries]) for kind, entries in layout]
        self._reads = [(kind, [Read(name, m.position if type(m) is BankMember else NOT_BANKED, m)
                               for name, m in entries]) for kind, entries in self._layout]
        self._step = 0
        self._start(members)
        self._build_phase_tasks()
        self._irregular = bool(self._slow or self._random)  # tasks off the periodic table: merged per step
        self._fast_path()

    def _fast_path(self) -> None:
        """The common case: one dict whose every observable the bank reads, in order (one read, one dict)."""
        first_kind, first_reads = self._reads[0] if self._reads else (dict, [])  # Updater([]): no dicts at all
        self._whole = None if self._nested else self._single_bank([read.reader for read in first_reads])
        self._dict_type, self._names = first_kind, [read.name for read in first_reads]

    def _members(self) -> dict[int, BankMember | DrawnMember]:
        """The banks' members, by the id of their channel."""
        members: list[BankMember | DrawnMember] = [*(self._bank.members() if self._bank else ()),
                                                   *(self._drawn.members() if self._drawn else ())]
        return {id(m.channel): m for m in members}

    @staticmethod
    def _single_bank(readers: list[Any]) -> FeatureBank | DrawnBank | None:
        """The bank that reads every observation, in order, when one does."""
        for kind in (BankMember, DrawnMember):
            if readers and all(type(r) is kind and r.position == i for i, r in enumerate(readers)):
                bank: FeatureBank | DrawnBank = readers[0].bank
                return bank
        return None

    def _bind(self, physics: Any,
              random_state: np.random.RandomState | None) -> list[tuple[type, list[tuple[str, Any]]]]:
        """Per observables dict: its type and (name, channel) of each enabled observable, in order. The
        episode entropy keys noise streams and planned schedules (drawn when some sensor has either)."""
        dicts = list(self._observables) if self._nested else [self._observables]
        keyed = any(getattr(o, "noise", None) is not None or planned(o.update_interval, o.delay)
                    for d in dicts for o in d.values() if o.enabled)
        entropy = episode_entropy(random_state) if keyed else None
        layout = []
        for index, obs_dict in enumerate(dicts):
            entries = [(name, make_channel(f"{index}/{name}" if self._nested else str(name), observable, physics,
                                           random_state, entropy, self._substeps, self._strip, self._pad))
                       for name, observable in obs_dict.items() if observable.enabled]
            layout.append((type(obs_dict), entries))
        return layout

    def _start(self, members: Mapping[int, Any]) -> None:
        """The reset samples, in dm_control's order: per observable, its delay draw then its sample."""
        synced = False
        for ch in self._channels:
            if id(ch) not in members:
                ch.start(0)
            elif not synced and getattr(ch.sampler, "sync", None) is not None:
                cast(Any, ch.sampler).sync()  # where dm_control's read would bring a dirty physics up to date
                synced = True
        if self._bank:
            self._bank.start()
        if self._drawn:
            self._drawn.start()

    def _make_bank(self, physics: Any) -> FeatureBank | None:
        members = [ch for ch in self._channels if qualifies(ch)]
        if not members:
            return None
        data = raw_structs(physics)[1]
        key = FeatureBank.key(members, data, self._substeps, self._pad)
        cached = self._bank_cache
        if cached is not None and cached[0] == key:  # same sensors: keep the history and its read layouts
            cached[1].rebind(members)
            return cached[1]
        view = buffer_view(data, fields_of(members))
        if view is None:  # fields outside MjData's main buffer: read them one by one
            return None
        bank = FeatureBank(members, data, self._substeps, self._pad, view)
        self._bank_cache = (key, bank)
        return bank

    def _make_drawn_bank(self, physics: Any) -> DrawnBank | None:
        """The planned-schedule features that join one bank (`runtime/planned.py`)."""
        members = [ch for ch in self._channels if joins(ch)]
        if not members:
            return None
        data = raw_structs(physics)[1]
        if any(getattr(ch.sampler, "sync", None) is not None for ch in members):
            return None  # a dm_control physics: per sample
        channels = members
        key = DrawnBank.key(channels, data, self._substeps, self._pad)
        cached = self._drawn_cache
        if cached is not None and cached[0] == key:  # same sensors: keep the layout and compiled read
            cached[1].rebind(channels)
            return cached[1]
        view = buffer_view(data, fields_of(members))
        if view is None:  # fields outside MjData's main buffer: per sample
            return None
        bank = DrawnBank(channels, data, self._substeps, self._pad, view)
        self._drawn_cache = (key, bank)
        return bank

    def _build_phase_tasks(self) -> None:
        """One table over the common period: which sampling tasks run at each step's phase."""
        tasks = [*self._tasks(), *self._before_tasks()]
        drawn = {id(m.channel) for m in self._drawn.members()} if self._drawn else set()
        self._random = [(order, ch) for order, ch in enumerate(self._channels)
                        if isinstance(ch, (RandomChannel, DrawnChannel)) and id(ch) not in drawn]
        period = math.lcm(*(task.period for task in tasks)) if tasks else 1
        if period > _MAX_TABLE_PERIOD:  # pathological interval mixes: each task checks its own phase
            self._period, self._phase_tasks, self._orders = 1, [()], [()]
            self._slow = [task._replace(phases=frozenset(task.phases)) for task in tasks]
            return
        self._slow = []
        table = _table(tasks, period)
        self._period = period
        self._phase_tasks = [tuple(run for _, run in entries) for entries in table]
        self._orders = [tuple(order for order, _ in entries) for entries in table]

    def _tasks(self) -> list[SamplingTask]:
        """Every periodic task. Tasks carry the position of their observable: samplers may have side effects
        (a corruptor drawing from the episode's random_state), so within a step they run in dm_control's
        order, the observables' order. The bank's snapshots and noise are pure reads and go first."""
        bank = self._bank
        banked = {id(m.channel) for m in bank.members()} if bank else set()
        tasks = [SamplingTask(ch.period(), ch.needed_phases(), order, ch.sample)
                 for order, ch in enumerate(self._channels) if isinstance(ch, FixedChannel) and id(ch) not in banked]
        if bank:
            tasks[:0] = self._bank_tasks(bank)
        if self._drawn:  # its snapshots, at the steps its rounds planned: a pure read of the state, first
            tasks.insert(0, SamplingTask(1, [0], BANK_ORDER, self._drawn.snapshot_task()))
        return tasks

    def _before_tasks(self) -> list[SamplingTask]:
        """A field computed on demand from the velocity a step starts from is remembered one step before
        each sample (at every step for a drawn schedule), after every sampler of that step."""
        last = len(self._channels)
        tasks = []
        for ch in self._channels:
            before = getattr(ch.sampler, "before_step", None)
            if before is None:
                continue
            if isinstance(ch, FixedChannel):
                period = ch.period()
                tasks.append(SamplingTask(period, [(p - 1) % period for p in ch.needed_phases()], last, before))
            else:
                tasks.append(SamplingTask(1, [0], last, before))
        return tasks

    @staticmethod
    def _bank_tasks(bank: FeatureBank) -> list[SamplingTask]:
        """The bank's snapshots and noise draws; on a dirty dm_control physics, mj_forward before a step's
        derived reads (as its bind does): within the snapshot when they happen at the same steps."""
        syncing = [ch for ch in bank.channels if getattr(ch.sampler, "sync", None)]
        sync = cast(Any, syncing[0].sampler).sync if syncing else None
        steps = sorted({t for ch in syncing for p in ch.needed_phases() for t in range(p, bank.rows, ch.period())})
        folded = sync is not None and steps == bank.snapshot_steps()
        tasks = [SamplingTask(p, phases, BANK_ORDER, run) for p, phases, run in bank.tasks(sync if folded else None)]
        if sync is not None and not folded:
            tasks.insert(0, SamplingTask(bank.rows, steps, SYNC_ORDER, lambda step: sync()))
        return tasks

    # -- the physics loop -------------------------------------------------------------------------

    def prepare_for_next_control_step(self) -> None:
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `prepare_for_next_control_step`.")
        for _, ch in self._random:
            ch.draw_ahead(self._step)
        if self._drawn is not None:
            self._drawn.draw_ahead(self._step)

    def update(self) -> None:
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `update`.")
        step = self._step = self._step + 1
        tasks = self._phase_tasks[step % self._period]
        if self._irregular:
            tasks = self._merge_irregular(step, tasks)
        for sample in tasks:
            sample(step)

    def control_step(self, physics_step: Callable[[], None]) -> None:
        """One control step: `prepare_for_next_control_step()`, then `physics_step()` and `update()`
        physics_steps_per_control_step times, as an environment's loop does (the same calls, with the
        Updater's per-step work inlined)."""
        self.prepare_for_next_control_step()
        if self._irregular:  # tasks off the periodic table: merged per step
            for _ in range(self._substeps):
                physics_step()
                self.update()
            return
        phase_tasks, period = self._phase_tasks, self._period
        for _ in range(self._substeps):
            physics_step()
            step = self._step = self._step + 1
            for sample in phase_tasks[step % period]:
                sample(step)

    def _merge_irregular(self, step: int, tasks: tuple[_Task, ...]) -> Any:
        """This step's tasks with the due random channels and off-table tasks, in observable order."""
        extra = [(task.order, task.run) for task in self._slow if step % task.period in task.phases]
        extra += [(order, ch.sample) for order, ch in self._random if ch.due(step)]
        if not extra:
            return tasks
        merged = sorted([*zip(self._orders[step % self._period], tasks), *extra], key=lambda entry: entry[0])
        return [task for _, task in merged]

    def get_observation(self) -> Any:
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `get_observation`.")
        step = self._step
        if self._whole is not None:  # the common case: one gather, then a dict in file order
            return self._dict_type(zip(self._names, self._whole.read(step)))
        banked = self._bank.read(step) if self._bank else ()
        out = [kind((read.name, banked[read.position] if read.position != NOT_BANKED else read.reader.read(step))
                    for read in entries) for kind, entries in self._reads]
        return type(self._observables)(out) if self._nested else out[0]

    # -- specs and counters -----------------------------------------------------------------------

    def observation_spec(self) -> Any:
        """dm_env specs of the observations; BoundedArray where bounds survive the aggregator."""
        if self._layout is None:
            raise RuntimeError("`reset` must be called before `observation_spec`.")
        dicts = list(self._observables) if self._nested else [self._observables]
        out = []
        for obs_dict, (kind, entries) in zip(dicts, self._layout):
            out.append(kind((name, observation_spec(name, obs_dict[name], ch.buffered_shape, ch.dtype, self._pad))
                            for name, ch in entries))
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
