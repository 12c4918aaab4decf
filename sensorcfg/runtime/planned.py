"""The feature bank of planned schedules: plain float64 features with drawn intervals or delays, together.

Their samples are planned in rounds (`plan/drawn.py`: every member in one Planner call, a round shortly
before it starts), so which steps snapshot and which history rows each read gathers are known before the
steps run. Per step that some member samples, one `numpy.take` copies every member's values from MjData's
main buffer into a step-indexed history; a read is compiled once (`bank_read.compile_read`; only the rows
it gathers change, an index computed with the round): one gather builds every window, noise is applied to
the gathered values (`BankNoise`: the same numbers as the per-sample pipeline, drawn for the samples taken),
and the reductions run as the fixed-schedule bank's do: all of it one call of the compiled kernel where it is
built (`runtime/read_kernel.py`), except reads early in an episode, whose windows show padding.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from typing import TYPE_CHECKING, NamedTuple, TypeGuard, cast

import numpy as np

from ..plan.bound import aggregator_name, field_reader
from ..plan.drawn import BANK_LONG_ROUND, BANK_RESET_STEPS, Planner, Round, chunk_steps, drawn_bank_rows
from ..plan.layout import Member, read_layout
from ..plan.records import NoiseProgram
from .bank import BankMember, bank_member, reuse_key
from .bank_noise import BankNoise, Layer, ReadOp, ops_of, program_of
from .bank_read import compile_read, cut, finish
from .channels import Channel, DrawnChannel
from .read_kernel import kernel_read, kernel_snapshot

if TYPE_CHECKING:
    from mujoco import MjData

__all__ = ["DrawnBank", "DrawnMember", "joins"]


def joins(ch: Channel) -> TypeGuard[DrawnChannel]:
    """Whether a planned channel can join the bank (`bank.bank_member`)."""
    return bank_member(ch, DrawnChannel)


class _Window(NamedTuple):
    """A member's schedule as `read_layout` reads it (`plan.layout.Windowed`): window position p of a member
    reads history row p."""

    buffer: int
    interval: int = 1

    def window(self, phase: int) -> np.ndarray:
        return np.arange(self.buffer)


class DrawnMember(BankMember):
    """A member of the drawn-schedule bank in the Updater's layout (`BankMember`'s reads, of a `DrawnBank`)."""

    __slots__ = ()


class DrawnBank:
    """All planned float64 features of one Updater: a history of `rows` steps (plus a padding row)."""

    def __init__(self, channels: list[DrawnChannel], data: MjData, substeps: int, pad: bool,
                 view: tuple[np.ndarray, dict[str, int]]):
        self.raw, offsets = view
        self._data = data  # keeps the memory behind `raw` alive
        self.channels, self.n, self.pad = channels, substeps, pad
        self.cols = np.cumsum([0] + [int(np.prod(ch.shape, dtype=int)) for ch in channels])
        self.width = int(self.cols[-1])
        self.source = np.concatenate(
            [offsets[field_reader(ch.sampler).field] + field_reader(ch.sampler).index.ravel()
             for ch in channels]).astype(np.intp)
        self.chunk = chunk_steps([ch.drawn for ch in channels], substeps, BANK_RESET_STEPS)
        # The reset plans one chunk (what its latency pays for), later rounds BANK_LONG_ROUND chunks each (a
        # round costs a fixed part, numpy calls, and a part per step). The history holds a planned round ahead
        # and `span` steps back.
        self.length = BANK_LONG_ROUND * self.chunk
        span = max(ch.drawn.span for ch in channels)
        self.rows = drawn_bank_rows([ch.drawn for ch in channels], substeps)
        # A round is planned this many steps before it starts: every sample its reads show is then still
        # ahead (a read shows samples at most `span` steps old), and so is every sample of the round before
        # whose first read falls in it (at most delay + substeps - 1 steps old).
        self.ahead = min(self.chunk, span + substeps)
        self.next_round = 0  # the start of the next round to plan
        self.history = np.zeros((self.rows, self.width))
        self.flat = self.history.reshape(-1)
        self.history_rows = list(self.history)
        self.needed = bytearray(self.rows)  # per history row: a sample is taken then (the snapshot reads bytes)
        self.need = np.frombuffer(self.needed, bool)  # (the same memory: the rounds mark it with numpy)
        # every member's schedule in one planner, each a "simulation" of its own (one call per round)
        self.planner = Planner([ch.drawn for ch in channels], len(channels))
        self.members_ = self.planner.all  # (the planner's own array: its paths for every simulation)
        self.older = np.zeros(len(channels), np.int64)  # per member: samples of rounds past
        self.recent: list[np.ndarray] = []  # the recent rounds' new samples, as member * _KEY + step (sorted)
        self._compile(channels)
        slots = self.rows // substeps
        self.gathers = np.zeros((slots, len(self.column)), np.intp)
        self.gather_rows, self.slots = list(self.gathers), slots  # (row views: a read indexes a list)
        self.pads: dict[int, np.ndarray] = {}  # read slot -> its gathered values before the reset sample
        self.pad_values = np.zeros(self.width)
        self._noise([program_of(ch.noise, ch.shape, ch.drawn) for ch in channels])
        self.kernel = kernel_read(self.compiled, self.noise_layers, self.flat)  # the read in one call, where built
        self.run = None if self.kernel is None else self.kernel.run
        self._read_step = -1
        self._outputs: Sequence[np.ndarray] = []
        self._pad_program: list[ReadOp] | None = None
        self._pad_work = np.zeros(0)

    def _compile(self, channels: list[DrawnChannel]) -> None:
        """A read compiled once (`bank_read`): only the rows it gathers change, each gathered value is
        (`entry`: its member's window entry in a round's windows, `column`)."""
        stand_ins = [Member(_Window(ch.buffer_size), aggregator_name(ch.aggregator), ch.shape, ch.buffered_shape)
                     for ch in channels]
        layout = read_layout(stand_ins, self.cols, max(ch.buffer_size for ch in channels), 0)
        self.compiled = compile_read(stand_ins, layout, None, None)
        template = self.compiled.source  # window position * width + column, in the order of the work buffer
        buffers = np.array([ch.buffer_size for ch in channels])
        member = np.searchsorted(self.cols, template % self.width, side="right") - 1
        # in a round's windows (member, read, largest buffer): a member reads the last `buffer` entries
        entry = member * self.planner.buffer + self.planner.buffer - buffers[member] + template // self.width
        self.column = template % self.width
        self.entry_member, self.entry_slot = np.divmod(entry, self.planner.buffer)

    def _noise(self, noises: list[NoiseProgram | None]) -> None:
        """The members' noise (`BankNoise`), drawn with the rounds for the samples they take (random walks a
        chunk at a time), and the read's noise program."""
        self.noise: BankNoise | None = None
        self.noise_program: list[ReadOp] = []
        self.noise_layers: list[Layer] = []
        self.walkers: set[int] = set()
        self.drawing: list[int] = []  # noisy members drawn per sample taken
        if not any(noise is not None and noise.steps for noise in noises):
            return
        strides = [_Stride(ch.shape, ch.drawn.stride) for ch in self.channels]
        offsets_in_chunk = [np.arange(0, self.chunk, s.interval, dtype=np.intp) for s in strides]
        self.noise = BankNoise(strides, noises, self.cols, self.rows, self.chunk, offsets_in_chunk)
        programs = self.noise.programs
        walks = [self.noise.walks(i) for i in range(len(programs))]
        self.walkers = {i for i, ops in enumerate(programs) if ops and walks[i]}
        self.drawing = [i for i, ops in enumerate(programs) if ops and not walks[i]]
        self.noise_layers = self.noise.read_layers(self.column)
        self.noise_program = ops_of(self.noise_layers, self.compiled.gathered)

    @staticmethod
    def key(channels: list[DrawnChannel], data: MjData, substeps: int, pad: bool) -> tuple[Hashable, ...]:
        """What the bank's layout depends on: equal keys let a reset reuse the bank (`rebind`)."""
        return reuse_key(channels, data, substeps, pad, [ch.drawn for ch in channels])

    def rebind(self, channels: list[DrawnChannel]) -> None:
        """Take this episode's channels (same settings as the ones the bank was built for)."""
        self.channels = channels

    def members(self) -> list[DrawnMember]:
        return [DrawnMember(self, i, ch) for i, ch in enumerate(self.channels)]

    # -- episodes and rounds ----------------------------------------------------------------------

    def start(self) -> None:
        """The reset sample (step 0), padding, and the first rounds."""
        self.need[:] = False
        self.older[:] = 1  # the reset sample
        self.recent = []
        self.raw.take(self.source, None, self.history[0], "clip")
        if self.noise is not None:
            # noise with the rounds' samples (the reset sample's with the first)
            self.noise.start([ch.key for ch in self.channels], fill=False)
            self.noise.fill(0, self.walkers)  # (random walks a chunk at a time)
        self.pads.clear()
        self._store(self.planner.start(self.members_, [ch.key for ch in self.channels]), 0, 0)
        self._draw_round(0, self.chunk)
        if self.pad:
            self.pad_values = self.history[0].copy()
            if self.noise is not None:  # padding repeats the first sample as delivered: with its noise
                self._pad_noise()
        else:
            self.pad_values = np.zeros(self.width)
        self.next_round = self.chunk
        self._read_step = -1  # a read at step 0 of this episode is not the last episode's (two resets in a row)
        self.draw_ahead(0)

    def _pad_noise(self) -> None:
        """The reset sample's noise on `pad_values` (row 0 of the history): a read program of every column,
        made once on a work row of its own (its layers hold this episode's draws in place)."""
        noise = cast(BankNoise, self.noise)
        if self._pad_program is None:
            self._pad_work = np.zeros(self.width)
            self._pad_program = noise.read_program(np.arange(self.width), self._pad_work)
        self._pad_work[:] = self.pad_values
        noise.apply(np.arange(self.width), self._pad_program)
        self.pad_values = self._pad_work.copy()

    def draw_ahead(self, step: int) -> None:
        """Before the control step after `step`: plan the next round (and draw its noise) once it is
        `ahead` steps away."""
        if step + self.ahead >= self.next_round:
            self._draw_round(self.next_round, self.length)
            self.next_round += self.length

    def _draw_round(self, base: int, length: int) -> None:
        round_ = self.planner.round(self.members_, length)
        self._store(round_, base // self.n + 1, length // self.n)
        self.need[round_.take_step % self.rows] = True
        if len(self.recent) == 3:  # rounds that ended before the current step
            self.older += np.bincount(self.recent.pop(0) // _KEY, minlength=len(self.channels))
        # a sample is shown first in its own round or the next: each counted once
        self.recent.append(_new(round_.take_sim * _KEY + round_.take_step,
                                self.recent[-1] if self.recent else _ZERO[:0]))
        if self.noise is not None:  # the noise of the samples this round takes first
            for chunk in range(base, base + length, self.chunk) if base and self.walkers else ():
                self.noise.fill(chunk, self.walkers)  # (the reset drew the first chunk's random walks)
            keys = self.recent[-1]
            bounds = keys.searchsorted(np.arange(len(self.channels) + 1) * _KEY)
            first = _ZERO if base == 0 else _ZERO[:0]  # the first round draws the reset sample's too
            self.noise.fill_samples([(i, np.concatenate((first, keys[bounds[i]:bounds[i + 1]] - i * _KEY)))
                                     for i in self.drawing if bounds[i + 1] > bounds[i] or base == 0])

    def samples(self, position: int, step: int) -> int:
        """Samples member `position` has taken by `step` (the reset sample included)."""
        bounds = np.array([position * _KEY, position * _KEY + step + 1])  # keys of steps 0..step
        return int(self.older[position]) + sum(int(np.diff(keys.searchsorted(bounds))[0]) for keys in self.recent)

    def _store(self, round_: Round, first: int, count: int) -> None:
        """Gather indices of a round's reads (read slots first .. first + count, or the reset read)."""
        entries = round_.windows[self.entry_member, :, self.entry_slot].T  # (read, gathered value)
        slots = (first + np.arange(max(count, 1))) % self.slots
        # (padding, -1, gathers any row: a read that shows it writes the pad values over it)
        self.gathers[slots] = entries % self.rows * self.width + self.column
        for slot in [slot for slot in self.pads if (slot - first) % self.slots < max(count, 1)]:
            del self.pads[slot]  # a slot of an earlier round
        padded = entries < 0  # only reads early in an episode show padding
        if padded.any():
            read, value = np.nonzero(padded)
            for r, values in zip(*_runs(read, value)):
                self.pads[int(slots[r])] = values

    # -- the physics loop -------------------------------------------------------------------------

    def due(self, step: int) -> bool:
        return bool(self.need[step % self.rows])

    def snapshot_task(self) -> Callable[[int], None]:
        """The Updater's task at every step: copy every member's values into the history row of `step` when
        some member samples then (a closure over what it uses)."""
        compiled_snapshot = kernel_snapshot(self.raw, self.source, self.history, self.needed, self._data)
        if compiled_snapshot is not None:
            return compiled_snapshot
        need, take, source, rows, count = self.needed, self.raw.take, self.source, self.history_rows, self.rows

        def snapshot(step: int) -> None:
            row = step % count
            if need[row]:
                need[row] = 0
                take(source, None, rows[row], "clip")  # mode="clip": no buffered output (indices are valid)

        return snapshot

    def read(self, step: int) -> Sequence[np.ndarray]:
        """Every member's observation at `step` (computed once per step)."""
        if step == self._read_step:
            return self._outputs
        slot = (step // self.n) % self.slots
        pads = self.pads.get(slot)
        if pads is None and self.run is not None:  # the gather, noise and reductions in one call
            self.run(self.gather_rows[slot])
            outputs = cut(self.compiled)
        elif self.kernel is not None:  # (padding, early in an episode: written between the two calls)
            index = self.gather_rows[slot]
            self.kernel.noised(index)
            self._pad(cast(np.ndarray, pads))
            self.kernel.reduced(index)
            outputs = cut(self.compiled)
        else:
            outputs = self._read_numpy(self.gather_rows[slot], pads)
        self._read_step, self._outputs = step, outputs
        return outputs

    def _read_numpy(self, index: np.ndarray, pads: np.ndarray | None) -> Sequence[np.ndarray]:
        """`read` in numpy calls (the reference; also reads whose windows show padding, early in an episode)."""
        compiled = self.compiled
        gathered = compiled.gathered
        self.flat.take(index, None, gathered, "clip")
        if self.noise is not None:
            self.noise.apply(index, self.noise_program)
        if pads is not None:
            self._pad(pads)
        return finish(compiled)

    def _pad(self, pads: np.ndarray) -> None:
        """Padding over the gathered values at `pads` (after their noise: it is the first sample's as delivered)."""
        self.compiled.gathered[pads] = self.pad_values.take(self.column[pads])


class _Stride(NamedTuple):
    """What BankNoise needs of a member: its sample shape and the steps between its sample indices."""

    shape: tuple[int, ...]
    interval: int


def _runs(keys: np.ndarray, values: np.ndarray) -> tuple[list[int], list[np.ndarray]]:
    """The distinct `keys` (sorted) and the `values` of each."""
    cut = np.flatnonzero(keys[1:] != keys[:-1]) + 1
    return keys[np.concatenate(([0], cut))].tolist(), np.split(values, cut)


def _new(steps: np.ndarray, before: np.ndarray) -> np.ndarray:
    """The distinct `steps` (sorted) not in `before` (sorted, distinct)."""
    steps = np.sort(steps)
    steps = steps[np.concatenate(([True], steps[1:] != steps[:-1]))]  # distinct (np.unique hashes, then sorts)
    if not len(before) or not len(steps):
        return steps
    at = np.searchsorted(before, steps)
    new: np.ndarray = steps[before.take(at, mode="clip") != steps]
    return new


_ZERO = np.zeros(1, np.intp)
_KEY = 1 << 40  # member * _KEY + step: a sample taken, as one sortable number
