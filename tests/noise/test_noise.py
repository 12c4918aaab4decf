"""Noise pipelines on their own: each stage's statistics and exact behaviour, dtypes, and binding errors.

Statistical checks use fixed seeds and tolerances derived from the sample size: an estimate must lie within
5 standard errors of the closed-form value (a false failure has probability below 1e-6 per check).
Independent samples come from many values of one observation (each value has its own draws) or from
many episodes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensorcfg.errors import SuiteError
from sensorcfg.noise import NoisePipeline, build_noise

DT = 0.002  # physics timestep (s)
Z = 5.0  # tolerance in standard errors


def pipeline(stages: list[dict], shape=(3,), dtype=np.float64, seed: int = 0, timestep: float = DT) -> NoisePipeline:
    p = build_noise(stages, shape, dtype, timestep)
    assert p is not None
    p.reset(np.random.default_rng(seed))
    return p


def run(p: NoisePipeline, value, steps) -> np.ndarray:
    """Outputs for the same input at each step, stacked."""
    value = np.broadcast_to(np.asarray(value, dtype=p.dtype), p.shape).copy()
    return np.stack([p(value, s) for s in steps])


def close_mean(samples: np.ndarray, mean, std, axis=0) -> None:
    n = samples.shape[axis]
    err = np.abs(samples.mean(axis=axis) - mean)
    assert np.all(err <= Z * np.asarray(std) / math.sqrt(n)), (samples.mean(axis=axis), mean)


def close_std(samples: np.ndarray, std, axis=0, kurtosis: float = 3.0) -> None:
    """Sample std vs std: SE of s is about std * sqrt((kurtosis - 1) / (4 n))."""
    n = samples.shape[axis]
    se = np.asarray(std) * math.sqrt((kurtosis - 1) / (4 * n))
    assert np.all(np.abs(samples.std(axis=axis, ddof=1) - std) <= Z * se), (samples.std(axis=axis), std)


def test_no_stages_no_pipeline():
    assert build_noise([], (3,), np.float64, DT) is None


# -- white noise ----------------------------------------------------------------------------------


def test_gaussian_mean_and_std_per_value():
    mean, std = np.array([0.0, 1.0, -2.0]), np.array([0.5, 1.0, 2.0])
    out = run(pipeline([{"type": "gaussian", "mean": mean.tolist(), "std": std.tolist()}]), 10.0, range(20000))
    close_mean(out, 10.0 + mean, std)
    close_std(out, std)
    corr = np.corrcoef(out[:-1, 0], out[1:, 0])[0, 1]  # white: no correlation between samples
    assert abs(corr) <= Z / math.sqrt(len(out))


def test_uniform_mean_std_and_range():
    low, high = -1.0, 3.0
    out = run(pipeline([{"type": "uniform", "low": low, "high": high}], shape=(4,)), 0.0, range(20000))
    std = (high - low) / math.sqrt(12)
    close_mean(out, (low + high) / 2, std)
    close_std(out, std, kurtosis=1.8)  # a uniform's kurtosis is 9/5
    assert out.min() >= low and out.max() < high


def test_per_last_axis_parameters_broadcast():
    """A list as long as the last axis applies to each row (e.g. x, y, z of several sites)."""
    out = run(pipeline([{"type": "gaussian", "std": [0.0, 1.0, 0.0]}], shape=(5, 3)), 0.0, range(10))
    assert np.all(out[..., 0] == 0) and np.all(out[..., 2] == 0) and np.all(out[..., 1] != 0)


# -- per-episode draws ----------------------------------------------------------------------------


@pytest.mark.parametrize("stage, mean, std", [
    pytest.param({"type": "bias", "mean": 0.5, "std": 0.2}, 0.5, 0.2, id="normal"),
    pytest.param({"type": "bias", "low": -0.3, "high": 0.9}, 0.3, 1.2 / math.sqrt(12), id="uniform"),
])
def test_bias_constant_within_an_episode_and_distributed_across_episodes(stage, mean, std):
    p = build_noise([stage], (3,), np.float64, DT)
    rng = np.random.default_rng(7)
    episodes = []
    for _ in range(3000):
        p.reset(rng)
        out = run(p, 1.0, range(0, 50, 5))
        assert np.all(out == out[0])  # constant within the episode
        episodes.append(out[0] - 1.0)
    offsets = np.array(episodes)
    close_mean(offsets, mean, std)
    close_std(offsets, std, kurtosis=3.0 if "std" in stage else 1.8)
    assert abs(np.corrcoef(offsets[:, 0], offsets[:, 1])[0, 1]) <= Z / math.sqrt(len(offsets))  # per value
    if "low" in stage:
        assert offsets.min() >= stage["low"] and offsets.max() < stage["high"]


def test_scale_is_a_per_episode_gain_around_one():
    p = build_noise([{"type": "scale", "std": 0.05}], (2,), np.float64, DT)
    rng = np.random.default_rng(3)
    gains = []
    for _ in range(3000):
        p.reset(rng)
        out = run(p, [2.0, -4.0], range(3))
        assert np.all(out == out[0])
        gains.append(out[0] / [2.0, -4.0])
    close_mean(np.array(gains), 1.0, 0.05)
    close_std(np.array(gains), 0.05)


# -- random walk ----------------------------------------------------------------------------------

N_WALKS = 20000  # independent walks: one per value of a wide observation


def walk(stage: dict, steps: list[int], seed: int = 11) -> np.ndarray:
    """The walk's value (the output for a zero input) at each step, for N_WALKS independent walks."""
    return run(pipeline([stage], shape=(N_WALKS,), seed=seed), 0.0, steps)


