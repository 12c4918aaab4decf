"""The dm_env Environment: conformance, determinism, episode isolation, episode ends, bad input."""

from __future__ import annotations

import math
import unittest

import dm_env
import mujoco
import numpy as np
import pytest
from dm_env import test_utils

import sensorcfg
from sensorcfg import ArgumentError, assets

ROBOT = str(assets.path("robot.xml"))


def proprio() -> dict[str, sensorcfg.Observable]:
    obs = {
        "joint_pos": sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], delay=2),
        "gyro": sensorcfg.Feature("sensordata", "sensor:imu_gyro", buffer_size=3, aggregator="mean"),
        "hand": sensorcfg.Feature("xpos", "site:hand_site", update_interval=4, buffer_size=2),
        "time": sensorcfg.Generic(lambda physics: np.array([physics.data.time])),
    }
    for o in obs.values():
        o.enabled = True
    return obs


class ProprioConformance(test_utils.EnvironmentTestMixin, unittest.TestCase):
    def make_object_under_test(self):
        return sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=5, time_limit=0.2, seed=3)


def run(env: sensorcfg.Environment, actions: np.ndarray) -> list[dict[str, np.ndarray]]:
    out = [env.reset().observation]
    for a in actions:
        out.append(env.step(a).observation)
    return out


def test_same_seed_same_actions_same_observations_bit_for_bit():
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 3))
    a = run(sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=4, seed=7), actions)
    b = run(sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=4, seed=7), actions)
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        for k in x:
            assert x[k].tobytes() == y[k].tobytes(), k


def test_reset_clears_buffers_between_episodes():
    env = sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=5, seed=1)
    first = env.reset().observation
    for _ in range(30):
        env.step(np.ones(3))
    again = env.reset().observation
    for k in first:
        np.testing.assert_array_equal(first[k], again[k], err_msg=k)
    # the delayed joint positions are zero-padded at reset, not left over from the last episode
    np.testing.assert_array_equal(again["joint_pos"], np.zeros((1, 2)))
    assert env.updater.samples_taken()["time"] == 1


def test_reset_after_reset_is_well_defined():
    env = sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=5, seed=1)
    a = env.reset().observation
    b = env.reset().observation
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])


def test_time_limit_truncates_with_discount_one():
    env = sensorcfg.Environment(ROBOT, proprio(), control_timestep=0.01, time_limit=0.05)
    env.reset()
    steps = [env.step(np.zeros(3)) for _ in range(5)]
    assert [s.step_type for s in steps[:-1]] == [dm_env.StepType.MID] * 4
    assert steps[-1].last() and steps[-1].discount == 1.0
    assert env.step(np.zeros(3)).first()  # stepping after the end starts a new episode


MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4
LIMITS = [  # (time_limit, control steps of 0.01 s or the message of the ArgumentError)
    pytest.param(None, None, id="None"),
    pytest.param(float("inf"), None, id="inf"),
    pytest.param(np.float64(np.inf), None, id="numpy-inf"),
    pytest.param(0.05, 5, id="seconds"),
    pytest.param(1, 100, id="integer-seconds"),
    pytest.param(0.001, 1, id="under-a-step"),
    pytest.param((2**32 + 3) * 0.01, 2**32 + 3, id="beyond-int32"),
    pytest.param(1e17, "time_limit 1e\\+17s is more than 9,223,372,036,854,775,807 control "
                 "steps of 0.01s \\(9.223e\\+16s\\), the most an episode can count; give at most 9.223e\\+16s, or None "
                 "or float\\('inf'\\) for no limit", id="beyond-int64"),
    pytest.param(10**400, "time_limit 1000.*s is more than 9,223,372,036,854,775,807 control steps", id="huge-int"),
    pytest.param(0, "time_limit must be a positive number of seconds, or None or float\\('inf'\\) for no limit; "
                 "got 0$", id="zero"),
    pytest.param(-math.inf, "positive number of seconds.*; got -inf", id="minus-inf"),
    pytest.param(math.nan, "positive number of seconds.*; got nan", id="nan"),
    pytest.param(True, "positive number of seconds.*; got True", id="bool"),
    pytest.param("5", "positive number of seconds.*; got '5'", id="string"),
]


@pytest.mark.parametrize("time_limit, expected", LIMITS)
def test_a_time_limit_is_whole_control_steps_none_or_an_argument_error(time_limit, expected):
    """One rule for every environment (`loop.episode.step_limit`): inf or None is no limit; what no engine's step
    counter holds, or what is not positive seconds, is an ArgumentError saying what fits."""
    from sensorcfg.loop.episode import step_limit

    envs = [lambda: sensorcfg.Environment(ROBOT, proprio(), control_timestep=0.01, time_limit=time_limit)]
    if MUJOCO4:
        from sensorcfg.batch import BatchEnvironment

        envs.append(lambda: BatchEnvironment(ROBOT, proprio_batch(), 2, control_timestep=0.01, time_limit=time_limit))
    if isinstance(expected, str):
        with pytest.raises(ArgumentError, match=expected):
            step_limit(time_limit, 0.002, 0.01)
        for make in envs:
            with pytest.raises(ArgumentError, match=expected):
                make()
        return
    assert step_limit(time_limit, 0.002, 0.01) == expected
    for make in envs:
        assert make()._step_limit == expected


def proprio_batch() -> dict[str, sensorcfg.Observable]:
    return {k: v for k, v in proprio().items() if k != "time"}  # (a batch runs no per-simulation callable)


