"""Counter-based random numbers: each sensor's noise streams for one episode. Numpy only.

A sample's numbers depend on the seed, the sensor, the stage and the sample's index only: numpy's Philox
keyed by the sensor's episode key (`draws.sensor_key`), with the counter (position, purpose, block,
stage). Per-sample numbers of sample j come from block j // B (`stages.Context.block`); purpose 1 holds
per-episode draws (bias, scale, a random walk's start, a custom stage's seed).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["Streams", "stream_key"]


class Streams:
    """Counter-based random numbers of one sensor's episode: Philox keyed by the sensor's episode key.

    The counter is (position, purpose, block, stage): purpose 0 holds per-sample numbers (block j // B of
    sample j), purpose 1 the per-episode draws. `at` repositions one generator (no new object per block).
    """

    __slots__ = ("key", "bitgen", "generator", "_state", "_counter")

    def __init__(self, key: np.ndarray):
        self.key = np.asarray(key, np.uint64)
        self.bitgen = np.random.Philox(key=self.key)
        self.generator = np.random.Generator(self.bitgen)
        self._counter = np.zeros(4, np.uint64)
        # a whole state, set at once (faster than reading the state back and editing it)
        self._state: Any = {"bit_generator": "Philox", "state": {"counter": self._counter, "key": self.key},
                            "buffer": np.zeros(4, np.uint64), "buffer_pos": 4, "has_uint32": 0, "uinteger": 0}

    def rekey(self, key: np.ndarray) -> None:
        """A new episode's key (the generator is kept)."""
        self.key = np.asarray(key, np.uint64)
        self._state["state"]["key"] = self.key

    def at(self, stage: int, block: int, purpose: int = 0, key: np.ndarray | None = None) -> np.random.Generator:
        """The generator positioned at the start of (stage, block, purpose) (of another key when given);
        `buffer_pos` 4: no buffered output, the next comes from the counter."""
        counter = self._counter
        counter[0], counter[1], counter[2], counter[3] = 0, purpose, block, stage
        self._state["state"]["key"] = self.key if key is None else key
        self.bitgen.state = self._state
        return self.generator


def stream_key(rng: np.random.Generator | np.random.RandomState) -> np.ndarray:
    """A sensor's 128-bit episode key: four 32-bit words from its stream."""
    if isinstance(rng, np.random.RandomState):
        words = rng.randint(0, 2**32, size=4, dtype=np.uint64)
    else:
        words = rng.integers(0, 2**32, size=4, dtype=np.uint64)
    return np.array([(words[0] << np.uint64(32)) | words[1], (words[2] << np.uint64(32)) | words[3]], np.uint64)
