"""What the Warp engine's noise draws per episode (`sensorcfg.warp.episode`): parameters drawn per episode
(`{uniform: [low, high]}`) of every stage type, and `misalign` on one, two and three 3-vectors, against the
single-simulation Updater on the same trajectory, over several episodes per world (resets of some worlds
mid-run, noise levels, more episodes than the key table holds: its top-up)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.noise.level import leveled  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from test_warp_fuzz import replay  # noqa: E402

ROBOT = str(assets.path("robot.xml"))
U = lambda low, high: {"uniform": [low, high]}  # noqa: E731  a parameter drawn per episode

# every stage type with a parameter drawn per episode (each of its parameters, across the list)
DRAWN = [
    {"type": "gaussian", "std": U(0.01, 0.03)},
    {"type": "gaussian", "mean": U(-0.01, 0.01), "std": 0.02},
    {"type": "uniform", "low": U(-0.03, -0.01), "high": U(0.01, 0.02)},
    {"type": "bias", "std": U(0.05, 0.2)},
    {"type": "bias", "low": U(-0.2, -0.1), "high": U(0.1, 0.3)},
    {"type": "scale", "mean": U(0.9, 1.1), "std": U(0.0, 0.05)},
    {"type": "random_walk", "std": U(0.005, 0.02), "correlation_time": U(0.02, 0.1)},
    {"type": "random_walk", "std": U(0.005, 0.02)},
    {"type": "quantize", "step": U(0.001, 0.01)},
    {"type": "clip", "min": U(-0.6, -0.3), "max": U(0.3, 0.6)},
    {"type": "dropout", "p": U(0.1, 0.5), "mode": "hold"},
    {"type": "dropout", "p": U(0.1, 0.5), "mode": "nan", "per": "value"},
    {"type": "outlier", "p": U(0.05, 0.2), "scale": U(0.5, 1.0)},
    {"type": "lowpass", "cutoff": U(5.0, 40.0)},
]
MISALIGN = [
    {"type": "misalign", "std": 0.05},
    {"type": "misalign", "matrix": [[1.0, 0.02, 0.0], [0.0, 0.98, 0.03], [0.01, 0.0, 1.02]]},
    {"type": "misalign", "matrix": [[1.0, 0.02, 0.0], [0.0, 0.98, 0.03], [0.01, 0.0, 1.02]], "std": "2deg"},
]
SCALARS = [("qpos", ["joint:shoulder", "joint:elbow"]), ("qvel", "joint:elbow")]
# a 3-vector, two, three (misalign takes any shape whose last axis holds 3 values: it turns each row)
VECTORS = [("sensordata", "sensor:imu_accel"), ("xpos", "site:hand_site"), ("xpos", ["site:hand_site", "site:imu"]),
           ("xpos", ["site:hand_site", "site:imu", "site:fingertip"])]


def suite(seed: int) -> dict[str, sensorcfg.Observable]:
    """Random sensors with random schedules, each with drawn parameters and (3-vectors) misalign stages
    before, between or after them."""
    rng = np.random.default_rng(seed)
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
    out = {}
    for j in range(int(rng.integers(3, 6))):
        vector = rng.random() < 0.6
        kind, element = (VECTORS if vector else SCALARS)[int(rng.integers(len(VECTORS if vector else SCALARS)))]
        obs = sensorcfg.Feature(kind, element, update_interval=int(rng.integers(1, 4)), delay=int(rng.integers(0, 4)),
                                buffer_size=int(rng.integers(1, 4)),
                                aggregator=[None, None, "mean", "median"][int(rng.integers(4))])
        obs.reader(physics)
        stages = [DRAWN[int(p)] for p in rng.choice(len(DRAWN), size=int(rng.integers(1, 4)), replace=False)]
        if vector:
            for _ in range(int(rng.integers(1, 3))):
                stages.insert(int(rng.integers(len(stages) + 1)), MISALIGN[int(rng.integers(len(MISALIGN)))])
        obs.noise = build_noise(stages, obs.array_spec.shape, obs.array_spec.dtype, physics.timestep)
        obs.enabled = True
        out[f"s{j}_{kind}"] = obs
    leveled(out)
    return out


def replay_episodes(make: Callable[[], dict[str, Any]], nworld: int, substeps: int, control_steps: int, seed: int,
                    restarts: dict[int, list[int]], levels: dict[int, float], key_episodes: int = 4) -> int:
    """World w of the Warp sensor layer against an Updater over `make()`'s observables on the bundled robot,
    both reading world w's CPU trajectory (`test_warp_fuzz.replay`: worlds `restarts[t]` start a new episode at
    control step t, new episodes from `levels[t]` on have that noise level, the key table holds
    `key_episodes` episodes ahead and is topped up by `layer.EpisodeKeys.top_up`). Returns the most episodes a
    world started."""
    options = {"physics_steps_per_control_step": substeps, "strip_singleton_buffer_dim": False,
               "pad_with_initial_value": False}
    return replay(make, mujoco.MjModel.from_xml_path(ROBOT), options, nworld, control_steps, seed, restarts, levels,
                  key_episodes)


@pytest.mark.parametrize("seed", range(4))
def test_world_i_draws_the_episodes_the_updater_draws(seed: int) -> None:
    restarts = {t: [w for w in range(3) if (t + w + seed) % (2 + w) == 0] for t in range(1, 25)}
    episodes = replay_episodes(lambda: suite(seed), 3, 1 + seed % 2, 24, seed, restarts, {9: 0.5, 17: 0.0})
    assert episodes > 2 * 4  # the key table (4 episodes ahead) was topped up, twice over


def test_each_stage_with_drawn_parameters_and_each_misalign_on_one_two_and_three_vectors() -> None:
    """One sensor per drawn stage, and misalign stages on one, two and three 3-vectors, with the
    misalign stages between others."""
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))

    def make() -> dict[str, sensorcfg.Observable]:
        out = {}
        for j, stage in enumerate(DRAWN):
            obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], update_interval=1 + j % 2)
            obs.reader(physics)
            obs.noise = build_noise([stage], (2,), np.float64, physics.timestep)
            out[f"drawn{j}"] = obs
        for j, (kind, element) in enumerate(VECTORS):
            obs = sensorcfg.Feature(kind, element, update_interval=1 + j % 2)
            obs.reader(physics)
            stages = [MISALIGN[j % 3], DRAWN[j], MISALIGN[(j + 1) % 3], DRAWN[j + 5]]
            obs.noise = build_noise(stages, obs.array_spec.shape, np.float64, physics.timestep)
            out[f"turned{j}"] = obs
        obs = sensorcfg.Feature("xpos", ["site:hand_site", "site:imu"], update_interval=2)  # a walk, then a turn
        obs.reader(physics)
        obs.noise = build_noise([DRAWN[6], MISALIGN[2], DRAWN[7], MISALIGN[0]], (2, 3), np.float64, physics.timestep)
        out["walked"] = obs
        obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"])  # a blend kept in bounds after a walk
        obs.reader(physics)
        obs.noise = build_noise([DRAWN[7], {"type": "clip", "min": 0.5, "max": 0.6}], (2,), np.float64,
                                physics.timestep)
        out["walked_clipped"] = obs
        for obs in out.values():
            obs.enabled = True
        leveled(out)
        return out

    restarts = {t: [t % 2] for t in range(3, 30, 3)}
    assert replay_episodes(make, 2, 2, 30, 7, restarts, {12: 0.3}) > 4

