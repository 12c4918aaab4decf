"""A planning round of the drawn schedules (`runtime/drawn.py`, `Planner`): the reset round in closed form
equals the general round at length 0."""

from __future__ import annotations

import numpy as np
import pytest

from sensorcfg.draws import ChoiceSteps, UniformSteps
from sensorcfg.plan.drawn import Drawn, Planner


def _schedules(rng: np.random.Generator, count: int, substeps: int) -> list[Drawn]:
    intervals = [1, 3, UniformSteps(1, 4), ChoiceSteps((2, 7)), UniformSteps(1, 2)]  # planned: at least 1
    delays = [0, 2, UniformSteps(0, 3), UniformSteps(1, 40), ChoiceSteps((1, 9), (0.7, 0.3))]
    return [Drawn(intervals[int(rng.integers(len(intervals)))], delays[int(rng.integers(len(delays)))],
                  int(rng.integers(1, 5)), substeps, bool(rng.random() < 0.2)) for _ in range(count)]


def _columns(flight: np.ndarray) -> list[tuple[int, ...]]:
    return sorted(map(tuple, flight.T.tolist()))


@pytest.mark.parametrize("seed", range(8))
def test_the_reset_round_in_closed_form_is_the_general_round(seed, monkeypatch) -> None:
    """`Planner.start` plans the reset read in closed form (`_reset_round`): the same windows, samples taken,
    tails, samples in flight (as a set: their order changes nothing) and positions as `round(sims, 0)`, for
    every simulation and for subsets restarted between rounds."""
    rng = np.random.default_rng(300 + seed)
    schedules = _schedules(rng, int(rng.integers(1, 7)), int(rng.integers(1, 6)))
    closed, general = Planner(schedules, len(schedules)), Planner(schedules, len(schedules))
    everyone = np.arange(len(schedules))
    keys = rng.integers(0, 2**63, (len(schedules), 2), dtype=np.uint64)

    def start(planner: Planner, sims: np.ndarray, k: np.ndarray, closed_form: bool) -> object:
        if not closed_form:
            monkeypatch.setattr(planner, "_reset_round", lambda s: planner.round(s, 0))
        out = planner.start(planner.all if sims is everyone else sims, k)
        monkeypatch.undo()
        return out

    for r in range(6):
        sims = everyone if r == 0 or rng.random() < 0.3 else np.sort(
            rng.choice(everyone, int(rng.integers(1, len(everyone) + 1)), replace=False))
        shifted = keys[sims] + np.uint64(r)
        a, b = start(closed, sims, shifted, True), start(general, sims, shifted, False)
        for x, y in zip(a, b):
            assert np.array_equal(x, y) and x.shape == y.shape
        assert _columns(closed.flight) == _columns(general.flight)
        for name in ("tail", "end", "next", "last", "keys"):
            assert np.array_equal(getattr(closed, name), getattr(general, name)), name
        length = schedules[0].substeps * int(rng.integers(1, 40))
        for x, y in zip(closed.round(everyone, length), general.round(everyone, length)):
            assert np.array_equal(x, y)