def close_corr(a: np.ndarray, b: np.ndarray, rho: float) -> None:
    r = np.corrcoef(a, b)[0, 1]
    assert abs(r - rho) <= Z * (1 - rho**2) / math.sqrt(len(a)) + 1e-12, (r, rho)


@pytest.mark.parametrize("interval", [pytest.param(1, id="every-step"), pytest.param(25, id="every-25-steps")])
def test_gauss_markov_variance_and_autocorrelation(interval):
    std, tau = 0.3, 0.1
    steps = [k * interval for k in range(4)]
    b = walk({"type": "random_walk", "std": std, "correlation_time": tau}, steps)
    for k in range(4):  # stationary from the first sample: N(0, std^2)
        close_mean(b[k], 0.0, std)
        close_std(b[k], std)
    for lag in (1, 3):
        rho = math.exp(-lag * interval * DT / tau)
        close_corr(b[0], b[lag], rho)


def test_gauss_markov_uses_the_time_between_samples():
    """Irregular intervals (as a random-interval sensor sees) give exp(-dt/tau) for each actual dt."""
    std, tau = 1.0, 0.05
    steps = [0, 3, 40, 41, 90]
    b = walk({"type": "random_walk", "std": std, "correlation_time": "50ms"}, steps)
    for i in range(1, len(steps)):
        close_corr(b[i - 1], b[i], math.exp(-(steps[i] - steps[i - 1]) * DT / tau))
        close_std(b[i], std)


@pytest.mark.parametrize("interval", [pytest.param(1, id="every-step"), pytest.param(50, id="every-50-steps")])
def test_brownian_walk_variance_grows_with_time(interval):
    std = 0.4  # per square-root second
    steps = [k * interval for k in range(5)]
    b = walk({"type": "random_walk", "std": std}, steps)
    assert np.all(b[0] == 0)  # a Brownian walk starts at 0
    for k in range(1, 5):
        close_std(b[k], std * math.sqrt(steps[k] * DT))
    increments = np.diff(b, axis=0)
    close_corr(increments[0], increments[2], 0.0)  # independent increments
    close_std(increments[3], std * math.sqrt(interval * DT))


def test_random_walk_statistics_do_not_depend_on_the_interval():
    """Sampled every step or every 10 steps, the walk at t = 0.2 s has the same distribution."""
    std, tau = 1.0, 0.3
    stage = {"type": "random_walk", "std": std, "correlation_time": tau}
    fine = walk(stage, list(range(101)), seed=1)
    coarse = walk(stage, list(range(0, 101, 10)), seed=2)
    rho = math.exp(-100 * DT / tau)
    close_corr(fine[0], fine[-1], rho)
    close_corr(coarse[0], coarse[-1], rho)


