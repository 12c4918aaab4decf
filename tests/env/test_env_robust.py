"""Environments after an exception from user code, and copies of environments.

Rule (docs/semantics.md): an exception raised during a step by user code (a generic sensor, custom
noise, `reward_fn`, `termination_fn`) propagates and ends the episode; the next step starts a new one
(FIRST), whose observations are those of a fresh environment. Environments cannot be copied or pickled:
their sensors are bound to their own MjData, so a copy would read the original's physics.
"""

from __future__ import annotations

import copy
import re
import pickle
import sys
import types

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets

ROBOT = str(assets.path("robot.xml"))
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4
needs_batch = pytest.mark.skipif(not MUJOCO4, reason=f"mujoco.batch needs MuJoCo 4; this is {mujoco.__version__}")


class Boom(Exception):
    pass


class FailOnCall:
    """A callable that raises on its `fail_at`-th call (1-based), counting calls."""

    def __init__(self, fail_at: int, value=lambda physics: np.array([physics.data.time])):
        self.calls, self.fail_at, self.value = 0, fail_at, value

    def __call__(self, *args):
        self.calls += 1
        if self.calls == self.fail_at:
            raise Boom(f"call {self.calls}")
        return self.value(*args)


def suite(generic=None) -> dict[str, sensorcfg.Observable]:
    obs = {"joint_pos": sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], delay=2, buffer_size=3),
           "hand": sensorcfg.Feature("xpos", "site:hand_site", update_interval=4, buffer_size=2)}
    if generic is not None:
        obs["time"] = sensorcfg.Generic(generic, buffer_size=2)
    for o in obs.values():
        o.enabled = True
    return obs


def episode(env, actions) -> list:
    steps = [env.reset()]
    steps += [env.step(a) for a in actions]
    return steps


def same_observations(a, b) -> None:
    for x, y in zip(a, b):
        assert x.step_type == y.step_type
        for k in x.observation:
            assert x.observation[k].tobytes() == y.observation[k].tobytes(), k


ACTIONS = np.random.default_rng(0).uniform(-1, 1, (12, 3))


def _generic(fail_at):
    return dict(suite=suite(FailOnCall(fail_at)))


def _reward(fail_at):
    return dict(suite=suite(), reward_fn=FailOnCall(fail_at, lambda physics: 1.0))


def _termination(fail_at):
    return dict(suite=suite(), termination_fn=FailOnCall(fail_at, lambda physics: False))


def _custom_noise(fail_at):
    from sensorcfg.noise import build_noise

    obs = suite()
    calls = FailOnCall(fail_at, lambda value, random_state: value)

    def fail(value, random_state):
        return calls(value, random_state)

    module = types.ModuleType("robust_noise_module")
    module.fail = fail  # type: ignore[attr-defined]
    sys.modules["robust_noise_module"] = module
    obs["joint_pos"].noise = build_noise([{"type": "custom", "callable": "robust_noise_module:fail"}], (2,),
                                         np.float64, 0.002)
    return dict(suite=obs)


@pytest.mark.parametrize("make", [
    pytest.param(_generic, id="generic-sensor"),
    pytest.param(_reward, id="reward_fn"),
    pytest.param(_termination, id="termination_fn"),
    pytest.param(_custom_noise, id="custom-noise"),
])
def test_an_exception_from_user_code_ends_the_episode(make):
    """The step re-raises; the next step is a FIRST whose episode is a fresh environment's, bit for bit."""
    kwargs = make(fail_at=8)
    env = sensorcfg.Environment(ROBOT, kwargs.pop("suite"), physics_steps_per_control_step=3, seed=5, **kwargs)
    env.reset()
    with pytest.raises(Boom):
        for a in ACTIONS:
            env.step(a)
    restarted = env.step(ACTIONS[0])
    assert restarted.first()
    after = [restarted] + [env.step(a) for a in ACTIONS[1:6]]
    # a fresh environment whose user code never fails, reset at the same point of the seed's stream
    fresh_kwargs = make(fail_at=-1)
    fresh = sensorcfg.Environment(ROBOT, fresh_kwargs.pop("suite"), physics_steps_per_control_step=3, seed=5,
                                  **fresh_kwargs)
    fresh.reset()  # the first episode of `env`, which ended in the exception
    same_observations(after, episode(fresh, ACTIONS[1:6]))


def test_a_bad_action_changes_nothing():
    env = sensorcfg.Environment(ROBOT, suite(), physics_steps_per_control_step=3, seed=5)
    env.reset()
    env.step(ACTIONS[0])
    with pytest.raises(sensorcfg.ArgumentError, match="action must have shape"):
        env.step(np.zeros(7))
    assert env.step(ACTIONS[1]).mid()  # the episode goes on


def test_an_exception_from_initialize_episode_leaves_the_next_step_resetting():
    calls = FailOnCall(2, lambda physics, random_state: None)
    env = sensorcfg.Environment(ROBOT, suite(), physics_steps_per_control_step=3, seed=5, initialize_episode=calls)
    env.reset()
    env.step(ACTIONS[0])
    with pytest.raises(Boom):
        env.reset()
    assert env.step(ACTIONS[1]).first()