def test_no_time_limit_never_ends_the_episode():
    env = sensorcfg.Environment(ROBOT, proprio(), control_timestep=0.01, time_limit=float("inf"))
    env.reset()
    assert all(env.step(np.zeros(3)).mid() for _ in range(50))


def test_termination_fn_ends_with_discount_zero_and_reward_fn_is_used():
    env = sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=5,
                                reward_fn=lambda p: float(p.data.time),
                                termination_fn=lambda p: p.data.time > 0.05)
    env.reset()
    while True:
        ts = env.step(np.zeros(3))
        if ts.last():
            break
    assert ts.discount == 0.0 and ts.reward == pytest.approx(env.physics.data.time)


def test_diverged_simulation_ends_the_episode_and_says_so():
    xml = """<mujoco><option timestep="0.01"/><worldbody><body><freejoint/>
             <geom size=".1" mass="1e-9"/></body></worldbody></mujoco>""".replace("<freejoint/>", "<freejoint name=\"j\"/>")
    model = mujoco.MjModel.from_xml_string(xml)
    obs = {"q": sensorcfg.Feature("qpos", "joint:*")}
    obs["q"].enabled = True

    def explode(physics, random_state):
        physics.data.qvel[:] = 1e300

    env = sensorcfg.Environment(model, obs, initialize_episode=explode)
    env.reset()
    with pytest.warns(RuntimeWarning, match="diverged"):
        ts = env.step(np.zeros(0))
    assert ts.last() and ts.discount == 0.0
    assert env.last_divergence


def test_action_spec_from_ctrlrange_and_bad_action_shape():
    env = sensorcfg.Environment(ROBOT, proprio())
    spec = env.action_spec()
    assert spec.shape == (3,)
    np.testing.assert_array_equal(spec.minimum, [-1, -1, 0])
    np.testing.assert_array_equal(spec.maximum, [1, 1, 0.04])
    env.reset()
    with pytest.raises(ArgumentError, match=r"action must have shape \(3,\)"):
        env.step(np.zeros(2))


def test_control_timestep_must_be_whole_steps():
    with pytest.raises(ArgumentError, match=r"not a whole number of 0.002s physics steps; use 0.006s or 0.008s"):
        sensorcfg.Environment(ROBOT, proprio(), control_timestep=0.007)
    env = sensorcfg.Environment(ROBOT, proprio(), control_timestep=0.01)
    assert env.physics_steps_per_control_step == 5


def test_initialize_episode_and_keyframe():
    calls = []
    env = sensorcfg.Environment(ROBOT, proprio(), seed=0,
                                initialize_episode=lambda p, rs: calls.append(rs.uniform()))
    env.reset()
    env.reset()
    assert len(calls) == 2 and calls[0] != calls[1]


def test_observation_spec_matches_observations():
    env = sensorcfg.Environment(ROBOT, proprio(), physics_steps_per_control_step=3)
    spec = env.observation_spec()
    ts = env.reset()
    for _ in range(3):
        for name, value in ts.observation.items():
            spec[name].validate(value)
        ts = env.step(np.zeros(3))


# dm_env's own conformance tests, for the bundled model with each example suite (and the demo suite).
from pathlib import Path  # noqa: E402

from conftest import ROOT

SUITES = sorted((ROOT / "configs").glob("*.yaml")) + [assets.path("demo.yaml")]


def _conformance_case(suite_path: Path) -> type:
    class Case(test_utils.EnvironmentTestMixin, unittest.TestCase):
        def make_object_under_test(self):
            return sensorcfg.make_env(suite_path, time_limit=0.1, seed=0)

    Case.__name__ = Case.__qualname__ = f"SuiteConformance_{suite_path.stem}"
    return Case


for _path in SUITES:
    globals()[f"SuiteConformance_{_path.stem}"] = _conformance_case(_path)


def test_make_env_uses_the_suites_model_and_control_interval():
    env = sensorcfg.make_env(ROOT / "configs" / "proprioception.yaml")
    assert env.physics_steps_per_control_step == 10  # options.control_interval: 20ms at 2ms steps
    assert env.physics.model.nq == mujoco.MjModel.from_xml_path(ROBOT).nq
    assert sensorcfg.make_env(SUITES[0], physics_steps_per_control_step=3).physics_steps_per_control_step == 3


def test_noisy_suite_is_bit_identical_for_a_seed_and_differs_across_seeds():
    suite = ROOT / "configs" / "sim2real.yaml"
    actions = np.random.default_rng(1).uniform(-1, 1, (20, 3))
    a = run(sensorcfg.make_env(suite, seed=5), actions)
    b = run(sensorcfg.make_env(suite, seed=5), actions)
    c = run(sensorcfg.make_env(suite, seed=6), actions)
    assert all(x[k].tobytes() == y[k].tobytes() for x, y in zip(a, b) for k in x)
    assert any(x[k].tobytes() != z[k].tobytes() for x, z in zip(a, c) for k in x)


def test_no_noise_state_survives_an_episode():
    """Per-episode draws (bias) are made at reset: the same random state gives the same first episode."""
    suite = ROOT / "configs" / "sim2real.yaml"
    env = sensorcfg.make_env(suite, seed=5)
    first = run(env, np.zeros((10, 3)))
    env.seed(5)  # same stream again: the second run must not remember the first
    again = run(env, np.zeros((10, 3)))
    assert all(x[k].tobytes() == y[k].tobytes() for x, y in zip(first, again) for k in x)
