"""The fast path for plain features: every noise-free float64 mjData feature of an Updater, together.

Per physics step that any of them must sample, one `numpy.take` copies all their values from MjData's
main buffer (one allocation holding qpos, xpos, sensordata, ...) into a history indexed by step; per read,
one gather builds every window at once and each aggregator runs once per (aggregator, buffer) group.
Which steps snapshot, and which history rows each read gathers, are periodic and computed once.

Semantics are those of `FixedChannel` (dm_control's): sample k is taken at step k*interval, delivered
`delay` steps later, and a read returns the last `buffer_size` delivered samples.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Hashable, Sequence
from typing import TYPE_CHECKING, Protocol, TypeGuard, cast

import numpy as np

from ..cache import BoundedCache
from ..plan.bound import aggregator_name, field_reader, plain_refusal
from ..plan.layout import Member, read_layout
from ..plan.records import NoiseProgram
from ..plan.schedule import history_rows, noise_chunk
from .bank_noise import BankNoise, program, program_of
from .bank_read import PADS, CompiledRead, compile_read, cut, finish
from .channels import Channel, DrawnChannel, FixedChannel
from .read_kernel import kernel_read, kernel_snapshot

if TYPE_CHECKING:
    from mujoco import MjData

__all__ = ["FeatureBank", "BankMember", "bank_member", "laid_out", "qualifies", "buffer_view", "fields_of",
           "reuse_key"]

_READS_BUDGET = 4 << 20  # bytes of read layouts kept, at least (4 x the history's size when that is more)


def buffer_view(data: MjData, fields: list[str]) -> tuple[np.ndarray, dict[str, int]] | None:
    """A float64 view spanning the given mjData fields, and each field's offset in it (in values).

    All mjData arrays live in one allocation of `nbuffer` bytes starting at `qpos`; returns None when the
    fields do not provably lie inside it (then the caller reads field by field).
    """
    start = data.qpos.ctypes.data
    nbuffer = int(getattr(data, "nbuffer", 0))
    arrays = {f: getattr(data, f) for f in fields}
    if nbuffer <= 0 or any(a.dtype != np.float64 or not a.flags.c_contiguous for a in arrays.values()):
        return None
    lo = min(a.ctypes.data for a in arrays.values())
    hi = max(a.ctypes.data + a.nbytes for a in arrays.values())
    if lo < start or hi > start + nbuffer or (lo - start) % 8:
        return None
    raw = np.ctypeslib.as_array((ctypes.c_double * ((hi - lo) // 8)).from_address(lo))
    return raw, {f: (a.ctypes.data - lo) // 8 for f, a in arrays.items()}


def fields_of(channels: Sequence[Channel]) -> list[str]:
    """The mjData fields that bank members read, sorted."""
    return sorted({field_reader(ch.sampler).field for ch in channels})


def laid_out(ch: FixedChannel) -> Member:
    """A fixed-schedule member as `read_layout` reads it."""
    return Member(ch.schedule, aggregator_name(ch.aggregator), ch.shape, ch.buffered_shape)


class SharedRead(Protocol):
    """What a bank member asks of its bank (`FeatureBank`, `planned.DrawnBank`)."""

    def read(self, step: int) -> Sequence[np.ndarray]: ...
    def samples(self, position: int, step: int) -> int: ...


class BankMember:
    """Stands in for a channel in the Updater's layout; reads come from the bank's shared read."""

    __slots__ = ("name", "bank", "position", "channel")

    def __init__(self, bank: SharedRead, position: int, channel: FixedChannel | DrawnChannel):
        self.name = channel.name
        self.bank = bank
        self.position = position
        self.channel = channel

    def samples_at(self, step: int) -> int:
        return self.bank.samples(self.position, step)

    @property
    def buffered_shape(self) -> tuple[int, ...]:
        return self.channel.buffered_shape

    @property
    def dtype(self) -> np.dtype:
        return self.channel.dtype

    def start(self, step: int) -> None:  # the bank takes the reset sample for all members at once
        pass

    def read(self, step: int) -> np.ndarray:
        return self.bank.read(step)[self.position]  # the Updater reads the bank once per observation instead


class FeatureBank:
    """All plain float64 mjData features of one Updater."""

    def __init__(self, channels: list[FixedChannel], data: MjData, substeps: int, pad: bool,
                 view: tuple[np.ndarray, dict[str, int]]):
        """`view`: `buffer_view(data, fields)` of the members' fields (the caller checked it exists)."""
        self.raw, offsets = view
        self._data = data  # keeps the memory behind `raw` alive
        self.channels = channels
        self.substeps = substeps
        self.pad = pad
        widths = [int(np.prod(ch.shape, dtype=int)) for ch in channels]
        self.cols = np.cumsum([0] + widths)
        self.width = int(self.cols[-1])
        self.source = np.concatenate(
            [offsets[field_reader(ch.sampler).field] + field_reader(ch.sampler).index.ravel()
             for ch in channels]).astype(np.intp)
        noises = [program_of(ch.noise, ch.shape, ch.schedule) for ch in channels]
        noisy = any(noise is not None and noise.steps for noise in noises)
        # Noise is drawn a chunk ahead; the history then also holds a chunk (rows: a multiple of the chunk).
        schedules = [ch.schedule for ch in channels]
        self.chunk = noise_chunk(schedules, substeps) if noisy else 0
        self.rows = history_rows(schedules, substeps, ahead=self.chunk)  # a multiple of every sampling period
        # the history, then the values reductions of different buffers are padded with (`bank_read.PADS`)
        self.flat = np.zeros(self.rows * self.width + len(PADS))
        self.flat[self.rows * self.width:] = PADS
        self.history = self.flat[:self.rows * self.width].reshape(self.rows, self.width)
        self.history_rows = list(self.history)
        self.phases = [(ch.period(), len(phases), phases) for ch in channels for phases in [ch.needed_phases()]]
        self.snap_rows = _snapshot_rows(self.phases, self.rows)
        # read layouts per phase, and early reads' padded positions per step: kept within a byte budget
        self._gathers = BoundedCache(max(_READS_BUDGET, 4 * self.history.nbytes))
        self._early = BoundedCache(_READS_BUDGET // 4)
        self.noise = self._noise(noises) if noisy else None
        self.pad_values = np.zeros(self.width)

    def _noise(self, noises: list[NoiseProgram | None]) -> BankNoise:
        """The members' noise, drawn a chunk ahead: each member's sample steps within one chunk."""
        in_chunk = [np.array(sorted(p + m for p in phases for m in range(0, self.chunk, period)), np.intp)
                    for period, _, phases in self.phases]
        return BankNoise(self.channels, noises, self.cols, self.rows, self.chunk, in_chunk)

    @staticmethod
    def key(channels: list[FixedChannel], data: MjData, substeps: int, pad: bool) -> tuple[Hashable, ...]:
        """What the bank's history and read layouts depend on: equal keys let a reset reuse the bank."""
        return reuse_key(channels, data, substeps, pad, [(ch.interval, ch.delay) for ch in channels])

    def rebind(self, channels: list[FixedChannel]) -> None:
        """Take this episode's channels (same settings as the ones the bank was built for)."""
        self.channels = channels

    def members(self) -> list[BankMember]:
        return [BankMember(self, i, ch) for i, ch in enumerate(self.channels)]

    def snapshot_steps(self) -> list[int]:
        return [t for t, snap in enumerate(self.snap_rows) if snap]

    def tasks(self, sync: Callable[[], None] | None = None) -> list[tuple[int, list[int], Callable[[int], None]]]:
        """(period, phases, task(step)) for the Updater's sampling table: snapshots (each calling `sync` first when
        given), and noise drawn a chunk ahead."""
        out = [(self.rows, self.snapshot_steps(), self._snapshot_task(sync))]
        if self.noise is not None:
            out.append((self.chunk, [0], self.noise.fill))
        return out

    def start(self) -> None:
        """Take the reset sample (step 0) and pad the history."""
        self.raw.take(self.source, None, self.history[0], "clip")
        if self.pad:
            self.history[1:] = self.history[0]
        else:
            self.history[1:] = 0.0
        if self.noise is not None:
            self.noise.start([ch.key for ch in self.channels])
            if self.pad:  # padding repeats the first sample as delivered: with its noise
                first = np.arange(self.width)
                self.pad_values = self.history[0].copy()
                self.noise.apply(first, self.noise.read_program(first, self.pad_values))

    def _snapshot_task(self, sync: Callable[[], None] | None) -> Callable[[int], None]:
        """Copy every member's values into the history row of `step`: a closure over what it uses (the
        sampling table calls it at every sampled step)."""
        take, source, rows, count = self.raw.take, self.source, self.history_rows, self.rows
        compiled_snapshot = None if sync else kernel_snapshot(self.raw, source, self.history, None, self._data)
        if compiled_snapshot is not None:
            return compiled_snapshot

        def snapshot(step: int) -> None:
            # mode="clip": indices are valid by construction, and "raise" would buffer the output
            take(source, None, rows[step % count], "clip")

        if sync is None:
            return snapshot
        bring_up_to_date = sync

        def synced(step: int) -> None:
            bring_up_to_date()
            take(source, None, rows[step % count], "clip")

        return synced

    def samples(self, position: int, step: int) -> int:
        """Samples member `position` has taken by `step`: the reset sample plus its needed steps so far."""
        return self.channels[position].schedule.samples_taken(self.phases[position][2], step)

    def _compile(self, phase: int) -> CompiledRead:
        layout = read_layout([laid_out(ch) for ch in self.channels], self.cols, self.rows, phase)
        if self.noise is None:  # gather the families' blocks straight from the history
            compiled = compile_read(self.channels, layout, None, self.rows * self.width)
        else:
            noise = self.noise
            compiled = compile_read(self.channels, layout, lambda source: noise.read_layers(source % self.width), None)
        return compiled._replace(kernel=kernel_read(compiled, compiled.layers, self.flat))

    def read(self, step: int) -> Sequence[np.ndarray]:
        """Every member's observation at `step`: fresh arrays (views of this read's own copy)."""
        phase = step % self.rows
        compiled = self._gathers.get(phase)
        if compiled is None:
            compiled = self._compile(phase)
            # its index, noise positions and work buffer (the noise program's fields are the bank's own), and the
            # compiled program's
            self._gathers.put(phase, compiled,
                              4 * compiled.source.nbytes + (compiled.kernel.nbytes if compiled.kernel else 0))
        if compiled.kernel is not None and (not compiled.noise or step >= self.rows):  # no padding after the noise
            compiled.kernel.run(compiled.source)
            return cut(compiled)
        self.flat.take(compiled.source, None, compiled.gathered, "clip")
        if compiled.noise and self.noise is not None:  # a noise program: the bank has noise
            self._apply_noise(step, compiled, self.noise)
        return finish(compiled)

    def _apply_noise(self, step: int, compiled: CompiledRead, noise: BankNoise) -> None:
        gathered, index = compiled.gathered, compiled.source
        noise.apply(index, compiled.noise)
        if step < self.rows:  # early in an episode: windows reach before the reset sample
            early = self._early.get(step)
            if early is None:
                early = self._early.put(step, np.flatnonzero(index // self.width > step))
            if len(early):
                gathered[early] = self.pad_values.take(index[early] % self.width)


def reuse_key(channels: Sequence[Channel], data: MjData, substeps: int, pad: bool,
              schedules: Sequence[Hashable]) -> tuple[Hashable, ...]:
    """What a bank's layout depends on (`schedules`: each member's schedule settings): equal keys let a reset
    keep the bank (FeatureBank, planned.DrawnBank), with this episode's channels (their keys)."""
    head: tuple[Hashable, ...] = (id(data), substeps, pad)
    return head + tuple(
        (reader.field, reader.index.shape, reader.index.tobytes(), schedule, ch.buffer_size,
         getattr(ch.aggregator, "name", None), ch.has_buffer_dim, id(ch.noise))
        for ch, schedule in zip(channels, schedules) for reader in [field_reader(ch.sampler)])


def _snapshot_rows(phases: list[tuple[int, int, list[int]]], rows: int) -> list[bool]:
    """Per history row (a step mod rows): whether some member samples then ((period, count, phases) each)."""
    snap = [False] * rows
    for period, _, needed in phases:
        for p in needed:
            for t in range(p, rows, period):
                snap[t] = True
    return snap


def bank_member(ch: Channel, kind: type[FixedChannel] | type[DrawnChannel]) -> bool:
    """Whether a channel of schedule type `kind` can join a feature bank (`FeatureBank`, `planned.DrawnBank`):
    an uncorrupted plain feature (`plain_refusal`) whose noise (if any) the bank can apply. A field MuJoCo
    computes on demand (`compute`) is read by its own reader, which fills it first."""
    if not (isinstance(ch, kind) and plain_refusal(ch) is None and getattr(ch.sampler, "compute", None) is None):
        return False
    if ch.noise is None:
        return True
    schedule = ch.schedule if isinstance(ch, FixedChannel) else cast(DrawnChannel, ch).drawn
    size = int(np.prod(ch.shape, dtype=np.int64))
    return (np.dtype(ch.noise.dtype) == np.float64
            and program(program_of(ch.noise, ch.shape, schedule), size) is not None)


def qualifies(ch: Channel) -> TypeGuard[FixedChannel]:
    """Whether a channel can join the fixed-schedule bank (`bank_member`)."""
    return bank_member(ch, FixedChannel)