def test_random_walk_start_differs_between_episodes():
    p = build_noise([{"type": "random_walk", "std": 1.0, "correlation_time": 1.0}], (2,), np.float64, DT)
    rng = np.random.default_rng(0)
    starts = []
    for _ in range(3):
        p.reset(rng)
        starts.append(p(np.zeros(2), 0))
    assert len({tuple(s) for s in starts}) == 3


def test_steps_going_back_is_an_error():
    p = pipeline([{"type": "random_walk", "std": 1.0}])
    p(np.zeros(3), 10)
    with pytest.raises(ValueError, match="earlier step"):
        p(np.zeros(3), 5)


# -- deterministic stages -------------------------------------------------------------------------


def test_quantize_is_exact():
    rng = np.random.default_rng(0)
    x = rng.normal(0, 3, size=(1000, 3))
    step = np.array([0.01, 0.25, 1.0])
    p = pipeline([{"type": "quantize", "step": step.tolist()}])
    out = np.stack([p(v, i) for i, v in enumerate(x)])
    np.testing.assert_array_equal(out, np.rint(x / step) * step)
    assert np.all(np.abs(out - x) <= step / 2 + 1e-12)
    assert np.all(np.abs(out / step - np.rint(out / step)) < 1e-9)  # multiples of the step


@pytest.mark.parametrize("stage, low, high", [
    pytest.param({"type": "clip", "min": -1, "max": [1, 2, 3]}, -1, [1, 2, 3], id="both"),
    pytest.param({"type": "clip", "min": 0}, 0, np.inf, id="min"),
    pytest.param({"type": "clip", "max": 0.5}, -np.inf, 0.5, id="max"),
])
def test_clip_is_exact(stage, low, high):
    x = np.random.default_rng(1).normal(0, 3, size=(500, 3))
    p = pipeline([stage])
    out = np.stack([p(v, i) for i, v in enumerate(x)])
    np.testing.assert_array_equal(out, np.clip(x, low, high))


def test_clip_after_gaussian_saturates():
    out = run(pipeline([{"type": "gaussian", "std": 10}, {"type": "clip", "min": -1, "max": 1}]), 0.0, range(200))
    assert out.min() == -1 and out.max() == 1


# -- dropout and outliers -------------------------------------------------------------------------


@pytest.mark.parametrize("mode, lost", [pytest.param("zero", 0.0, id="zero"), pytest.param("nan", np.nan, id="nan")])
def test_dropout_rate_whole_samples(mode, lost):
    p_lost, n = 0.2, 20000
    out = run(pipeline([{"type": "dropout", "p": p_lost, "mode": mode}], shape=(4,)), 1.0, range(n))
    rows_lost = np.all(np.isnan(out) if mode == "nan" else out == 0, axis=1)
    assert np.all(rows_lost | np.all(out == 1.0, axis=1))  # a whole sample is lost, or none of it
    assert abs(rows_lost.mean() - p_lost) <= Z * math.sqrt(p_lost * (1 - p_lost) / n)


def test_dropout_hold_repeats_the_last_delivered_sample():
    p_lost, n = 0.3, 20000
    p = pipeline([{"type": "dropout", "p": p_lost, "mode": "hold"}], shape=(2,))
    out = np.stack([p(np.full(2, float(s)), s) for s in range(n)])
    assert out[0, 0] == 0  # the first sample is always delivered
    held = out[1:, 0] != np.arange(1, n)
    previous = out[:-1, 0]
    assert np.all(out[1:, 0][held] == previous[held])  # a lost sample repeats the one before
    assert np.all(out[:, 0] == out[:, 1])
    assert abs(held.mean() - p_lost) <= Z * math.sqrt(p_lost * (1 - p_lost) / n)


def test_dropout_hold_with_certain_loss_keeps_the_first_sample():
    p = pipeline([{"type": "dropout", "p": 1.0, "mode": "hold"}])
    out = np.stack([p(np.full(3, float(s)), s) for s in range(5)])
    assert np.all(out == 0.0)


