"""`set_noise_level`: every stage's effect scaled from the next episode on, single and batched."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import assert_batch_equals_single

TERRAIN = str(Path(__file__).parent / "models" / "terrain.xml")
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
    with pytest.raises(sensorcfg.SuiteError, match=r"a noise level is a number >= 0 .* got -1"):
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
