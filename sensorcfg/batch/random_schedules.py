"""Random intervals and delays across simulations: each simulation's schedule, planned in blocks.

A channel with drawn intervals or delays decides when it samples and which samples a read sees from its
draws alone, never from the values. So each simulation runs the single-simulation `RandomChannel` itself
(dm_control's planning, draw order and dropping, against that simulation's own episode random state) on
sample *codes* instead of values (code 0: a zero fill, code s + 1: the sample taken at step s), `block`
control steps ahead. The per-step path then only indexes the recorded plan: which simulations sample at
each physics step, and which steps each read gathers. A refill, once per `block` control steps of a
simulation, is the only loop over simulations.

Planning ahead must not move the random state past an episode's end: a reset of simulation i restores its
random state and channels as they were at the start of the block and replays the control steps its
episode really ran, so the next episode draws exactly what a single simulation would.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..runtime.channels import RandomChannel

__all__ = ["Timelines"]

BLOCK = 32  # control steps planned per refill


class _Plan:
    """One simulation's shadow channels and what they planned for the current block."""

    __slots__ = ("channels", "state", "saved", "base", "step")

    def __init__(self) -> None:
        self.channels: list[RandomChannel] = []
        self.state: Any = None  # the random state at the block's start
        self.saved: list[RandomChannel] = []  # the channels at the block's start
        self.base = 0  # episode control step of the block's first
        self.step = [0]  # the physics step being sampled (the samplers read it)


class Timelines:
    """The random-schedule channels of a batch: per simulation, sample times and read windows."""

    def __init__(self, specs: Sequence[tuple[str, RandomChannel, Callable[[Any], tuple[Any, Any]]]], nsim: int,
                 n: int, pad: bool, block: int = BLOCK):
        """`specs`: (label, template channel, make_drawers(random_state) -> (interval, delay) callables)."""
        self.specs = list(specs)
        self.nsim, self.n, self.pad, self.block = nsim, n, pad, block
        nc = len(self.specs)
        self.taken = np.zeros((nsim, block, nc, n), bool)  # [sim, block step, channel, substep]
        self.windows = [np.zeros((nsim, block, ch.buffer_size), np.int64) for _, ch, _ in self.specs]
        self.cursor = np.full(nsim, block, np.intp)  # block position of each simulation's next control step
        self.last = [np.zeros((nsim, ch.buffer_size), np.int64) for _, ch, _ in self.specs]  # the latest reads
        self.plans = [_Plan() for _ in range(nsim)]
        self.states: list[np.random.RandomState | None] = [None] * nsim

    def _shadow(self, plan: _Plan, template: RandomChannel, drawers: tuple[Any, Any]) -> RandomChannel:
        step = plan.step
        return RandomChannel(template.name, lambda: step[0] + 1, None, (), np.dtype(np.int64),
                             template.buffer_size, False, self.pad, self.n, None, False, None,
                             interval=drawers[0], delay=drawers[1])

    def start(self, i: int, random_state: np.random.RandomState) -> None:
        """Simulation i's episode starts: its channels' reset draws, in observable order, then a block."""
        plan = self.plans[i] = _Plan()
        self.states[i] = random_state
        plan.channels = [self._shadow(plan, template, make(random_state)) for _, template, make in self.specs]
        for ch in plan.channels:
            ch.start(0)
        for ci, ch in enumerate(plan.channels):  # the reset observation's read
            self.last[ci][i] = ch.read(0)
        self._refill(i, 0)

    def finish(self, i: int, control_steps: int) -> None:
        """Simulation i's episode ended after `control_steps`: rewind its random state to that point."""
        plan, state = self.plans[i], self.states[i]
        if state is None or not plan.channels:
            return
        state.set_state(plan.state)
        plan.channels = plan.saved
        plan.saved = copy.deepcopy(plan.channels)
        for c in range(plan.base, control_steps):
            self._advance(plan, c, None, 0)

    def _advance(self, plan: _Plan, c: int, i: int | None, j: int) -> None:
        """Control step c of the episode: plan, sample, read, as the Updater does (recorded when i is given)."""
        n, t = self.n, c * self.n
        for ch in plan.channels:
            ch.plan(t)
        for k in range(1, n + 1):
            plan.step[0] = t + k
            for ci, ch in enumerate(plan.channels):
                if ch.due(t + k):
                    ch.sample(t + k)
                    if i is not None:
                        self.taken[i, j, ci, k - 1] = True
        for ci, ch in enumerate(plan.channels):
            window = ch.read(t + n)
            if i is not None:
                self.windows[ci][i, j] = window

    def _refill(self, i: int, base: int) -> None:
        plan, state = self.plans[i], self.states[i]
        plan.state = state.get_state()  # type: ignore[union-attr]
        plan.saved = copy.deepcopy(plan.channels)
        plan.base = base
        self.taken[i] = False
        for j in range(self.block):
            self._advance(plan, base + j, i, j)
        self.cursor[i] = 0

    def ensure(self, sims: np.ndarray, control_steps: np.ndarray) -> None:
        """Plan another block for the simulations in `sims` whose block is used up."""
        used = sims[self.cursor[sims] == self.block]
        for i in used:
            self._refill(int(i), int(control_steps[i]))

    def taken_now(self) -> np.ndarray:
        """Which channels sample at each substep of this control step, (nsim, channels, n) (valid for the
        simulations that `ensure` prepared)."""
        j = np.minimum(self.cursor, self.block - 1)
        return self.taken[np.arange(self.nsim), j]

    def advance(self, sims: np.ndarray) -> None:
        """The control step ran for `sims`: their reads are this step's windows."""
        j = self.cursor[sims]
        for last, windows in zip(self.last, self.windows):
            last[sims] = windows[sims, j]
        self.cursor[sims] = j + 1
