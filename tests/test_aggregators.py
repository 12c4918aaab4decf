"""The one aggregator table: read-only, and each entry's bank reducer is numpy's reduction to the bit."""

from __future__ import annotations

import numpy as np
import pytest

import sensorcfg
from sensorcfg.observables.aggregators import AGGREGATORS, builtin


def test_the_table_is_read_only() -> None:
    with pytest.raises(TypeError):
        sensorcfg.AGGREGATORS["mode"] = AGGREGATORS["mean"]  # type: ignore[index]
    assert builtin(AGGREGATORS["mean"]) is AGGREGATORS["mean"] and builtin(np.mean) is None


@pytest.mark.parametrize("name", list(AGGREGATORS))
def test_each_reducer_is_numpys_reduction(name: str) -> None:
    rng = np.random.default_rng(0)
    for buffer in range(1, 12):
        for width in (1, 3, 17):
            x = rng.normal(size=(buffer, width)) * 10.0 ** rng.integers(-3, 4, size=(buffer, width))
            if buffer > 2:
                x[rng.integers(buffer), 0] = np.nan
            expected = AGGREGATORS[name](x)
            assert np.array_equal(AGGREGATORS[name].reduce(x), expected, equal_nan=True), (name, buffer, width)
