"""The Gymnasium adapters (extra `gym`)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import sensorcfg

gymnasium = pytest.importorskip("gymnasium", reason="the gym extra is not installed")
from gymnasium.utils.env_checker import check_env  # noqa: E402

from sensorcfg.gym import GymEnv  # noqa: E402

from conftest import ROOT


@pytest.mark.parametrize("suite", ["proprioception.yaml", "imu.yaml", "sim2real.yaml"])
def test_gym_env_passes_gymnasiums_checker(suite: str) -> None:
    env = GymEnv(sensorcfg.make_env(ROOT / "configs" / suite, time_limit=0.2))
    check_env(env, skip_render_check=True)


def test_terminated_and_truncated_follow_the_timestep() -> None:
    env = GymEnv(sensorcfg.make_env(ROOT / "configs" / "imu.yaml", time_limit=0.05))
    obs, _ = env.reset(seed=1)
    assert set(obs) == set(env.observation_space.spaces)
    done = truncated = False
    while not (done or truncated):
        obs, reward, done, truncated, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
    assert truncated and not done  # the time limit truncates


def test_reset_with_a_seed_is_reproducible() -> None:
    env = GymEnv(sensorcfg.make_env(ROOT / "configs" / "sim2real.yaml"))
    a, _ = env.reset(seed=4)
    a1 = env.step(np.zeros(3))[0]
    b, _ = env.reset(seed=4)
    b1 = env.step(np.zeros(3))[0]
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
        np.testing.assert_array_equal(a1[k], b1[k])


def test_example_script_runs() -> None:
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "random_episode.py"), "--seconds", "0.2"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "steps/s" in out.stdout and "samples taken" in out.stdout
