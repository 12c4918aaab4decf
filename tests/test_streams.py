"""The counter-based numbers (`sensorcfg.noise.streams`): Philox4x32-10 as published, random access, and
normals and uniforms with the right distributions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensorcfg.noise.streams import Draw, numbers, philox

# Random123's known-answer vectors for philox4x32-10: (counter, key, result)
KNOWN = [
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]


def test_philox_gives_the_published_answers_one_at_a_time_and_together():
    counters = [np.array([c[i] for c, _, _ in KNOWN], np.uint32) for i in range(4)]
    keys = [np.array([k[i] for _, k, _ in KNOWN], np.uint32) for i in range(2)]
    together = philox(counters, keys)
    for n, (counter, key, expected) in enumerate(KNOWN):
        alone = philox([np.array([w], np.uint32) for w in counter], [np.array([w], np.uint32) for w in key])
        assert [int(w[0]) for w in alone] == list(expected)
        assert [int(w[n]) for w in together] == list(expected)


KEYS = np.random.default_rng(5).integers(0, 2**63, (6, 2)).astype(np.uint64)


@pytest.mark.parametrize("normal", [True, False], ids=["normals", "uniforms"])
def test_a_samples_numbers_do_not_depend_on_what_else_is_drawn(normal):
    samples = np.arange(40)
    keys = np.repeat(KEYS, 40 // len(KEYS) + 1, axis=0)[:40]
    many = numbers([Draw(keys, samples, 2, 0, 7, normal), Draw(keys[:3], samples[:3], 5, 1, 3, not normal)])
    for j in (0, 13, 39):
        alone = numbers([Draw(keys[j:j + 1], samples[j:j + 1], 2, 0, 7, normal)])[0]
        assert np.array_equal(alone[0], many[0][j])
    # the first values of a sample are the same whatever its size (four values per counter)
    assert np.array_equal(numbers([Draw(keys, samples, 2, 0, 5, normal)])[0], many[0][:, :5])


def test_keys_stages_lanes_and_samples_give_different_numbers():
    base = Draw(KEYS[:1], np.array([3]), 1, 0, 8, True)
    first = numbers([base])[0]
    for other in (base._replace(keys=KEYS[1:2]), base._replace(stage=2), base._replace(lane=1),
                  base._replace(samples=np.array([4]))):
        assert not np.any(numbers([other])[0] == first)


def test_normals_are_standard_normal_and_uniforms_uniform():
    n = 200_000
    keys = np.repeat(KEYS[:1], n // 20, axis=0)
    z, u = numbers([Draw(keys, np.arange(n // 20), 0, 0, 20, True), Draw(keys, np.arange(n // 20), 1, 0, 20, False)])
    z, u = z.ravel(), u.ravel()
    assert abs(z.mean()) < 0.01 and abs(z.std() - 1) < 0.01
    for t in (1.0, 2.0, 3.0):  # tail frequencies, against 5 standard errors
        p = math.erfc(t / math.sqrt(2))
        assert abs(np.mean(np.abs(z) > t) - p) < 5 * math.sqrt(p * (1 - p) / n)
    zs = np.sort(z)[::50]
    cdf = 0.5 * np.array([math.erfc(-x / math.sqrt(2)) for x in zs])
    assert np.max(np.abs(cdf - (np.arange(zs.size) * 50 + 1) / n)) < 1.63 / math.sqrt(n)  # KS at 1%
    assert u.min() >= 0 and u.max() < 1 and abs(u.mean() - 0.5) < 0.005
    assert np.all(np.abs(np.histogram(u, 10, (0, 1))[0] - n / 10) < 5 * math.sqrt(n / 10))
