"""`set_noise_level`: every stage's effect scaled from the next episode on, single and batched."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS, assert_batch_equals_single

TERRAIN = str(MODELS / "terrain.xml")
NOISE = ("[{type: gaussian, std: 0.05}, {type: bias, std: 0.2}, {type: random_walk, std: 0.01, "
         "correlation_time: 0.1}, {type: uniform, low: -0.02, high: 0.03}]")
SUITE = f"""\
options: {{control_interval: 5, strip_singleton_buffer_dim: true}}
sensors:
  noisy: {{kind: velocimeter, element: body:base, noise: {NOISE}}}
  clean: {{kind: velocimeter, element: body:base}}
  quantized: {{kind: qpos, element: joint:hip_f, noise: [{{type: quantize, step: 0.1}}, {{type: scale, std: 0.1}}]}}
"""


def _errors(level: float | None, episodes: int = 2, steps: int = 20) -> list[np.ndarray]:
    env = sensorcfg.Environment(TERRAIN, sensorcfg.loads(SUITE), seed=0)
    env.reset()
    if level is not None:
        env.set_noise_level(level)
    out = []
    for _ in range(episodes):
        env.reset()
        errors = []
        for _ in range(steps):
            obs = env.step(np.array([0.5, -0.5])).observation
            errors.append(obs["noisy"] - obs["clean"])
        out.append(np.array(errors))
    return out


def test_level_scales_additive_noise_and_one_is_exact() -> None:
    base = _errors(None)
    np.testing.assert_array_equal(_errors(1.0)[1], base[1])  # level 1: the suite's noise, bit for bit
    np.testing.assert_allclose(_errors(0.25)[1], 0.25 * base[1], rtol=1e-9, atol=1e-12)  # the same draws, scaled
    assert np.all(_errors(0.0)[1] == 0)


def test_a_level_applies_from_the_next_episode() -> None:
    env = sensorcfg.Environment(TERRAIN, sensorcfg.loads(SUITE), seed=0)
    env.reset()
    env.step(np.zeros(2))
    env.set_noise_level(0.0)
    obs = env.step(np.zeros(2)).observation
    assert np.any(obs["noisy"] != obs["clean"])  # this episode keeps its level
    env.reset()
    obs = env.step(np.zeros(2)).observation
    np.testing.assert_array_equal(obs["noisy"], obs["clean"])


def test_a_bad_level_is_refused() -> None:
    env = sensorcfg.Environment(TERRAIN, sensorcfg.loads(SUITE), seed=0)
    with pytest.raises(sensorcfg.ArgumentError, match=r"a noise level is a number >= 0 .* got -1"):
        env.set_noise_level(-1)


@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
@pytest.mark.parametrize("level", [None, 0.3])
def test_batched_levels_equal_single(level: float | None, monkeypatch: pytest.MonkeyPatch) -> None:
    suite = sensorcfg.loads(SUITE)
    if level is not None:  # every environment the helper builds starts at this level
        for cls in (sensorcfg.Environment, sensorcfg.BatchEnvironment):
            original = cls.reset

            def reset(self, *args, _original=original, **kwargs):
                self.set_noise_level(level)
                return _original(self, *args, **kwargs)

            monkeypatch.setattr(cls, "reset", reset)
    assert_batch_equals_single(TERRAIN, suite, nsim=3, seed=2, steps=15)


STAGED = ("options: {control_interval: 5, strip_singleton_buffer_dim: true}\nsensors:\n"
          "  v: {kind: velocimeter, element: body:base, noise: [{type: misalign, std: 5deg},\n"
          "      {type: gaussian, std: {uniform: [0.01, 0.05]}}, {type: lowpass, cutoff: 10Hz},\n"
          "      {type: scale, low: {uniform: [0.8, 0.9]}, high: {uniform: [1.1, 1.2]}}]}\n"
          "  h: {kind: heightscan, element: site:imu, interval: 5, buffer: 2,\n"
          "      noise: [{type: gaussian, std: 0.01}, {type: lowpass, cutoff: 20Hz}]}\n")


def _episodes(make, level: float | None, at: int, steps: int = 12) -> list[dict[str, np.ndarray]]:
    """Two episodes of observations; `set_noise_level(level)` is called after `at` steps of the first."""
    env = make()
    out = [env.reset().observation]
    for episode in range(2):
        for k in range(steps):
            if episode == 0 and k == at and level is not None:
                env.set_noise_level(level)
            out.append(env.step(np.full(env.action_spec().shape, 0.3)).observation)
        out.append(env.reset().observation if episode == 0 else out[-1])
    return out


def _single() -> sensorcfg.Environment:
    return sensorcfg.Environment(TERRAIN, sensorcfg.loads(STAGED), seed=4)


def _batch() -> sensorcfg.BatchEnvironment:
    return sensorcfg.BatchEnvironment(TERRAIN, sensorcfg.loads(STAGED), 2, seed=4)


@pytest.mark.parametrize("make", [
    pytest.param(_single, id="single"),
    pytest.param(_batch, id="batch", marks=pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4,
                                                             reason="mujoco.batch needs MuJoCo 4")),
])
def test_a_level_set_mid_episode_leaves_that_episode_untouched(make) -> None:
    """Misalignment, drawn parameters and a low-pass keep their episode's draws and state when a level is set
    mid-episode: at level 1 nothing changes at all; at level 0 the episode under way keeps its noise and the
    next one is clean."""
    base = _episodes(make, None, at=5)
    for got, want in zip(_episodes(make, 1.0, at=5), base):
        for name in want:
            np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    clean = _episodes(make, 0.0, at=5)
    steps = 12
    for got, want in zip(clean[:steps + 1], base[:steps + 1]):  # the first episode, to its last step
        for name in want:
            np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    assert np.any(clean[-1]["v"] != base[-1]["v"])  # the next episode is at level 0


CLIPPED = ("options: {strip_singleton_buffer_dim: true, pad_with_initial_value: true}\nsensors:\n"
           "  q: {kind: qpos, element: joint:hip_f, noise: [{type: gaussian, std: 0.05},\n"
           "      {type: clip, min: 0.1, max: 0.2}]}\n"
           "  v: {kind: velocimeter, element: body:base, buffer: 3, aggregator: max,\n"
           "      noise: [{type: clip, min: [-0.01, -0.02, 0.05], max: 0.3}, {type: lowpass, cutoff: 20Hz}]}\n")


@pytest.mark.parametrize("level", [0.0, 0.5, 2.0])
def test_values_stay_within_the_spec_bounds_at_any_level(level: float) -> None:
    """A blend of the raw value (outside the clip) and the clipped one would leave the clip's range: the
    blend is kept within the bounds the noisy values keep, so the spec holds at every level, in a batch
    too."""
    env = sensorcfg.Environment(TERRAIN, sensorcfg.loads(CLIPPED), seed=1)
    spec = env.observation_spec()
    assert (spec["q"].minimum, spec["q"].maximum) == (0.1, 0.2)
    env.set_noise_level(level)
    shown = [env.reset().observation] + [env.step(np.array([0.5, -0.5])).observation for _ in range(30)]
    for obs in shown:
        for name, value in obs.items():
            spec[name].validate(value)
    q = {float(obs["q"][0]) for obs in shown}  # the joint stays near 0, below the clip: a blend would too
    assert q == {0.1} if level < 1 else 0.2 in q  # (at level 2, 2 noisy - raw is above the clip's max)
    if int(mujoco.__version__.split(".")[0]) < 4:
        return
    batch = sensorcfg.BatchEnvironment(TERRAIN, sensorcfg.loads(CLIPPED), 2, seed=1)
    batch_spec = batch.observation_spec()
    batch.set_noise_level(level)
    for obs in [batch.reset().observation] + [batch.step(np.full((2, 2), 0.5)).observation for _ in range(30)]:
        for name, value in obs.items():
            batch_spec[name].validate(value)


def test_a_scalar_sensor_with_bounded_noise_blends_at_a_level() -> None:
    """A sensor of one value (`index: 0`: shape ()) whose noise keeps bounds (a clip): its blend at a level
    below 1 is clipped in place, a 0-d array (numpy's arithmetic on 0-d arrays gives a scalar)."""
    suite = """\
sensors:
  one: {kind: qpos, element: joint:hip_f, index: 0,
        noise: [{type: gaussian, std: 0.5}, {type: clip, min: -0.1, max: 0.1}]}
  clean: {kind: qpos, element: joint:hip_f, index: 0}
"""
    env = sensorcfg.Environment(TERRAIN, sensorcfg.loads(suite), seed=0)
    env.reset()
    env.set_noise_level(0.5)
    env.reset()
    for _ in range(5):
        obs = env.step(np.zeros(2)).observation
        assert -0.1 <= float(obs["one"][0]) <= 0.1
