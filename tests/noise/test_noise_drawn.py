"""Noise parameters drawn per episode: `std: {uniform: [0.01, 0.03]}`, single and batched."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS, assert_batch_equals_single

TERRAIN = str(MODELS / "terrain.xml")


def _suite(noise: str) -> sensorcfg.Suite:
    return sensorcfg.loads("options: {strip_singleton_buffer_dim: true}\nsensors:\n"
                           f"  noisy: {{kind: qpos, element: joint:hip_f, noise: [{noise}]}}\n"
                           "  clean: {kind: qpos, element: joint:hip_f}\n")


def _errors(noise: str, episodes: int, steps: int = 400, seed: int = 0) -> np.ndarray:
    env = sensorcfg.Environment(TERRAIN, _suite(noise), seed=seed)
    out = []
    for _ in range(episodes):
        env.reset()
        errors = []
        for _ in range(steps):
            obs = env.step(np.zeros(2)).observation
            errors.append(obs["noisy"] - obs["clean"])
        out.append(errors)
    return np.array(out)


def test_a_range_is_drawn_once_per_episode() -> None:
    errors = _errors("{type: uniform, low: 0, high: {uniform: [0.2, 1.0]}}", episodes=4)
    highs = errors.max(axis=1)  # each episode's noise lies in [0, high) for its one drawn high
    assert np.all(errors >= 0) and np.all(highs < 1.0) and np.all(highs > 0.2 * 0.95)
    assert np.ptp(highs) > 0.05  # episodes differ
    np.testing.assert_array_equal(_errors("{type: uniform, low: 0, high: {uniform: [0.2, 1.0]}}", episodes=4),
                                  errors)  # and the seed decides


def test_a_drawn_std_stays_in_its_range() -> None:
    stds = _errors("{type: gaussian, std: {uniform: [0.01, 0.03]}}", episodes=5).std(axis=1)
    assert np.all(stds > 0.01 * 0.85) and np.all(stds < 0.03 * 1.15) and np.ptp(stds) > 0.002


def test_bounds_out_of_order_are_a_problem_at_their_line() -> None:
    with pytest.raises(sensorcfg.SuiteError) as info:
        _suite("{type: gaussian, std: {uniform: [0.03, 0.01]}}")
    assert "sensors.noisy.noise.0.std: uniform bounds must satisfy low <= high; got [0.03, 0.01]: swap them" \
        in str(info.value)


@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
def test_batched_draws_equal_single() -> None:
    suite = sensorcfg.loads(
        "options: {control_interval: 5, strip_singleton_buffer_dim: true}\nsensors:\n"
        "  v: {kind: velocimeter, element: body:base, noise: [{type: gaussian, std: {uniform: [0.01, 0.05]}},\n"
        "      {type: random_walk, std: {uniform: [0.001, 0.01]}, correlation_time: 0.1},\n"
        "      {type: misalign, std: 1deg}]}\n"
        "  q: {kind: qpos, element: joint:hip_r, interval: 2, noise: [{type: lowpass, cutoff: {uniform: [5, 50]}}]}\n")
    assert_batch_equals_single(TERRAIN, suite, nsim=3, seed=6, steps=15)


@pytest.mark.parametrize("stage, message", [
    pytest.param("{type: clip, min: {uniform: [0, 0.5]}, max: {uniform: [0.3, 1]}}",
                 "noise.0.min: min must not exceed max in any episode, but min is drawn from [0, 0.5] and max is "
                 "drawn from [0.3, 1]: a draw can put min above max; make min's highest value (0.5) at most "
                 "max's lowest value (0.3), so that the two never cross", id="clip-both-drawn"),
    pytest.param("{type: uniform, low: {uniform: [-0.1, 0.2]}, high: 0.1}",
                 "noise.0.low: low must not exceed high in any episode, but low is drawn from [-0.1, 0.2] and high "
                 "is 0.1: a draw can put low above high; make low's highest value (0.2) at most high (0.1), so that "
                 "the two never cross", id="uniform-low-drawn"),
    pytest.param("{type: bias, low: -0.1, high: {uniform: [-0.2, 0.1]}}",
                 "noise.0.low: low must not exceed high in any episode, but low is -0.1 and high is drawn from "
                 "[-0.2, 0.1]: a draw can put low above high; make low (-0.1) at most high's lowest value (-0.2), "
                 "so that the two never cross", id="bias-high-drawn"),
    pytest.param("{type: scale, low: {uniform: [0.8, 1.05]}, high: {uniform: [1.0, 1.2]}}",
                 "noise.0.low: low must not exceed high in any episode", id="scale-both-drawn"),
    pytest.param("{type: clip, min: {uniform: [0, 0.5]}, max: [1, 0.4, 2]}",
                 "noise.0.min: min must not exceed max (entry 1) in any episode, but min is drawn from [0, 0.5] and "
                 "max is 0.4", id="per-value"),
])
def test_drawn_ends_that_can_cross_are_refused_at_their_line(stage: str, message: str) -> None:
    """Two ends of a range drawn each episode must never cross (in 7 of 10 episodes a clip ran with min above
    max): ranges that overlap are refused where the stage is written, not put back in order at each draw
    (which would change the distributions the suite gives)."""
    with pytest.raises(sensorcfg.SuiteError) as info:
        _suite(stage)
    assert f"sensors.noisy.noise.0.{message.split('noise.0.', 1)[1]}" in str(info.value)


@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
def test_drawn_ends_that_only_touch_keep_their_order_in_every_episode() -> None:
    """Ranges that meet at one value are accepted: every episode's draws keep min <= max (single and batched,
    which equal each other)."""
    noise = "{type: clip, min: {uniform: [-0.3, 0.0]}, max: {uniform: [0.0, 0.3]}}"
    env = sensorcfg.Environment(TERRAIN, _suite(noise), seed=3)
    for _ in range(10):
        env.reset()
        drawn = env._observables["noisy"].noise.stages[0].values
        assert drawn["min"] <= drawn["max"]
    assert_batch_equals_single(TERRAIN, _suite(noise), nsim=3, seed=6, steps=10)
