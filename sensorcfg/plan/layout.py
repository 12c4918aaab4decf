"""What the reads at one phase of a step-indexed history gather, and how they cut and reduce it: the read layout.

A history holds one row per step (modulo `rows`) of every member's values side by side (member i in columns
`cols[i]:cols[i + 1]`). The reads of one phase gather one flat index (row * width + column) and cut it into
plain outputs (reshaped) and reduction groups (members with one built-in aggregator and buffer, stacked into
(buffer, group width) and reduced once). The one home of that layout: the plan's read table
(`plan/compile.py`), the feature banks (`runtime/bank.py`, `runtime/planned.py`) and the batch's reads.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, NamedTuple, Protocol

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from ..observables.aggregators import AGGREGATORS, pairwise

__all__ = ["GroupMember", "Member", "PlainRead", "ReadLayout", "ReductionGroup", "Windowed", "read_layout"]

IntArray = NDArray[np.intp]
if TYPE_CHECKING:
    Span = slice[int, int, None]  # a run of positions


class Windowed(Protocol):
    """A member's schedule as the layout reads it: sample k is at step `k * interval`, the read at a step sees
    samples `window(step)` (a `plan.schedule.Schedule`; a drawn bank's stand-in: position p reads row p)."""

    @property
    def interval(self) -> int: ...
    @property
    def buffer(self) -> int: ...
    def window(self, read_step: int) -> NDArray[np.int64]: ...


class Member(NamedTuple):
    """What `read_layout` reads of a member: its schedule, its built-in aggregator's name (None: not reduced)
    and its shapes (of a sample, and of a read before any reduction)."""

    schedule: Windowed
    aggregator: str | None
    shape: tuple[int, ...]
    buffered_shape: tuple[int, ...]


class PlainRead(NamedTuple):
    """A member read without reduction: `gathered[part]` reshaped to `shape`."""

    member: int
    part: Span  # of the gather (of one simulation's read in the batch's layout)
    shape: tuple[int, ...]


class GroupMember(NamedTuple):
    """A member of a reduction group: columns `columns` of the reduced group, reshaped to `shape`."""

    member: int
    columns: Span
    shape: tuple[int, ...]


class ReductionGroup(NamedTuple):
    """Members with one aggregator and buffer size: `gathered[part]` as (buffer, group width), reduced once."""

    part: IntArray  # positions in the gather (in one simulation's read in the batch's layout)
    block: tuple[int, int]
    members: list[GroupMember]
    aggregator: str  # the built-in's name (`observables.aggregators`)

    @property
    def reduce(self) -> Callable[[npt.NDArray[np.float64]], npt.NDArray[np.float64]]:
        """The built-in's reduction (`AGGREGATORS`)."""
        return AGGREGATORS[self.aggregator].reduce


class ReadLayout(NamedTuple):
    """One `gather` index (row * width + column of the history) and how to cut and reduce what it gathers."""

    gather: IntArray
    groups: list[ReductionGroup]
    plain: list[PlainRead]


def read_layout(members: Sequence[Member], cols: IntArray, rows: int, phase: int) -> ReadLayout:
    """For reads at steps = phase (mod rows) of a step-indexed history of `rows` rows of `cols[-1]` values,
    member i in columns cols[i]:cols[i+1]: one flat gather index (row * width + column), and how to cut
    and reduce it (`ReadLayout`)."""
    width = int(cols[-1])
    # per group key (aggregator, buffer, the member when it is reduced alone (else -1)); None: not reduced
    blocks: dict[tuple[str, int, int] | None, list[tuple[int, IntArray]]] = {}
    for i, member in enumerate(members):
        schedule = member.schedule
        steps = schedule.interval * schedule.window(phase)
        block = (steps % rows)[:, None] * width + np.arange(cols[i], cols[i + 1])
        key = None
        if member.aggregator is not None:
            name = member.aggregator
            key = (name, schedule.buffer, i if pairwise(name, int(cols[i + 1] - cols[i])) else -1)
        blocks.setdefault(key, []).append((i, block))
    parts: list[IntArray] = []
    groups: list[ReductionGroup] = []
    plain: list[PlainRead] = []
    offset = 0
    for key, entries in blocks.items():
        if key is None:
            for i, block in entries:
                plain.append(PlainRead(i, slice(offset, offset + block.size), members[i].buffered_shape))
                parts.append(block.ravel())
                offset += block.size
            continue
        stacked = np.concatenate([block for _, block in entries], axis=1)  # (buffer, group width)
        grouped: list[GroupMember] = []
        col = 0
        for i, block in entries:
            grouped.append(GroupMember(i, slice(col, col + block.shape[1]), members[i].shape))
            col += block.shape[1]
        groups.append(ReductionGroup(np.arange(offset, offset + stacked.size, dtype=np.intp),
                                     (stacked.shape[0], stacked.shape[1]), grouped, key[0]))
        parts.append(stacked.ravel())
        offset += stacked.size
    return ReadLayout(np.concatenate(parts).astype(np.intp), groups, plain)
