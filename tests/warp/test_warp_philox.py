"""The Warp engine's counter-based numbers (`sensorcfg.warp.philox`) on Warp's CPU device against the numpy
reference (`sensorcfg.noise.streams`): Philox words and uniforms bit for bit; normals bit for bit where the
ziggurat takes the first word, within one float64 ulp where its fallback's exp and log enter."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

from sensorcfg.noise import streams  # noqa: E402
from sensorcfg.noise.streams import Draw  # noqa: E402
from sensorcfg.warp import philox  # noqa: E402

DEVICE = "cpu"
wp.set_module_options(philox.MODULE_OPTIONS)  # this module's kernels call philox's functions


@wp.kernel
def _words(counters: wp.array2d[wp.uint32], keys: wp.array2d[wp.uint32],
           out: wp.array2d[wp.uint32]):
    i = wp.tid()
    c = wp.vec4ui(counters[i, 0], counters[i, 1], counters[i, 2], counters[i, 3])
    w = philox.philox4x32(c, wp.vec2ui(keys[i, 0], keys[i, 1]))
    for j in range(4):
        out[i, j] = w[j]


@wp.kernel
def _values(keys: wp.array2d[wp.uint64], samples: wp.array[wp.int64], tag: wp.uint32, size: int,
            is_normal: bool, z: philox.Ziggurat, out: wp.array2d[wp.float64]):
    i, v = wp.tid()
    out[i, v] = philox.value(keys[i, 0], keys[i, 1], samples[i], tag, v, is_normal, z)


def _keys(rng: np.random.Generator, m: int) -> np.ndarray:
    """m episode keys (m, 2) uint64 over all 64 bits of each word."""
    return rng.integers(0, 2**32, size=(m, 4), dtype=np.uint64).reshape(m, 2, 2) @ np.array([1 << 32, 1], np.uint64)


def _samples(rng: np.random.Generator, m: int) -> np.ndarray:
    """Sample indices, small and beyond 2^32 (the counter keeps j mod 2^32)."""
    return np.concatenate([np.arange(m // 2), rng.integers(2**32 - 4, 2**45, size=m - m // 2)]).astype(np.int64)


def test_philox_words_are_the_references_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    n = 4096
    counters = rng.integers(0, 2**32, size=(n, 4), dtype=np.uint64).astype(np.uint32)
    counters[:4] = [[0, 0, 0, 0], [2**32 - 1] * 4, [1, 2, 3, 4], [2**31, 0, 2**31, 0]]
    keys = rng.integers(0, 2**32, size=(n, 2), dtype=np.uint64).astype(np.uint32)
    keys[:2] = [[0, 0], [2**32 - 1] * 2]
    out = wp.empty((n, 4), dtype=wp.uint32, device=DEVICE)
    wp.launch(_words, dim=n, inputs=[wp.array(counters, dtype=wp.uint32, device=DEVICE),
                                     wp.array(keys, dtype=wp.uint32, device=DEVICE)], outputs=[out], device=DEVICE)
    ref = np.stack(streams.philox(list(counters.T), list(keys.T)), axis=1)
    np.testing.assert_array_equal(out.numpy(), ref)


# (stage, lane, size): one value, several counters (size >= 4), a size not a multiple of 4, the largest stage
SHAPES = [(0, 0, 1), (3, 1, 4), (7, 2, 13), (255, 0, 6)]


@pytest.mark.parametrize("stage,lane,size", SHAPES)
def test_uniforms_are_the_references_bit_for_bit(stage: int, lane: int, size: int) -> None:
    rng = np.random.default_rng(stage)
    keys, samples = _keys(rng, 1000), _samples(rng, 1000)
    ref = streams.numbers([Draw(keys, samples, stage, lane, size, False)], compiled=False)[0]
    got = philox.numbers(keys, samples, stage, lane, size, False, device=DEVICE).numpy()
    np.testing.assert_array_equal(got, ref)


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance in float64 units in the last place (both finite, of one sign or zero)."""
    return np.abs(a.view(np.int64) - b.view(np.int64))


def _first_word_accepted(keys: np.ndarray, samples: np.ndarray, stage: int, lane: int, size: int) -> np.ndarray:
    """(m, size) bool: the values the ziggurat takes on their own word (no exp or log)."""
    counter, key, q = streams._counters([Draw(keys, samples, stage, lane, size, True)])
    words = np.stack(streams.philox(counter, key), axis=1).reshape(len(samples), -1)[:, :size]
    hz = words.view(np.int32)
    return np.abs(hz).view(np.uint32) < streams._KN[words & 127]


@pytest.mark.parametrize("stage,lane,size", SHAPES)
def test_normals_are_the_references(stage: int, lane: int, size: int) -> None:
    """Bit for bit where the first word is taken; the fallback's values (its exp and log the device's) within
    one ulp, and there are such values in every shape (about 1 in 36)."""
    rng = np.random.default_rng(100 + stage)
    m = 40000 // size
    keys, samples = _keys(rng, m), _samples(rng, m)
    ref = streams.numbers([Draw(keys, samples, stage, lane, size, True)], compiled=False)[0]
    got = philox.numbers(keys, samples, stage, lane, size, True, device=DEVICE).numpy()
    first = _first_word_accepted(keys, samples, stage, lane, size)
    np.testing.assert_array_equal(got[first], ref[first])
    fallback = ~first
    assert fallback.sum() > 100
    ulps = _ulps(got[fallback], ref[fallback])
    assert ulps.max() <= 1, f"{(ulps > 1).sum()} of {fallback.sum()} fallback values differ by more than 1 ulp"
    tail = (ref[fallback] > streams._R) | (ref[fallback] < -streams._R)
    assert tail.any()  # the exponential tail (a logarithm) is among them


def test_value_function_is_numbers() -> None:
    """`philox.value` (one value, for the engine's own kernels) equals `numbers`, normal and uniform."""
    rng = np.random.default_rng(7)
    keys, samples = _keys(rng, 3000), _samples(rng, 3000)
    for normal in (False, True):
        ref = streams.numbers([Draw(keys, samples, 5, 1, 9, normal)], compiled=False)[0]
        out = wp.empty((3000, 9), dtype=wp.float64, device=DEVICE)
        wp.launch(_values, dim=(3000, 9), inputs=[wp.array(keys, dtype=wp.uint64, device=DEVICE),
                                                  wp.array(samples, dtype=wp.int64, device=DEVICE),
                                                  wp.uint32(philox.tag(5, 1)), 9, normal, philox.ziggurat(DEVICE)],
                  outputs=[out], device=DEVICE)
        assert _ulps(out.numpy(), ref).max() <= 1


def test_out_of_range_draws_are_refused() -> None:
    keys, samples = np.zeros((1, 2), np.uint64), np.zeros(1, np.int64)
    for stage, lane, size in ((256, 0, 1), (0, 3, 1), (0, 0, (1 << 22) + 1)):
        with pytest.raises(ValueError):
            philox.numbers(keys, samples, stage, lane, size, True, device=DEVICE)


def test_modules_calling_the_functions_do_not_fuse_multiply_adds() -> None:
    """The ziggurat's wedge test rounds as numpy only without FMA contraction (CUDA's default)."""
    assert philox.MODULE_OPTIONS["fuse_fp"] is False
    for module in ("sensorcfg.warp.philox", __name__):
        assert wp.get_module(module).options["fuse_fp"] is False
