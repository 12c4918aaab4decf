"""The one aggregator table: read-only, and each entry's bank reducer is numpy's reduction to the bit."""

from __future__ import annotations

import numpy as np
import pytest

import sensorcfg
from sensorcfg.observables.aggregators import AGGREGATORS, FAMILIES, builtin, family


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
            out = np.full(width + 2, 7.0)  # `reduce(x, out)`: the bank writes into its read's own buffer
            assert np.shares_memory(AGGREGATORS[name].reduce(x, out[1:-1]), out)
            assert np.array_equal(out[1:-1], expected, equal_nan=True) and out[0] == out[-1] == 7.0, (name, buffer, width)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal values, nans in the same places, and zeros of the same sign."""
    return np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a) | np.isnan(a),
                                                                    np.signbit(b) | np.isnan(b))


def _hostile(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Values with signed zeros, infinities and nans among them."""
    x = rng.normal(size=shape)
    specials = np.array([0.0, -0.0, -0.0, np.inf, -np.inf, np.nan, 1.0, -1.0])
    mask = rng.random(shape) < 0.6
    x[mask] = rng.choice(specials, size=int(mask.sum()))
    return x


@pytest.mark.filterwarnings("ignore:invalid value encountered")  # inf - inf
@pytest.mark.parametrize("name", list(AGGREGATORS))
def test_reducers_keep_numpys_signed_zeros(name: str) -> None:
    """numpy adds from 0.0 (a mean of -0.0s is 0.0; so is their median, a mean of the middle values)."""
    rng = np.random.default_rng(2)
    for buffer in range(1, 7):
        for width in (2, 5):
            x = _hostile(rng, (buffer, width))
            assert _same_bits(AGGREGATORS[name].reduce(x), AGGREGATORS[name](x)), (name, x)
            assert _same_bits(AGGREGATORS[name].reduce(x, np.empty(width)), AGGREGATORS[name](x)), (name, x)


@pytest.mark.filterwarnings("ignore:invalid value encountered")
def test_a_family_reduces_mixed_buffers_padded_as_each_alone() -> None:
    """Buffers of one family padded to the longest with the family's pad, reduced once and divided by each
    column's count, give each aggregator's own numpy result, to the bit (signed zeros, infinities, nans)."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        entries = [(str(rng.choice(list(AGGREGATORS))), int(rng.integers(1, 7)), int(rng.integers(2, 4)))
                   for _ in range(4)]
        by_family: dict[str, list[tuple[str, np.ndarray, int]]] = {}
        for name, buffer, width in entries:
            found = family(name, buffer, width)
            if found is None:
                assert name == "median" and buffer > 2
                continue
            fam, divisor = found
            by_family.setdefault(fam.reduce, []).append((name, _hostile(rng, (buffer, width)), divisor))
        for reduce, members in by_family.items():
            pad = FAMILIES[reduce].pad
            longest = max(x.shape[0] for _, x, _ in members)
            block = np.concatenate([np.concatenate([x, np.full((longest - len(x), x.shape[1]), pad)]) for _, x, _ in members],
                                   axis=1)
            counts = np.concatenate([np.full(x.shape[1], float(d)) for _, x, d in members])
            out = np.true_divide(AGGREGATORS[reduce].reduce(block), counts)
            col = 0
            for name, x, _ in members:
                assert _same_bits(out[col:col + x.shape[1]], AGGREGATORS[name](x)), (name, x)
                col += x.shape[1]


def test_one_value_sums_and_means_run_alone() -> None:
    """numpy sums a 1-D buffer pairwise from 8 values on: a one-value sum or mean is never stacked."""
    assert family("sum", 9, 1) is None and family("mean", 3, 1) is None and family("median", 3, 4) is None
    assert family("max", 9, 1) == (FAMILIES["max"], 1) and family("median", 2, 3) == (FAMILIES["sum"], 2)
