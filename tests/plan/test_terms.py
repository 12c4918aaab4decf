"""A noise program's additive terms made from the plan alone (`plan.terms`) are the per-sample stages' numbers."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import TypeAdapter

from sensorcfg.config.noise import NoiseStage
from sensorcfg.noise import build_noise, stages
from sensorcfg.noise.streams import MAX_TERMS, numbers
from sensorcfg.plan import FixedTiming, episode
from sensorcfg.plan import terms as tm
from sensorcfg.plan.noise import program

STAGES = TypeAdapter(list[NoiseStage])
SHAPE = (2, 3)
PIPELINES = [
    [{"type": "gaussian", "std": 0.1}],
    [{"type": "gaussian", "mean": [0.5, -1, 0], "std": 0.1}],
    [{"type": "uniform", "low": -1, "high": [1, 2, 3]}],
    [{"type": "outlier", "p": 0.3, "scale": 2.0}],
    [{"type": "bias", "std": 1.0}, {"type": "gaussian", "std": 0.1}, {"type": "uniform", "low": 0, "high": 1}],
    [{"type": "gaussian", "std": 0.2}, {"type": "outlier", "p": 0.5, "scale": 3}, {"type": "bias", "mean": 0.1}],
    [{"type": "random_walk", "std": 0.3, "correlation_time": "20ms"}],
]
TIMING = FixedTiming(1, 0, 1, 1, np.ones((1, 1), bool), False)


@pytest.mark.parametrize("configs", PIPELINES)
def test_a_terms_values_are_the_stages_numbers(configs: list[dict]) -> None:
    pipeline = build_noise(STAGES.validate_python(configs), SHAPE, np.dtype(np.float64), 0.002)
    key = np.array([12345, 678], np.uint64)
    pipeline.reset(key, 1)
    noise = program(pipeline, SHAPE, 1, TIMING)
    assert noise is not None
    drawn = episode(noise, key)
    samples = np.array([0, 1, 7, 1000, 5], np.int64)
    keys = np.repeat(key[None], samples.size, axis=0)
    terms = [(q, term) for q, term in tm.terms(noise, 6) if term is not None]
    runtime = [s for s in pipeline.stages if isinstance(s, stages._Additive)]
    assert len(terms) == len(runtime)  # one term per fused or additive stage, in order
    for (q, term), stage in zip(terms, runtime):
        biases = [drawn[s.stream].values for s in term.steps if s.stage == "bias"]
        ours = tm.values(term, numbers(tm.draws(term, samples, keys)), samples.size, biases)
        theirs = stage.shape(numbers(stage.draws(samples, keys)), samples.size)
        np.testing.assert_array_equal(ours, np.asarray(theirs).reshape(samples.size, -1))
        assert ours.dtype == np.float64
        affine = tm.affine(term)
        walks_or_draws_per_episode = any(s.stage in ("outlier", "bias", "random_walk") for s in term.steps)
        assert (affine is None) == (walks_or_draws_per_episode or len(term.steps) > MAX_TERMS)