def test_dropout_per_value_rates():
    probs, n = np.array([0.05, 0.5, 0.9]), 20000
    out = run(pipeline([{"type": "dropout", "p": probs.tolist(), "mode": "nan", "per": "value"}]), 2.0, range(n))
    rate = np.isnan(out).mean(axis=0)
    assert np.all(np.abs(rate - probs) <= Z * np.sqrt(probs * (1 - probs) / n))
    assert np.all(out[~np.isnan(out)] == 2.0)


def test_dropout_per_value_hold():
    p = pipeline([{"type": "dropout", "p": 0.5, "mode": "hold", "per": "value"}], shape=(50,))
    values = [np.arange(50.0) + 100 * s for s in range(30)]
    out = np.stack([p(v, s) for s, v in enumerate(values)])
    np.testing.assert_array_equal(out[0], values[0])
    for s in range(1, 30):
        kept = out[s] == values[s]
        np.testing.assert_array_equal(out[s][~kept], out[s - 1][~kept])


def test_outlier_rate_and_size():
    prob, scale, n = 0.05, 100.0, 4000
    out = run(pipeline([{"type": "outlier", "p": prob, "scale": scale}], shape=(100,)), 1.0, range(n))
    hit = out != 1.0
    assert abs(hit.mean() - prob) <= Z * math.sqrt(prob * (1 - prob) / hit.size)
    close_std(out[hit] - 1.0, scale)


# -- lowpass --------------------------------------------------------------------------------------


@pytest.mark.parametrize("steps", [
    pytest.param(list(range(0, 60)), id="every-step"),
    pytest.param(list(range(0, 300, 7)), id="every-7-steps"),
    pytest.param([0, 1, 2, 10, 11, 40, 41, 42, 100], id="irregular"),
])
def test_lowpass_step_response(steps):
    """A unit step after the first sample gives 1 - exp(-2 pi fc t) at every sample time t."""
    fc = 20.0
    p = pipeline([{"type": "lowpass", "cutoff": f"{fc:g}Hz"}], shape=(2,))
    first = p(np.zeros(2), steps[0])
    np.testing.assert_array_equal(first, 0.0)  # starts settled at the first sample
    out = np.stack([p(np.ones(2), s) for s in steps[1:]])
    t = np.array(steps[1:]) * DT
    np.testing.assert_allclose(out[:, 0], 1 - np.exp(-2 * math.pi * fc * t), rtol=1e-12, atol=1e-15)


def test_lowpass_per_value_cutoff():
    p = pipeline([{"type": "lowpass", "cutoff": ["5Hz", 50]}], shape=(2,))
    p(np.zeros(2), 0)
    out = p(np.ones(2), 10)
    np.testing.assert_allclose(out, 1 - np.exp(-2 * math.pi * np.array([5.0, 50.0]) * 10 * DT), rtol=1e-12)


# -- images and dtypes ----------------------------------------------------------------------------


def test_rgb_image_keeps_uint8_and_range():
    shape = (16, 16, 3)
    p = pipeline([{"type": "gaussian", "std": [40, 0, 40]}, {"type": "dropout", "p": 0.1, "mode": "zero"}],
                 shape=shape, dtype=np.uint8)
    bright = np.full(shape, 250, np.uint8)
    outs = [p(bright, s) for s in range(200)]
    assert all(o.dtype == np.uint8 and o.shape == shape for o in outs)
    stack = np.stack(outs).astype(int)
    assert stack.max() == 255  # clipped, not wrapped around
    assert np.all(stack[..., 1][stack[..., 1] != 0] == 250)  # std 0 on green: unchanged unless dropped
    dark = np.stack([p(np.zeros(shape, np.uint8), s) for s in range(200, 260)]).astype(int)
    assert dark.min() == 0 and dark.max() > 0


def test_rgb_image_noise_statistics_in_range():
    """Mid-grey with small noise: rounding to integers keeps the mean and adds 1/12 to the variance."""
    shape = (64, 64, 3)
    p = pipeline([{"type": "gaussian", "std": 5.0}], shape=shape, dtype=np.uint8)
    out = np.stack([p(np.full(shape, 128, np.uint8), s) for s in range(5)]).astype(float)
    close_mean(out.ravel(), 128.0, 5.0)
    close_std(out.ravel(), math.sqrt(25 + 1 / 12))