@needs_batch
def test_an_exception_from_batch_user_code_ends_every_episode():
    from sensorcfg.batch import BatchEnvironment

    nsim = 3
    reward = FailOnCall(4, lambda batch: np.zeros(nsim))
    env = BatchEnvironment(ROBOT, suite(), nsim, physics_steps_per_control_step=3, seed=2, reward_fn=reward)
    actions = np.zeros((nsim, 3))
    env.reset()
    with pytest.raises(Boom):
        for _ in range(6):
            env.step(actions)
    restarted = env.step(actions)
    assert restarted.first().all()
    fresh = BatchEnvironment(ROBOT, suite(), nsim, physics_steps_per_control_step=3, seed=2)
    fresh.reset()
    fresh_first = fresh.reset()  # the same point of each simulation's stream: the second episode
    for k in restarted.observation:
        np.testing.assert_array_equal(restarted.observation[k], fresh_first.observation[k], err_msg=k)
    assert env.step(actions).mid().all()


@needs_batch
def test_an_exception_in_the_step_that_restarts_a_simulation_restarts_it_once():
    """Rewards and terminations come before the step's restarts (as on the Warp engine): when one raises, a
    simulation whose episode had ended is not restarted yet, and the next step starts the next episode of every
    simulation, the second of each here (a restart before the exception would have used one more: its third)."""
    from sensorcfg.batch import BatchEnvironment
    from sensorcfg.noise import build_noise

    def noisy() -> dict[str, sensorcfg.Observable]:
        obs = suite()
        obs["noisy"] = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"])  # (read at the reset too)
        obs["noisy"].noise = build_noise([{"type": "gaussian", "std": 0.1}], (2,), np.float64, 0.002)
        obs["noisy"].enabled = True
        return obs

    nsim = 2
    ends = FailOnCall(-1, lambda batch: np.array([ends.calls == 1, False]))  # simulation 0 ends at the first step
    env = BatchEnvironment(ROBOT, noisy(), nsim, seed=2, reward_fn=FailOnCall(2, lambda batch: np.zeros(nsim)),
                           termination_fn=ends)
    actions = np.zeros((nsim, 3))
    env.reset()
    assert env.step(actions).step_type.tolist() == [2, 1]
    with pytest.raises(Boom):
        env.step(actions)  # simulation 0 was to restart in it
    restarted = env.step(actions)
    assert restarted.first().all()
    fresh = BatchEnvironment(ROBOT, noisy(), nsim, seed=2)
    fresh.reset()
    second = fresh.reset()
    for k in restarted.observation:
        np.testing.assert_array_equal(restarted.observation[k], second.observation[k], err_msg=k)


def _envs():
    yield "Environment", lambda: sensorcfg.Environment(ROBOT, suite(), seed=1)
    if MUJOCO4:
        from sensorcfg.batch import BatchEnvironment

        yield "BatchEnvironment", lambda: BatchEnvironment(ROBOT, suite(), 2, seed=1)


@pytest.mark.parametrize("how", [copy.copy, copy.deepcopy, pickle.dumps], ids=["copy", "deepcopy", "pickle"])
@pytest.mark.parametrize("name,make", list(_envs()), ids=[name for name, _ in _envs()])
def test_copies_and_pickles_raise_a_clear_error(name, make, how):
    env = make()
    env.reset()
    article = "an" if name == "Environment" else "a"
    with pytest.raises(TypeError, match=rf"{article} {name} cannot be copied or pickled: its sensors are bound to its own "
                                        r"MjData and renderers, so a copy would read the original's physics; build "
                                        rf"another {name} from the same model and suite"):
        how(env)
    env.step(np.zeros(env.action_spec().shape))  # the original is untouched


@pytest.mark.parametrize("seed", [-1, 2**40, 1.5, "0", True], ids=["negative", "too-large", "float", "text", "bool"])
def test_a_bad_seed_is_an_argument_error(seed):
    with pytest.raises(sensorcfg.ArgumentError, match="seed must be None, an integer from 0 to 2\\*\\*32 - 1"):
        sensorcfg.Environment(ROBOT, suite(), seed=seed)
    if MUJOCO4 and seed != 2**40:  # a batch's root seed is a SeedSequence's entropy: any non-negative integer
        from sensorcfg.batch import BatchEnvironment

        with pytest.raises(sensorcfg.ArgumentError, match="seed must be None, a non-negative integer"):
            BatchEnvironment(ROBOT, suite(), 2, seed=seed)


@pytest.mark.parametrize("model", [42, b"robot.xml", ["robot.xml"]], ids=["int", "bytes", "list"])
def test_a_model_of_another_type_is_an_argument_error(model):
    """Found by review: make_env(path, model=42) raised numpy's or os's raw TypeError."""
    with pytest.raises(sensorcfg.ArgumentError, match="model must be an MjModel, an MjSpec, a model path"):
        sensorcfg.Environment(model, suite())
    if MUJOCO4:
        from sensorcfg.batch import BatchEnvironment

        with pytest.raises(sensorcfg.ArgumentError, match="model must be an MjModel, an MjSpec, a model path"):
            BatchEnvironment(model, suite(), 2)


