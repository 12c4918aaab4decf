"""Random intervals and delays across simulations: each simulation's schedule, planned in rounds.

A sensor with drawn intervals or delays decides when it samples and which samples a read sees from its
draws alone, never from the values. The batch plans them from the plan's `DrawnTiming`s with the planner of
the stream rule (`plan/drawn.py`, `Drawn.of`: each simulation's sensor key), vectorised across the simulations
that start a round together, one round ahead (rounds of at least `plan.drawn.ROUND_STEPS` steps). The
per-step path only indexes the rings: which simulations sample at each substep, and which steps each read
gathers, as codes (0: a zero fill, s + 1: the sample of step s since reset). Planning draws from
counter-based streams, never from an episode's random state, so an episode that ends early needs no rewinding.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from ..plan import DrawnTiming, SuitePlan
from ..plan.drawn import ROUND_STEPS, Drawn, Planner, Round, chunk_steps

__all__ = ["Timelines"]


class Timelines:
    """The random-schedule channels of a batch: per simulation, sample times and read windows."""

    def __init__(self, plan: SuitePlan):
        """The drawn-schedule sensors of `plan` (after its fixed ones, in history order), planned from their
        `DrawnTiming` records; `labels`: their names (which key their schedules)."""
        records = plan.sensors[plan.nfixed:]
        self.labels = [record.name for record in records]
        nsim, substeps = plan.nsim, plan.substeps
        self.nsim, self.substeps, self.pad = nsim, substeps, plan.pad_with_initial_value
        drawn = [Drawn.of(cast(DrawnTiming, record.timing), substeps) for record in records]
        self.chunk = chunk_steps(drawn, substeps, ROUND_STEPS) if drawn else substeps
        self.slots = 3 * self.chunk // substeps  # control steps held by the rings: two rounds ahead
        nc = len(drawn)
        self.taken = np.zeros((nsim, self.slots, nc, substeps), bool)  # [sim, control step, channel, substep]
        self.windows = [np.zeros((nsim, self.slots, d.buffer), np.int64) for d in drawn]
        self.last = [np.zeros((nsim, d.buffer), np.int64) for d in drawn]  # the latest reads' codes
        self.planners = [Planner(d, nsim) for d in drawn]
        self.control = np.zeros(nsim, np.int64)  # each simulation's control steps since its reset

    def _codes(self, windows: np.ndarray) -> np.ndarray:
        return np.where(windows >= 0, windows + 1, 1 if self.pad else 0)

    def start(self, sims: np.ndarray, keys: np.ndarray) -> None:
        """Episodes of simulations `sims` start: `keys` (channel, simulation, 2) their sensors' episode keys
        (`draws.sensor_key`), which key every schedule."""
        self.taken[sims] = False
        self.control[sims] = 0
        for c, planner in enumerate(self.planners):
            first = planner.start(sims, keys[c])
            self.last[c][sims] = self._codes(first.windows[:, 0])
        self._draw_round(sims, np.zeros(len(sims), np.int64))
        self._draw_round(sims, np.full(len(sims), self.chunk, np.int64))

    def _draw_round(self, sims: np.ndarray, base: np.ndarray) -> None:
        """The round (base, base + chunk] of simulations `sims`, into the rings."""
        n = self.substeps
        per_round = self.chunk // n
        slots = (base[:, None] // n + np.arange(per_round)) % self.slots  # control steps of the round's reads
        self.taken[sims[:, None], slots] = False
        for c, planner in enumerate(self.planners):
            round_: Round = planner.round(sims, self.chunk)
            self.windows[c][sims[:, None], slots] = self._codes(round_.windows)
            steps = round_.take_step
            control = (steps - 1) // n  # sample at step s is taken in control step (s - 1) // n
            self.taken[sims[round_.take_sim], control % self.slots, c, (steps - 1) % n] = True

    def ensure(self, sims: np.ndarray, control_steps: np.ndarray) -> None:
        """Before the control step: simulations at a round's start plan the round after next."""
        steps = control_steps[sims] * self.substeps
        due = sims[(steps > 0) & (steps % self.chunk == 0)]
        if due.size:
            self._draw_round(due, control_steps[due] * self.substeps + self.chunk)

    def taken_now(self) -> np.ndarray:
        """Which channels sample at each substep of this control step, (nsim, channels, substeps)."""
        return self.taken[np.arange(self.nsim), self.control % self.slots]

    def advance(self, sims: np.ndarray) -> None:
        """The control step ran for `sims`: their reads are this step's windows."""
        c = self.control[sims] + 1
        for last, windows in zip(self.last, self.windows):
            last[sims] = windows[sims, (c - 1) % self.slots]
        self.control[sims] = c