def test_uint8_quantize_and_clip():
    p = pipeline([{"type": "quantize", "step": 16}, {"type": "clip", "min": 32, "max": 200}], shape=(256,),
                 dtype=np.uint8)
    x = np.arange(256, dtype=np.uint8)
    out = p(x, 0)
    assert out.dtype == np.uint8
    np.testing.assert_array_equal(out, np.clip(np.rint(x / 16) * 16, 32, 200).astype(np.uint8))


def test_depth_image_in_metres_keeps_float32():
    shape = (32, 32)
    p = pipeline([{"type": "gaussian", "std": 0.01}, {"type": "dropout", "p": 0.1, "mode": "zero", "per": "value"}],
                 shape=shape, dtype=np.float32)
    out = np.stack([p(np.full(shape, 2.0, np.float32), s) for s in range(20)])
    assert out.dtype == np.float32
    valid = out[out != 0]
    close_mean(valid, 2.0, 0.01)
    assert abs((out == 0).mean() - 0.1) <= Z * math.sqrt(0.09 / out.size)


def test_float32_features_stay_float32():
    p = pipeline([{"type": "bias", "std": 1}, {"type": "random_walk", "std": 1}, {"type": "lowpass", "cutoff": 5}],
                 dtype=np.float32)
    assert p(np.zeros(3, np.float32), 0).dtype == np.float32


def test_scalar_observation():
    p = pipeline([{"type": "gaussian", "std": 1}, {"type": "random_walk", "std": 1, "correlation_time": 1},
                  {"type": "clip", "min": -0.5}], shape=())
    out = p(np.float64(0.0), 3)
    assert out.shape == () and out >= -0.5


# -- custom ---------------------------------------------------------------------------------------


def corrupt(value, random_state):
    """A dm_control corruptor: it gets a numpy RandomState."""
    assert isinstance(random_state, np.random.RandomState)
    return value + random_state.uniform(-1, 1, size=np.shape(value))


