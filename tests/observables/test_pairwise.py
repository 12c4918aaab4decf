"""numpy adds a 1-D buffer pairwise: one rule (`aggregators.pairwise`) for the bank's groups and families and
the batch's reductions."""

from __future__ import annotations

import numpy as np
import pytest

from sensorcfg.observables.aggregators import AGGREGATORS, FAMILIES, family, pairwise, reduce_stacked


@pytest.mark.parametrize("name", list(AGGREGATORS))
@pytest.mark.parametrize("width", [1, 3])
def test_stacked_buffers_reduce_as_each_alone(name: str, width: int) -> None:
    rng = np.random.default_rng(0)
    window = rng.standard_normal((13, 5, width)) * 10.0 ** rng.integers(-8, 8, (13, 5, width))
    got = reduce_stacked(name, window)
    for i in range(5):
        buffer = window[:, i, :].copy()
        want = AGGREGATORS[name](buffer[:, 0] if width == 1 else buffer)  # a one-value buffer is 1-D to numpy
        np.testing.assert_array_equal(got[i], np.atleast_1d(want))


@pytest.mark.parametrize("name, width, expected", [
    ("sum", 1, True), ("mean", 1, True), ("sum", 2, False), ("median", 1, False), ("max", 1, False)])
def test_pairwise(name: str, width: int, expected: bool) -> None:
    assert pairwise(name, width) is expected


def test_families_leave_out_what_numpy_adds_pairwise() -> None:
    assert family("sum", 13, 1) is None and family("mean", 13, 1) is None
    assert family("sum", 13, 2) == (FAMILIES["sum"], 1)
    assert family("median", 2, 1) == (FAMILIES["sum"], 2)  # a median of two is their mean, added row by row
    assert family("median", 3, 2) is None  # sorted
