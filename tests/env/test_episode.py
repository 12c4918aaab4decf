"""The one episode-end rule that Environment and BatchEnvironment share (`loop.episode`)."""

from __future__ import annotations

import numpy as np

from sensorcfg.loop.episode import episode_end


def test_termination_before_truncation_before_going_on():
    diverged = np.array([True, False, False, False, True])
    terminated = np.array([False, True, False, False, True])
    steps = np.array([1, 1, 5, 2, 9])
    last, discount = episode_end(diverged, terminated, steps, step_limit=5)
    assert last.tolist() == [True, True, True, False, True]
    assert discount.tolist() == [0.0, 0.0, 1.0, 1.0, 0.0]
    last, discount = episode_end(False, False, 10**6, None)  # no time limit: it goes on
    assert not last and discount == 1.0