def test_custom_callable_with_dm_control_signature(tmp_path, monkeypatch):
    (tmp_path / "my_noise.py").write_text(
        "import numpy as np\n"
        "def salt(value, random_state):\n"
        "    assert isinstance(random_state, np.random.RandomState)\n"
        "    return value + random_state.uniform(-1, 1, size=value.shape)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    a = run(pipeline([{"type": "custom", "callable": "my_noise:salt"}], seed=4), 5.0, range(100))
    b = run(pipeline([{"type": "custom", "callable": corrupt}], seed=4), 5.0, range(100))
    np.testing.assert_array_equal(a, b)  # same seed, same stream, whichever way it is named
    assert np.all(np.abs(a - 5.0) < 1) and len(np.unique(a)) == a.size
    c = run(pipeline([{"type": "custom", "callable": corrupt}], seed=5), 5.0, range(100))
    assert not np.array_equal(a, c)


def test_custom_on_uint8_gets_uint8():
    seen = []

    def record(value, random_state):
        seen.append(value.dtype)
        return value.astype(np.int64) + 300  # out of range: clipped
    out = pipeline([{"type": "custom", "callable": record}], shape=(2, 2, 3), dtype=np.uint8)(
        np.zeros((2, 2, 3), np.uint8), 0)
    assert seen == [np.uint8] and out.dtype == np.uint8 and np.all(out == 255)


def test_custom_on_segmentation_is_allowed():
    flip = lambda value, random_state: np.where(random_state.random_sample(value.shape) < 0.5, -1, value)  # noqa: E731
    out = pipeline([{"type": "custom", "callable": flip}], shape=(4, 4, 2), dtype=np.int32)(
        np.ones((4, 4, 2), np.int32), 0)
    assert out.dtype == np.int32 and set(np.unique(out)) <= {-1, 1}


def test_custom_wrong_shape_is_an_error():
    p = pipeline([{"type": "custom", "callable": lambda value, random_state: value[:2]}])
    with pytest.raises(SuiteError, match=r"noise.0.callable: custom noise callable .* returned a value of shape "
                                         r"\(2,\); the observation's shape is \(3,\)"):
        p(np.zeros(3), 0)


# -- seeds, streams and the calling convention ----------------------------------------------------

ALL = [{"type": "gaussian", "std": 0.1}, {"type": "uniform", "low": -1, "high": [1, 2, 3]},
       {"type": "bias", "std": 1}, {"type": "scale", "low": 0.9, "high": 1.1},
       {"type": "random_walk", "std": 1, "correlation_time": "1s"}, {"type": "random_walk", "std": 1},
       {"type": "quantize", "step": 0.01}, {"type": "clip", "min": -5, "max": 5},
       {"type": "dropout", "p": 0.1, "mode": "hold"}, {"type": "outlier", "p": 0.1, "scale": 3},
       {"type": "lowpass", "cutoff": "20Hz"}, {"type": "dropout", "p": [0.1, 0.2, 0.3], "mode": "nan", "per": "value"},
       {"type": "custom", "callable": corrupt}]


def test_same_seed_same_stream_bit_for_bit():
    a = run(pipeline(ALL, seed=9), 0.5, range(0, 600, 3))
    b = run(pipeline(ALL, seed=9), 0.5, range(0, 600, 3))
    np.testing.assert_array_equal(a, b)
    c = run(pipeline(ALL, seed=10), 0.5, range(0, 600, 3))
    assert not np.array_equal(a, c, equal_nan=True)


def test_reset_starts_a_new_episode_reproducibly():
    p = build_noise(ALL, (3,), np.float64, DT)
    rng = np.random.default_rng(2)
    p.reset(rng)
    first = run(p, 0.5, range(50))
    p.reset(rng)
    second = run(p, 0.5, range(50))
    assert not np.array_equal(first, second, equal_nan=True)
    p.reset(np.random.default_rng(2))
    np.testing.assert_array_equal(run(p, 0.5, range(50)), first)


def test_legacy_random_state_is_accepted():
    p = build_noise([{"type": "gaussian", "std": 1}], (3,), np.float64, DT)
    p.reset(np.random.RandomState(0))
    a = run(p, 0.0, range(3))
    p.reset(np.random.RandomState(0))
    np.testing.assert_array_equal(run(p, 0.0, range(3)), a)


def test_appending_a_stage_leaves_earlier_draws_alone():
    """Each stage has its own stream (the i-th child of the pipeline's): a clip that never bites after a
    random walk changes nothing, and fusing adjacent additive stages draws what each would alone."""
    walk = [{"type": "random_walk", "std": 1, "correlation_time": 1}]
    a = run(pipeline(walk, seed=3), 0.0, range(100))
    b = run(pipeline([*walk, {"type": "clip", "min": -1e9}], seed=3), 0.0, range(100))
    np.testing.assert_array_equal(a, b)
    g1 = run(pipeline([{"type": "gaussian", "std": 1}], seed=3), 0.0, range(300))
    g2 = run(pipeline([{"type": "gaussian", "std": 1}, {"type": "gaussian", "std": 0}], seed=3), 0.0, range(300))
    np.testing.assert_array_equal(g1, g2)


def test_input_is_never_written_and_out_is_honoured():
    x = np.array([1.0, 2.0, 3.0])
    keep = x.copy()
    for stages in ([ALL[0]], ALL[:-1], [ALL[10]]):
        p, q = pipeline(stages, seed=1), pipeline(stages, seed=1)
        for s in range(20):
            y = p(x, s)
            assert y is not x
            np.testing.assert_array_equal(x, keep)
            buf = x.copy()
            assert q(buf, s, out=buf) is buf  # in place, as a ring buffer row
            np.testing.assert_array_equal(buf, y)


def test_results_are_not_reused_between_calls():
    p = pipeline([{"type": "gaussian", "std": 1}, {"type": "clip", "min": -2}])
    a = p(np.zeros(3), 0)
    a_copy = a.copy()
    p(np.zeros(3), 1)
    np.testing.assert_array_equal(a, a_copy)


# -- binding-time errors --------------------------------------------------------------------------


@pytest.mark.parametrize("stages, shape, dtype, message", [
    pytest.param([{"type": "gaussian", "std": [1, 2]}], (3,), np.float64,
                 "noise.0.std: 2 entries do not fit the observation's shape (3,): give a number or 3 (one per value)",
                 id="list-length"),
    pytest.param([{"type": "gaussian", "std": 1}, {"type": "clip", "min": [1, 2]}], (4, 3), np.float64,
                 "noise.1.min: 2 entries do not fit the observation's shape (4, 3): give a number or 12 (one per "
                 "value) or 3 (one per entry of the last axis)", id="list-length-2d"),
    pytest.param([{"type": "uniform", "low": [0, 0, 5], "high": [1, 1, 1, 1, 1, 1]}], (2, 3), np.float64,
                 "noise.0.low: low must not exceed high (for every value once broadcast to the shape (2, 3)); "
                 "swap them", id="low-gt-high-broadcast"),
    pytest.param([{"type": "random_walk", "std": 1}], (48, 64, 3), np.uint8,
                 "noise.0.type: random_walk cannot apply to a uint8 image: images take gaussian, uniform, quantize, "
                 "clip, dropout, outlier, custom (results are rounded and clipped to 0..255)", id="walk-on-rgb"),
    pytest.param([{"type": "dropout", "p": 0.1, "mode": "nan"}], (48, 64, 3), np.uint8,
                 "noise.0.mode: a uint8 image cannot hold NaN; use mode hold or zero", id="nan-on-rgb"),
    pytest.param([{"type": "gaussian", "std": 1}], (48, 64, 2), np.int32,
                 "noise.0.type: gaussian cannot apply to int32 values (ids or counts, such as a segmentation "
                 "image): only a custom stage can", id="gaussian-on-segmentation"),
    pytest.param([{"type": "gausian", "std": 1}], (3,), np.float64,
                 "noise.0.type: unknown noise stage type 'gausian' (did you mean 'gaussian'?); stage types are "
                 "gaussian, uniform, bias, scale, random_walk, quantize, clip, dropout, outlier, lowpass, misalign, custom",
                 id="unknown-type"),
    pytest.param([{"type": "gaussian", "std": -1}], (3,), np.float64,
                 "noise.0.std: a standard deviation must be >= 0, got -1", id="negative-std"),
    pytest.param([{"type": "custom", "callable": "numpy:sqrtt"}], (3,), np.float64,
                 "noise.0.callable: 'numpy' has no attribute 'sqrtt' (did you mean 'sqrt' or 'sort' or 'short'?)",
                 id="custom-missing"),
    pytest.param([{"type": "custom", "callable": "no_such_module_xyz:f"}], (3,), np.float64,
                 "noise.0.callable: cannot import 'no_such_module_xyz' for 'no_such_module_xyz:f': No module named "
                 "'no_such_module_xyz'", id="custom-module"),
    pytest.param([{"type": "custom", "callable": "math:pi"}], (3,), np.float64,
                 "noise.0.callable: custom noise callable 'math:pi' is a float, not a function", id="custom-not-fn"),
    pytest.param([{"type": "custom", "callable": "math:floor"}], (3,), np.float64,
                 "noise.0.callable: custom noise callable 'math:floor' must accept (value, random_state), as a "
                 "dm_control corruptor does; it takes (x, /)", id="custom-signature"),
    pytest.param([{"type": "custom", "callable": "builtins:max"}], (3,), np.float64,
                 "noise.0.callable: custom noise callable 'builtins:max' has no signature Python can read, so whether "
                 "it accepts (value, random_state) cannot be checked before it is called: wrap it in a function "
                 "`def corrupt(value, random_state): ...`", id="custom-no-signature"),
])
def test_binding_errors(stages, shape, dtype, message):
    with pytest.raises(SuiteError) as info:
        build_noise(stages, shape, dtype, DT)
    assert [f"{p.loc}: {p.message}" for p in info.value.problems] == [message]


def test_binding_errors_are_reported_together():
    with pytest.raises(SuiteError) as info:
        build_noise([{"type": "random_walk", "std": 1}, {"type": "lowpass", "cutoff": 5},
                     {"type": "gaussian", "std": [1, 2]}], (8, 8, 3), np.uint8, DT)
    assert [p.loc for p in info.value.problems] == ["noise.0.type", "noise.1.type", "noise.2.std"]
