"""Suites inside dm_control: dm_control's own Updater runs the adapted observables (oracle environment)."""

from __future__ import annotations

import numpy as np

import sensorcfg
from sensorcfg import assets

from conftest import ROOT

CONFIGS = ROOT / "configs"


def dm_physics(oracle):
    from dm_control import mujoco as dm_mujoco

    return dm_mujoco.Physics.from_xml_path(str(assets.path("robot.xml")))


def run_dm_control(oracle, physics, observables, n, seed, steps=60):
    return run_updater(oracle.updater.Updater(observables, n), physics, n, seed, steps)


def run_updater(updater, physics, n, seed, steps=60):
    physics.reset()
    physics.data.qvel[:] = 0.3
    updater.reset(physics, np.random.RandomState(seed))
    out = [updater.get_observation()]
    for _ in range(steps):
        updater.prepare_for_next_control_step()
        for _ in range(n):
            physics.step()
            updater.update()
        out.append(updater.get_observation())
    return out


def test_dm_control_updater_runs_a_clean_suite_exactly_like_ours(oracle):
    suite = sensorcfg.load(CONFIGS / "imu.yaml")
    physics = dm_physics(oracle)
    n = suite.updater_kwargs(physics.model.ptr)["physics_steps_per_control_step"]
    theirs = run_dm_control(oracle, physics, sensorcfg.dm_control_observables(suite, physics), n, seed=0)
    ours = run_dm_control(oracle, physics, suite.build(physics.model.ptr), n, seed=0)  # duck-typed: ours in theirs
    reference = sensorcfg.Updater(suite.build(physics.model.ptr), n)
    physics.reset()
    physics.data.qvel[:] = 0.3
    reference.reset(physics, np.random.RandomState(0))
    mine = [reference.get_observation()]
    for _ in range(60):
        reference.prepare_for_next_control_step()
        for _ in range(n):
            physics.step()
            reference.update()
        mine.append(reference.get_observation())
    for a, b, c in zip(theirs, ours, mine):
        for name in a:
            np.testing.assert_array_equal(a[name], c[name], err_msg=name)
            np.testing.assert_array_equal(b[name], c[name], err_msg=name)


def test_noise_and_random_delays_run_under_dm_control_deterministically(oracle):
    suite = sensorcfg.load(CONFIGS / "sim2real.yaml")
    physics = dm_physics(oracle)
    n = suite.updater_kwargs(physics.model.ptr)["physics_steps_per_control_step"]
    first = run_dm_control(oracle, physics, sensorcfg.dm_control_observables(suite, physics), n, seed=3)
    second = run_dm_control(oracle, physics, sensorcfg.dm_control_observables(suite, physics), n, seed=3)
    clean = run_dm_control(oracle, physics, sensorcfg.dm_control_observables(CONFIGS / "proprioception.yaml",
                                                                            physics), n, seed=3)
    for a, b in zip(first, second):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert not np.array_equal(first[-1]["arm_qpos"], clean[-1]["arm_qpos"])  # the noise is applied


def test_schedule_callables_get_the_random_state_by_one_rule(oracle):
    # dm_control calls a callable with an optional random_state bare; one requiring it gets the episode's.
    # Our Updater and the adapter (under dm_control's Updater) follow the same rule: `takes_random_state`.
    from sensorcfg.draws import takes_random_state

    seen = {"optional": [], "required": []}

    def optional(random_state=None):
        seen["optional"].append(random_state)
        return 2

    def required(random_state):
        seen["required"].append(random_state)
        return 3

    assert not takes_random_state(optional) and takes_random_state(required)
    physics = dm_physics(oracle)
    for runner in ("ours", "dm_control"):
        seen["optional"].clear()
        seen["required"].clear()
        observables = {"a": sensorcfg.Feature("qpos", "joint:shoulder", update_interval=optional, delay=required)}
        observables["a"].enabled = True
        random_state = np.random.RandomState(0)
        if runner == "ours":
            updater = sensorcfg.Updater(observables, 2)
        else:
            from sensorcfg.env.dm_control_adapter import BridgedObservable

            updater = oracle.updater.Updater({"a": BridgedObservable("a", observables["a"])}, 2)
        updater.reset(physics, random_state)
        updater.prepare_for_next_control_step()
        assert seen["optional"] and all(rs is None for rs in seen["optional"]), runner
        assert seen["required"] and all(rs is random_state for rs in seen["required"]), runner


def test_noise_under_dm_control_is_our_updaters_noise(oracle):
    # one episode entropy shared by the suite (drawn as our Updater draws it) and counter-based numbers:
    # stateless stages and random walks give each sample what our Updater gives it, bit for bit
    noise = ("[{type: bias, std: 0.1}, {type: gaussian, std: 0.05}, {type: outlier, p: 0.2, scale: 1}, "
             "{type: random_walk, std: 0.1, correlation_time: 50ms}, {type: quantize, step: 0.01}, "
             "{type: dropout, p: 0.2, mode: zero, per: value}, {type: clip, min: -3, max: 3}]")
    suite = sensorcfg.loads(f"""
version: 1
model: package://sensorcfg/assets/robot.xml
options: {{control_interval: 10ms}}
sensors:
  gyro: {{kind: sensordata, element: "sensor:imu_gyro", interval: 4ms, buffer: 3, aggregator: mean, noise: {noise}}}
  arm: {{kind: qpos, element: ["joint:shoulder", "joint:elbow"], delay: 2ms, buffer: 2, noise: {noise}}}
  clean: {{kind: qvel, element: "joint:elbow"}}
  hand: {{kind: xpos, element: "site:hand_site", interval: 6ms, delay: 4ms, noise: {noise}}}
""")
    physics = dm_physics(oracle)
    n = suite.updater_kwargs(physics.model.ptr)["physics_steps_per_control_step"]

    theirs = run_dm_control(oracle, physics, sensorcfg.dm_control_observables(suite, physics), n, seed=3)
    mine = run_updater(sensorcfg.Updater(suite.build(physics.model.ptr), n), physics, n, seed=3)
    assert any(not np.array_equal(a, b) for a, b in zip(theirs[5].values(), theirs[6].values()))
    for step, (a, c) in enumerate(zip(theirs, mine)):
        for name in a:
            np.testing.assert_array_equal(a[name], c[name], err_msg=f"{name} at control step {step}")