def test_the_physics_copies_independently_both_ways():
    """What the error message suggests works: a new environment with the state copied reads its own physics."""
    a = sensorcfg.Environment(ROBOT, suite(), physics_steps_per_control_step=2, seed=1)
    a.reset()
    for act in ACTIONS[:4]:
        a.step(act)
    b = sensorcfg.Environment(ROBOT, suite(), physics_steps_per_control_step=2, seed=1)
    b.reset()
    mujoco.mj_copyData(b.physics.data, b.physics.model, a.physics.data)
    qpos_a = a.physics.data.qpos.copy()
    b.step(np.ones(3))
    np.testing.assert_array_equal(a.physics.data.qpos, qpos_a)  # stepping the copy leaves the original
    qpos_b = b.physics.data.qpos.copy()
    a.step(-np.ones(3))
    np.testing.assert_array_equal(b.physics.data.qpos, qpos_b)  # and the other way round


ZERO_WIDTH = f"""\
model: package://sensorcfg/assets/robot.xml
sensors:
  nothing:
    kind: qpos
    element: joint:shoulder
    index: "0:0"
    buffer: 3
    aggregator: mean
  fine:
    kind: qpos
    element: joint:shoulder
    index: "0:0"
"""


def test_zero_width_features_with_an_aggregator_are_a_problem_at_its_line():
    suite = sensorcfg.loads(ZERO_WIDTH, file="s.yaml")
    (problem,) = suite.check()
    assert problem.format() == ("s.yaml:8:17: error: sensors.nothing.aggregator: the value has no entries (shape (0,)), "
                                "so 'mean' has nothing to reduce (min and max raise, mean and median give nan); "
                                "remove the aggregator or select elements that have this value")
    with pytest.raises(sensorcfg.SuiteError, match="s.yaml:8:17: error: sensors.nothing.aggregator"):
        sensorcfg.Environment(ROBOT, suite)
    if MUJOCO4:
        from sensorcfg.batch import BatchEnvironment

        with pytest.raises(sensorcfg.SuiteError, match="s.yaml:8:17: error: sensors.nothing.aggregator"):
            BatchEnvironment(ROBOT, suite, 2)


_ZERO_STEP_SUITE = """\
model: zero.xml
options: {control_interval: 10ms}
sensors:
  q: {kind: qpos, element: joint:hip_f, interval: 2, delay: 4ms,
      noise: [{type: gaussian, density: 0.1}, {type: lowpass, cutoff: 10Hz}]}
"""
_ZERO_STEP = ("s.yaml:1:8: error: model: the model's physics timestep (<option timestep>) is 0 s; a suite's intervals, "
              "delays, rates and noise are timed in physics steps of it, which must last a positive, finite time: give "
              "the model a timestep such as <option timestep=\"0.002\"/>")


@pytest.mark.parametrize("timestep", ["0", "-0.001", "inf"])
def test_a_model_whose_step_lasts_no_time_is_a_problem_at_the_model_line(tmp_path, monkeypatch, capsys, timestep):
    """MuJoCo compiles timestep="0": every time in the suite would be divided by it. validate, run, spec and
    both environments say so at the model line, once."""
    from sensorcfg.cli import main

    text = open(assets.path("robot.xml")).read()
    assert 'timestep="0.002"' in text
    (tmp_path / "zero.xml").write_text(text.replace('timestep="0.002"', f'timestep="{timestep}"'))
    (tmp_path / "s.yaml").write_text(_ZERO_STEP_SUITE)
    monkeypatch.chdir(tmp_path)
    expected = _ZERO_STEP.replace("is 0 s", f"is {float(timestep):g} s")
    suite = sensorcfg.load("s.yaml")
    assert [p.format() for p in suite.check()] == [expected]
    for command in (["validate", "s.yaml"], ["run", "s.yaml", "--steps", "3"], ["spec", "s.yaml"]):
        assert main(command) == 1, command
        out = capsys.readouterr()
        assert expected in (out.out + out.err).splitlines(), command
    with pytest.raises(sensorcfg.SuiteError, match="^" + re.escape(expected) + "$"):
        sensorcfg.Environment("zero.xml", suite)
    if MUJOCO4:
        from sensorcfg.batch import BatchEnvironment

        with pytest.raises(sensorcfg.SuiteError, match="^" + re.escape(expected) + "$"):
            BatchEnvironment("zero.xml", suite, 2)
    model = mujoco.MjModel.from_xml_path("zero.xml")
    for settings in ({"control_timestep": 0.01}, {"time_limit": 1.0}):
        with pytest.raises(sensorcfg.ArgumentError, match="is in seconds: the model's physics timestep"):
            sensorcfg.Environment(model, {"q": sensorcfg.Feature("qpos", "joint:*")}, **settings)
