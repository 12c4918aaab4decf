"""BatchEnvironment: each simulation against the single-simulation Environment, bit for bit.

The differential tests draw random suites (intervals 1-8, delays 0-8, drawn `{uniform}` / `{choice}`
intervals and delays, buffers, aggregators, noise stages) and compare every simulation's observations,
step types, rewards and discounts with `Environment(model, suite, seed=sim_seed(seed, i))` given the same
actions, through time-limit auto-resets and partial resets.
"""

from __future__ import annotations

import re
import warnings

import dm_env
import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import ArgumentError, SuiteError, UnsupportedError, assets
from sensorcfg.batch import BatchEnvironment, sim_seed
from sensorcfg.draws import ChoiceSteps, UniformSteps
from sensorcfg.noise import build_noise
from sensorcfg.physics import Physics

from conftest import ROOT

ROBOT = str(assets.path("robot.xml"))
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4
needs_batch = pytest.mark.skipif(not MUJOCO4, reason=f"mujoco.batch needs MuJoCo 4; this is {mujoco.__version__}")

FEATURES = [
    ("qpos", ["joint:shoulder", "joint:elbow"]),
    ("qvel", "joint:elbow"),
    ("qacc", ["joint:shoulder", "joint:elbow"]),
    ("qpos", "joint:wrist"),
    ("sensordata", "sensor:imu_gyro"),
    ("sensordata", "sensor:imu_accel"),
    ("xpos", "site:hand_site"),
    ("xmat", "site:fingertip"),
    ("xquat", "body:hand"),
    ("cvel", "body:forearm"),
    ("qfrc_actuator", ["joint:shoulder", "joint:elbow"]),
    ("force", "actuator:elbow_motor"),
]

NOISE = [
    {"type": "gaussian", "std": 0.01},
    {"type": "gaussian", "mean": 0.001, "std": 0.02},
    {"type": "uniform", "low": -0.01, "high": 0.02},
    {"type": "bias", "std": 0.1},
    {"type": "scale", "low": 0.9, "high": 1.1},
    {"type": "random_walk", "std": 0.01, "correlation_time": 0.05},
    {"type": "random_walk", "std": 0.01},
    {"type": "quantize", "step": 0.001},
    {"type": "clip", "min": -0.5, "max": 0.5},
    {"type": "dropout", "p": 0.3, "mode": "hold"},
    {"type": "dropout", "p": 0.3, "mode": "zero", "per": "value"},
    {"type": "dropout", "p": 0.2, "mode": "nan"},
    {"type": "outlier", "p": 0.1, "scale": 1.0},
    {"type": "lowpass", "cutoff": 20.0},
]


def _schedule(rng: np.random.Generator, low: int, high: int, drawn: bool):
    if drawn and rng.random() < 0.3:
        lo = int(rng.integers(low, high + 1))
        return UniformSteps(lo, int(rng.integers(lo, high + 1)))
    if drawn and rng.random() < 0.15:
        values = tuple(int(v) for v in rng.integers(low, high + 1, size=int(rng.integers(1, 4))))
        return ChoiceSteps(values)
    return int(rng.integers(low, high + 1))


def random_suite(seed: int, *, drawn: bool = True, noise: bool = True) -> dict[str, sensorcfg.Observable]:
    """A fresh dict of observables (bound once to read shapes, so noise fits them)."""
    rng = np.random.default_rng(seed)
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
    out = {}
    for j in range(int(rng.integers(3, 8))):
        kind, element = FEATURES[int(rng.integers(len(FEATURES)))]
        buffer = int(rng.integers(1, 6)) if rng.random() < 0.8 else int(rng.integers(8, 14))  # long ones sum pairwise
        aggregator = [None, None, "min", "max", "sum", "mean", "median"][int(rng.integers(7))]
        obs = sensorcfg.Feature(kind, element, update_interval=_schedule(rng, 1, 8, drawn),
                                delay=_schedule(rng, 0, 8, drawn), buffer_size=buffer, aggregator=aggregator)
        obs.reader(physics)
        if noise and rng.random() < 0.6:
            picks = rng.choice(len(NOISE), size=int(rng.integers(1, 4)), replace=False)
            spec = obs.array_spec
            obs.noise = build_noise([NOISE[int(p)] for p in picks], spec.shape, spec.dtype, physics.timestep)
        obs.enabled = True
        out[f"s{j}_{kind}"] = obs
    return out


def same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def check_sim(batch_steps, single_steps, i: int, where: str) -> None:
    for s, (bt, st) in enumerate(zip(batch_steps, single_steps)):
        assert int(bt.step_type[i]) == int(st.step_type), f"{where}: sim {i} step {s} step type"
        if not st.first():
            assert bt.reward[i] == (st.reward or 0.0) and bt.discount[i] == st.discount, f"{where}: sim {i} step {s}"
        assert bt.observation.keys() == st.observation.keys()
        for k, v in st.observation.items():
            assert same(bt.observation[k][i], v), f"{where}: sim {i} step {s} {k}: {bt.observation[k][i]} != {v}"


def run_pair(suite_seed: int, nsim: int, steps: int, *, seed=7, n=3, time_limit=None, resets=(), **suite_kw):
    """The batch's TimeSteps, and each simulation's single-simulation TimeSteps, for the same actions.

    `resets`: (step, ids) pairs: before that step, `reset(ids)` on the batch and `reset()` on those singles.
    """
    env = BatchEnvironment(ROBOT, random_suite(suite_seed, **suite_kw), nsim, nthread=2,
                           physics_steps_per_control_step=n, time_limit=time_limit, seed=seed)
    singles = [sensorcfg.Environment(ROBOT, random_suite(suite_seed, **suite_kw), physics_steps_per_control_step=n,
                                     time_limit=time_limit, seed=sim_seed(seed, i)) for i in range(nsim)]
    lo, hi = env.action_spec().minimum, env.action_spec().maximum
    actions = np.random.default_rng(suite_seed).uniform(lo, hi, (steps, nsim, len(lo)))
    resets = dict(resets)
    batch_steps = [env.reset()]
    single_steps = [[e.reset()] for e in singles]
    for s, a in enumerate(actions):
        if s in resets:
            ids = resets[s]
            batch_steps.append(env.reset(ids))
            for i, e in enumerate(singles):
                single_steps[i].append(e.reset() if i in ids else single_steps[i][-1]._replace(
                    step_type=dm_env.StepType.MID, reward=0.0, discount=1.0))
        batch_steps.append(env.step(a))
        for i, e in enumerate(singles):
            single_steps[i].append(e.step(a[i]))
    return env, batch_steps, single_steps


# -- the differential test ---------------------------------------------------------------------------


@needs_batch
@pytest.mark.parametrize("suite_seed", range(12))
def test_each_simulation_is_the_single_environment_bit_for_bit(suite_seed):
    nsim = 5
    rng = np.random.default_rng(1000 + suite_seed)
    resets = [(int(rng.integers(3, 30)), sorted(set(rng.integers(0, nsim, 2).tolist())))]
    _, batch_steps, single_steps = run_pair(suite_seed, nsim, 40, n=int(rng.integers(1, 6)), time_limit=0.06,
                                            resets=resets)
    for i in range(nsim):
        check_sim(batch_steps, [s for s in single_steps[i]], i, f"suite {suite_seed}")


@needs_batch
@pytest.mark.parametrize("suite_seed", range(12, 24))
def test_fixed_noise_free_schedules_read_records_and_history(suite_seed):
    # the path that reads the current control step's samples from the records and older ones from history
    rng = np.random.default_rng(2000 + suite_seed)
    resets = [(int(rng.integers(2, 20)), [int(rng.integers(0, 4))])]
    _, batch_steps, single_steps = run_pair(suite_seed, 4, 30, drawn=False, noise=False, n=int(rng.integers(1, 9)),
                                            time_limit=0.05, resets=resets)
    for i in range(4):
        check_sim(batch_steps, single_steps[i], i, f"suite {suite_seed}")


@needs_batch
def test_pad_with_initial_value_and_strip_follow_the_suite_options():
    suite = sensorcfg.loads(OPTIONS_SUITE)
    env = BatchEnvironment(ROBOT, suite, 3, physics_steps_per_control_step=4, seed=11)
    single = [sensorcfg.Environment(ROBOT, sensorcfg.loads(OPTIONS_SUITE), physics_steps_per_control_step=4,
                                    seed=sim_seed(11, i)) for i in range(3)]
    actions = np.random.default_rng(3).uniform(-1, 1, (20, 3, 3)) * [1, 1, 0.04]
    b = [env.reset()] + [env.step(a) for a in actions]
    for i, e in enumerate(single):
        check_sim(b, [e.reset()] + [e.step(a[i]) for a in actions], i, "options")
    assert b[1].observation["gyro"].shape == (3, 3)  # the singleton buffer is stripped


@needs_batch
@pytest.mark.parametrize("stages", [2, 9], ids=["fused", "too-long-to-fuse"])
def test_additive_noise_applied_in_place_is_the_single_environments(stages):
    """A pipeline of gaussian and uniform stages only is added straight into the history by one kernel pass
    (`streams.add_sums`, up to MAX_TERMS terms); longer sums take the general path. Both equal the single
    Environment's observations bit for bit."""
    noise = ", ".join("{type: gaussian, std: 0.1}" if k % 2 == 0 else "{type: uniform, low: -0.01, high: 0.02}"
                      for k in range(stages))
    text = f"""
version: 1
sensors:
  qpos: {{kind: qpos, element: "joint:*", buffer: 3, noise: [{noise}]}}
  gyro: {{kind: sensordata, element: "sensor:imu_gyro", interval: 2, delay: 1, noise: [{noise}]}}
"""
    env = BatchEnvironment(ROBOT, sensorcfg.loads(text), 3, physics_steps_per_control_step=3, seed=4)
    fused = [p.fused is not None for p in env.updater.noise.values()]
    assert fused == [stages <= 8] * 2
    single = [sensorcfg.Environment(ROBOT, sensorcfg.loads(text), physics_steps_per_control_step=3, seed=sim_seed(4, i))
              for i in range(3)]
    actions = np.random.default_rng(5).uniform(-1, 1, (15, 3, 3)) * [1, 1, 0.04]
    b = [env.reset()] + [env.step(a) for a in actions]
    for i, e in enumerate(single):
        check_sim(b, [e.reset()] + [e.step(a[i]) for a in actions], i, f"{stages} stages")


READ_NOISE_SUITE = """
version: 1
options: {{pad_with_initial_value: {pad}}}
sensors:
  qpos: {{kind: qpos, element: "joint:*", buffer: 3, delay: 2, noise: [{{type: gaussian, std: 0.1}}]}}
  gyro: {{kind: sensordata, element: "sensor:imu_gyro", delay: 1, buffer: 3, aggregator: mean,
          noise: [{{type: gaussian, std: 0.1}}, {{type: uniform, low: -0.01, high: 0.02}}]}}
  hand: {{kind: xpos, element: "site:hand_site", interval: 3, delay: 4, noise: [{{type: uniform, low: 0, high: 0.1}}]}}
  elbow: {{kind: qvel, element: "joint:elbow", buffer: 3, aggregator: max, noise: [{{type: gaussian, mean: 1, std: 0.5}}]}}
  walk: {{kind: qvel, element: "joint:shoulder", delay: 1, noise: [{{type: random_walk, std: 0.1}}]}}
  stack: {{kind: qpos, element: "joint:elbow", interval: 3, buffer: 2, noise: [{{type: gaussian, std: 0.1}}]}}
"""


@needs_batch
@pytest.mark.parametrize("pad", [False, True])
def test_additive_noise_added_as_the_batch_reads_is_the_single_environments(pad):
    """Fixed-schedule sensors whose noise only adds numbers get it as the batch reads (`batch.read_noise`), the
    others in the history (a stateful stage, or a buffer that shows each sample twice: the history
    path draws fewer numbers): buffered, delayed, aggregated, padded or not, through partial resets that leave the
    simulations at different phases and noise levels (0.3 and 0 blend after the addition). Every simulation
    equals its Environment bit for bit."""
    text = READ_NOISE_SUITE.format(pad=str(pad).lower())
    nsim, n = 4, 3
    env = BatchEnvironment(ROBOT, sensorcfg.loads(text), nsim, physics_steps_per_control_step=n, seed=4)
    updater = env.updater
    assert sorted(updater.labels[c] for c in updater.corrupted) == ["stack", "walk"]
    assert updater.read_noise is not None and len(updater.read_noise.sensors) == 4
    singles = [sensorcfg.Environment(ROBOT, sensorcfg.loads(text), physics_steps_per_control_step=n,
                                     seed=sim_seed(4, i)) for i in range(nsim)]
    actions = np.random.default_rng(5).uniform(-1, 1, (30, nsim, 3)) * [1, 1, 0.04]
    resets = {4: (0.3, [1, 2]), 11: (0.0, [2, 3]), 19: (1.0, [0, 2])}  # step: (level, simulations reset)
    b, s = [env.reset()], [[e.reset()] for e in singles]
    for step, a in enumerate(actions):
        if step in resets:
            level, ids = resets[step]
            env.set_noise_level(level)
            b.append(env.reset(ids))
            for i, e in enumerate(singles):
                if i in ids:
                    e.set_noise_level(level)
                s[i].append(e.reset() if i in ids else s[i][-1]._replace(step_type=dm_env.StepType.MID,
                                                                        reward=0.0, discount=1.0))
        b.append(env.step(a))
        for i, e in enumerate(singles):
            s[i].append(e.step(a[i]))
    for i in range(nsim):
        check_sim(b, s[i], i, f"pad {pad}")
    noisy = np.array([t.observation["elbow"][1] for t in b[8:12]])  # simulation 1, at level 0.3: noise scaled
    assert np.all(noisy != 0)


LONG_BUFFERS_SUITE = """
version: 1
sensors:
  sum: {kind: qvel, element: "joint:shoulder", buffer: 12, aggregator: sum}
  mean: {kind: qpos, element: "joint:elbow", delay: 2, buffer: 9, aggregator: mean, noise: [{type: gaussian, std: 0.1}]}
  median: {kind: qvel, element: "joint:elbow", buffer: 10, aggregator: median}
  drawn: {kind: qvel, element: "joint:elbow", delay: {uniform: [0, 3]}, buffer: 11, aggregator: sum}
  wide: {kind: qvel, element: "joint:*", buffer: 12, aggregator: sum}
"""


@needs_batch
def test_long_buffers_of_one_value_samples_are_summed_as_the_single_environment_sums_them():
    """numpy sums a contiguous buffer pairwise from 8 values on: a one-value sensor's buffer is contiguous in the
    Environment's read, so each simulation's is made contiguous in the batch too (fixed and drawn schedules)."""
    nsim = 3
    env = BatchEnvironment(ROBOT, sensorcfg.loads(LONG_BUFFERS_SUITE), nsim, physics_steps_per_control_step=4, seed=4)
    singles = [sensorcfg.Environment(ROBOT, sensorcfg.loads(LONG_BUFFERS_SUITE), physics_steps_per_control_step=4,
                                     seed=sim_seed(4, i)) for i in range(nsim)]
    actions = np.random.default_rng(5).uniform(-1, 1, (12, nsim, 3)) * [1, 1, 0.04]
    b = [env.reset()] + [env.step(a) for a in actions]
    for i, e in enumerate(singles):
        check_sim(b, [e.reset()] + [e.step(a[i]) for a in actions], i, "long buffers")


OPTIONS_SUITE = """
version: 1
options: {pad_with_initial_value: true, strip_singleton_buffer_dim: true}
sensors:
  elbow: {kind: qpos, element: "joint:elbow", delay: 3, buffer: 4}
  gyro: {kind: sensordata, element: "sensor:imu_gyro", interval: 2, noise: [{type: gaussian, std: 0.1}]}
  hand: {kind: xpos, element: "site:hand_site", delay: {uniform: [0, 4]}, buffer: 3, aggregator: mean}
"""


# -- seeds -------------------------------------------------------------------------------------------


@needs_batch
def test_growing_nsim_leaves_the_first_simulations_streams_unchanged():
    def run(nsim: int):
        env = BatchEnvironment(ROBOT, random_suite(3), nsim, physics_steps_per_control_step=2, seed=5)
        actions = np.random.default_rng(0).uniform(-1, 1, (25, 5, 3))[:, :nsim]
        return [env.reset()] + [env.step(a) for a in actions]

    small, large = run(2), run(5)
    for s, l in zip(small, large):
        for k in s.observation:
            assert same(s.observation[k], l.observation[k][:2]), k


@needs_batch
def test_sim_seed_is_the_spawned_child():
    root = np.random.SeedSequence(42)
    children = root.spawn(4)
    for i, child in enumerate(children):
        assert sim_seed(42, i).generate_state(4).tolist() == child.generate_state(4).tolist()
    assert sim_seed(42, 1).generate_state(4).tolist() != sim_seed(42, 2).generate_state(4).tolist()


@needs_batch
def test_noise_streams_differ_between_simulations():
    obs = random_suite(0, drawn=False, noise=False)
    first = next(iter(obs.values()))
    first.noise = build_noise([{"type": "gaussian", "std": 1.0}], first.array_spec.shape, np.float64, 0.002)
    env = BatchEnvironment(ROBOT, obs, 4, seed=1)
    name = next(iter(obs))
    values = env.reset().observation[name]
    assert len({v.tobytes() for v in values}) == 4


# -- resets ------------------------------------------------------------------------------------------


@needs_batch
def test_partial_reset_touches_only_its_simulations():
    env = BatchEnvironment(ROBOT, random_suite(4), 4, physics_steps_per_control_step=2, seed=2)
    env.reset()
    actions = np.random.default_rng(1).uniform(-1, 1, (10, 4, 3))
    for a in actions:
        env.step(a)
    before = env.updater.get_observation()
    qpos = env.batch.bind("qpos").copy()
    ts = env.reset([1, 3])
    assert ts.step_type.tolist() == [int(dm_env.StepType.MID), int(dm_env.StepType.FIRST)] * 2
    for k, v in ts.observation.items():
        assert same(v[[0, 2]], before[k][[0, 2]]), k
    np.testing.assert_array_equal(env.batch.bind("qpos")[[0, 2]], qpos[[0, 2]])
    assert (env.updater.age == [20, 0, 20, 0]).all()


@needs_batch
def test_time_limit_truncates_then_auto_resets():
    env = BatchEnvironment(ROBOT, random_suite(5), 3, physics_steps_per_control_step=5, time_limit=0.03, seed=0)
    env.reset()
    types = [env.step(np.zeros((3, 3))) for _ in range(4)]
    assert [int(t.step_type[0]) for t in types] == [1, 1, 2, 0]
    assert types[2].discount.tolist() == [1.0, 1.0, 1.0]
    assert types[3].first().all()


# -- divergence --------------------------------------------------------------------------------------


@needs_batch
def test_a_diverged_simulation_ends_its_episode_and_not_the_others():
    seed, nsim = 9, 4
    env = BatchEnvironment(ROBOT, random_suite(6), nsim, physics_steps_per_control_step=2, seed=seed)
    singles = [sensorcfg.Environment(ROBOT, random_suite(6), physics_steps_per_control_step=2, seed=sim_seed(seed, i))
               for i in range(nsim)]
    actions = np.random.default_rng(2).uniform(-1, 1, (12, nsim, 3))
    b = [env.reset()]
    s = [[e.reset()] for e in singles]
    for step, a in enumerate(actions):
        if step == 5:
            env.batch.bind("qvel")[2] = np.inf
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            b.append(env.step(a))
        if step == 5:
            assert b[-1].step_type.tolist() == [1, 1, 2, 1] and b[-1].discount[2] == 0.0
            assert env.last_divergence[2] and "diverged" in str(caught[0].message)
        if step == 6:
            assert b[-1].first()[2] and env.last_divergence[2] is None
        for i, e in enumerate(singles):
            s[i].append(e.step(a[i]))
    for i in (0, 1, 3):
        check_sim(b, s[i], i, "diverged neighbour")
    # its next episode is the single environment's after the same 6 control steps (the 6th diverged)
    e2 = sensorcfg.Environment(ROBOT, random_suite(6), physics_steps_per_control_step=2, seed=sim_seed(seed, 2))
    e2.reset()
    for a in actions[:6]:
        e2.step(a[2])
    tail = [e2.reset()] + [e2.step(a[2]) for a in actions[7:]]
    check_sim(b[7:], tail, 2, "after divergence")


# -- bad input ---------------------------------------------------------------------------------------


@needs_batch
@pytest.mark.parametrize("actions, message", [
    pytest.param(np.zeros((3, 3)), r"actions must have shape \(4, 3\) \(one control per simulation and actuator\), "
                                   r"got \(3, 3\)", id="too-few-simulations"),
    pytest.param(np.zeros((4, 2)), r"got \(4, 2\)", id="too-few-actuators"),
    pytest.param(np.zeros(12), r"got \(12,\)", id="flat"),
    pytest.param([["a"] * 3] * 4, r"actions must be a \(4, 3\) array of numbers", id="not-numbers"),
])
def test_bad_actions_raise_before_stepping(actions, message):
    env = BatchEnvironment(ROBOT, random_suite(0), 4, seed=0)
    env.reset()
    time = env.batch.bind("time").copy()
    with pytest.raises(ArgumentError, match=message):
        env.step(actions)
    np.testing.assert_array_equal(env.batch.bind("time"), time)


@needs_batch
@pytest.mark.parametrize("ids, message", [
    pytest.param([4], r"simulation id 4 is out of range: the batch has 4 simulations \(ids 0 to 3\)", id="high"),
    pytest.param([-1], r"simulation id -1 is out of range", id="negative"),
    pytest.param([0.5], r"ids must be simulation indices", id="float"),
    pytest.param(np.ones(3, bool), r"a boolean mask of simulations must have shape \(4,\), got \(3,\)", id="mask"),
])
def test_bad_ids_raise(ids, message):
    env = BatchEnvironment(ROBOT, random_suite(0), 4, seed=0)
    with pytest.raises(ArgumentError, match=message):
        env.reset(ids)


def _one(**kwargs) -> dict[str, sensorcfg.Observable]:
    obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], **kwargs)
    obs.enabled = True
    return {"arm": obs}


@needs_batch
def test_unvectorisable_suites_raise_before_stepping():
    custom = _one()
    custom["arm"].noise = build_noise([{"type": "gaussian", "std": 0.1},
                                       {"type": "custom", "callable": lambda value, random_state: value}],
                                      (2,), np.float64, 0.002)
    with pytest.raises(SuiteError, match=r"sensor 'arm': a custom noise stage \(custom noise callable '.*<lambda>'\) "
                                         r"runs Python once per sample and simulation, which a BatchEnvironment "
                                         r"cannot vectorise"):
        BatchEnvironment(ROBOT, custom, 2)
    with pytest.raises(SuiteError, match=r"sensor 'arm': its delay is a callable .* cannot be vectorised"):
        BatchEnvironment(ROBOT, _one(delay=lambda random_state: 1), 2)
    with pytest.raises(SuiteError, match=r"sensor 'arm': a corruptor runs a Python callable"):
        BatchEnvironment(ROBOT, _one(corruptor=lambda v, random_state: v), 2)
    with pytest.raises(SuiteError, match=r"sensor 'arm': its aggregator cannot be vectorised"):
        BatchEnvironment(ROBOT, _one(buffer_size=2, aggregator=lambda x: x.sum(0)), 2)
    generic = {"time": sensorcfg.Generic(lambda physics: np.array([physics.data.time]))}
    generic["time"].enabled = True
    with pytest.raises(SuiteError, match=r"sensor 'time' \(Generic\): a generic callable runs Python per sample"):
        BatchEnvironment(ROBOT, generic, 2)
    with pytest.raises(ArgumentError, match=r"nsim must be a positive integer"):
        BatchEnvironment(ROBOT, _one(), 0)


@needs_batch
def test_specs_have_a_leading_simulation_axis():
    env = BatchEnvironment(ROBOT, _one(buffer_size=3), 6)
    assert env.observation_spec()["arm"].shape == (6, 3, 2)
    assert env.action_spec().shape == (6, 3)
    obs = env.reset().observation
    assert obs["arm"].shape == (6, 3, 2)
    env.observation_spec()["arm"].validate(obs["arm"])


# what Environment exposes that a batch has in another form: its one physics is the batch's `batch`, its one
# random state the batch's `seed_sequence` (simulation i draws from `sim_seed(seed_sequence, i)`)
SINGLE_ONLY = {"physics": "batch", "random_state": "seed_sequence"}


@needs_batch
def test_the_batch_exposes_what_the_environment_exposes():
    """Every public attribute of Environment reads on a BatchEnvironment too (issue 24: its
    `physics_steps_per_control_step` raised AttributeError), and the control loop's agree."""
    single = sensorcfg.Environment(ROBOT, _one(), physics_steps_per_control_step=3)
    env = BatchEnvironment(ROBOT, _one(), 2, physics_steps_per_control_step=3)
    names = {n for n in dir(single) if not n.startswith("_")}
    for name in sorted(names):
        expected = SINGLE_ONLY.get(name, name)
        getattr(env, expected)  # reads without error (a property's body runs)
    for spec in ("action_spec", "observation_spec", "reward_spec", "discount_spec"):
        getattr(env, spec)()
    assert env.physics_steps_per_control_step == single.physics_steps_per_control_step == 3
    assert env.control_timestep == single.control_timestep == pytest.approx(0.006)


# -- MuJoCo 3 ----------------------------------------------------------------------------------------


@pytest.mark.skipif(MUJOCO4, reason="checks the error on MuJoCo 3; this is MuJoCo 4")
def test_mujoco3_says_it_needs_mujoco4():
    with pytest.raises(UnsupportedError, match=r"BatchEnvironment needs MuJoCo 4 \(its mujoco.batch module\); this is "
                                         r"mujoco 3\.[0-9.]+: pip install 'mujoco>=4'"):
        BatchEnvironment(ROBOT, _one(), 2)


# -- Gymnasium ---------------------------------------------------------------------------------------


@needs_batch
def test_rewards_and_terminations_are_the_single_environments():
    """reward_fn / termination_fn per simulation, through terminations at different steps and their
    auto-resets, give each simulation the single Environment's rewards, step types and discounts."""
    nsim, n, seed = 4, 3, 11
    limits = np.array([0.015, 0.03, 0.05, 1.0])  # simulated seconds before each simulation terminates

    def batch_reward(batch):
        return batch.qpos[:, 0] + 2.0 * batch.bind("qvel")[:, 1]

    env = BatchEnvironment(ROBOT, random_suite(3), nsim, nthread=2, physics_steps_per_control_step=n, seed=seed,
                           reward_fn=batch_reward, termination_fn=lambda batch: batch.time > limits)
    singles = [sensorcfg.Environment(ROBOT, random_suite(3), physics_steps_per_control_step=n, seed=sim_seed(seed, i),
                                     reward_fn=lambda p: p.data.qpos[0] + 2.0 * p.data.qvel[1],
                                     termination_fn=lambda p, i=i: p.data.time > limits[i]) for i in range(nsim)]
    lo, hi = env.action_spec().minimum, env.action_spec().maximum
    actions = np.random.default_rng(0).uniform(lo, hi, (30, nsim, len(lo)))
    batch_steps, single_steps = [env.reset()], [[e.reset()] for e in singles]
    for a in actions:
        batch_steps.append(env.step(a))
        for i, e in enumerate(singles):
            single_steps[i].append(e.step(a[i]))
    for i in range(nsim):
        check_sim(batch_steps, single_steps[i], i, "rewards")
    ends = np.array([ts.last() & (ts.discount == 0) for ts in batch_steps])
    assert ends[:, :3].sum(axis=0).min() >= 2 and not ends[:, 3].any()  # several terminations, not in lockstep
    assert np.array([ts.reward for ts in batch_steps[1:]]).std() > 0


@needs_batch
def test_gymnasium_vector_env_reports_terminations_and_rewards():
    pytest.importorskip("gymnasium")
    from sensorcfg.gym_vector import GymVectorEnv

    env = BatchEnvironment(ROBOT, _one(), 3, physics_steps_per_control_step=2, reward_fn=lambda b: b.time * 10,
                           termination_fn=lambda b: b.time > np.array([0.0, 1.0, 1.0]))
    venv = GymVectorEnv(env)
    venv.reset(seed=0)
    _, reward, terminated, truncated, info = venv.step(np.zeros((3, 3)))
    np.testing.assert_array_equal(reward, env.batch.time * 10)
    assert terminated.tolist() == [True, False, False] and not truncated.any()
    assert "diverged" not in info  # a termination is not a divergence


@needs_batch
@pytest.mark.parametrize("fn, message", [
    (lambda batch: 1.0, r"reward_fn returned shape \(\); it must return one value per simulation, shape \(2,\)"),
    (lambda batch: ["a", "b"], r"reward_fn must return 2 numbers \(one per simulation\)"),
])
def test_a_reward_fn_of_the_wrong_shape_is_named(fn, message):
    env = BatchEnvironment(ROBOT, _one(), 2, reward_fn=fn)
    env.reset()
    with pytest.raises(ArgumentError, match=message):
        env.step(np.zeros((2, 3)))
    with pytest.raises(ArgumentError, match="termination_fn must be a callable"):
        BatchEnvironment(ROBOT, _one(), 2, termination_fn=3)


@needs_batch
def test_gymnasium_vector_env_steps_and_autoresets_as_the_batch():
    pytest.importorskip("gymnasium")
    from gymnasium.vector import AutoresetMode

    from sensorcfg.gym_vector import GymVectorEnv

    def make():
        return BatchEnvironment(ROBOT, random_suite(2, noise=False), 3, physics_steps_per_control_step=5,
                                time_limit=0.03)

    venv, env = GymVectorEnv(make()), make()
    assert venv.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    obs, _ = venv.reset(seed=4)
    env.seed(4)
    ref = env.reset().observation
    assert venv.observation_space.contains(obs) and obs.keys() == ref.keys()
    actions = np.random.default_rng(0).uniform(-1, 1, (5, 3, 3))
    for step, a in enumerate(actions):
        obs, reward, terminated, truncated, _ = venv.step(a)
        ts = env.step(a)
        assert all(same(obs[k], ts.observation[k]) for k in obs)
        assert truncated.tolist() == [step == 2] * 3 and not terminated.any()
        assert venv.observation_space.contains(obs)
    obs, _ = venv.reset(options={"reset_mask": np.array([True, False, False])})
    assert all(same(obs[k][1:], ts.observation[k][1:]) for k in obs)
    venv.close()


# -- cameras -----------------------------------------------------------------------------------------


def cameras() -> dict[str, sensorcfg.Observable]:
    obs = {
        "overview": sensorcfg.Camera("overview", height=24, width=32, update_interval=3, buffer_size=2),
        "wrist_depth": sensorcfg.Camera("wrist", height=16, width=16, mode="depth", delay=2),
        "hand": sensorcfg.Feature("xpos", "site:hand_site", buffer_size=2, delay=1),
        "wrist_seg": sensorcfg.Camera("camera:wrist", height=8, width=8, mode="segmentation", update_interval=2,
                                      delay=3, buffer_size=3),
    }
    for o in obs.values():
        o.enabled = True
    return obs


@needs_batch
def test_cameras_render_per_simulation_bit_for_bit():
    seed, nsim, n = 3, 3, 4
    env = BatchEnvironment(ROBOT, cameras(), nsim, physics_steps_per_control_step=n, time_limit=0.06, seed=seed)
    assert env.batch.persistent
    singles = [sensorcfg.Environment(ROBOT, cameras(), physics_steps_per_control_step=n, time_limit=0.06,
                                     seed=sim_seed(seed, i)) for i in range(nsim)]
    actions = np.random.default_rng(5).uniform(-1, 1, (12, nsim, 3)) * [1, 1, 0.04]
    b = [env.reset()]
    s = [[e.reset()] for e in singles]
    for step, a in enumerate(actions):
        if step == 4:
            b.append(env.reset([1]))
            s[1].append(singles[1].reset())
            for i in (0, 2):
                s[i].append(s[i][-1]._replace(step_type=dm_env.StepType.MID, reward=0.0, discount=1.0))
        b.append(env.step(a))
        for i, e in enumerate(singles):
            s[i].append(e.step(a[i]))
    assert b[-1].observation["overview"].shape == (nsim, 2, 24, 32, 3)
    assert b[-1].observation["overview"].any()
    for i in range(nsim):
        check_sim(b, s[i], i, "cameras")


@needs_batch
def test_cameras_render_only_frames_a_read_can_see(monkeypatch):
    from sensorcfg.batch import camera

    obs = {"cam": sensorcfg.Camera("overview", height=8, width=8)}  # every step, buffer 1
    obs["cam"].enabled = True
    env = BatchEnvironment(ROBOT, obs, 2, physics_steps_per_control_step=5)
    env.reset()
    frames = []
    render = camera.BatchCameras._frame
    monkeypatch.setattr(camera.BatchCameras, "_frame", lambda self, i, cam: frames.append(i) or render(self, i, cam))
    for _ in range(4):
        env.step(np.zeros((2, 3)))
    assert frames == [0, 1] * 4  # once per control step and simulation, not 5 times


@needs_batch
def test_noisy_cameras_run_per_simulation_as_the_single_environment():
    """Image noise (a stateful low-pass included) runs per simulation, keyed as each simulation's Environment."""
    from conftest import assert_batch_equals_single

    suite = sensorcfg.loads("""
defaults: {camera: {width: 16, height: 12}}
sensors:
  rgb: {kind: rgb, element: camera:overview, interval: 2, buffer: 2, noise: [{type: gaussian, std: 8}]}
  depth: {kind: depth, element: camera:overview, noise: [{type: gaussian, std: 0.01}, {type: lowpass, cutoff: 30Hz}]}
  joints: {kind: qpos, element: "joint:*", noise: [{type: gaussian, std: 0.01}]}
""")
    assert_batch_equals_single(ROBOT, suite, nsim=2, seed=4, steps=6)


@needs_batch
def test_cameras_with_aggregators_are_rejected():
    obs = {"cam": sensorcfg.Camera("overview", height=8, width=8, buffer_size=2, aggregator="mean")}
    obs["cam"].enabled = True
    with pytest.raises(SuiteError, match=r"camera 'cam': a BatchEnvironment renders cameras per simulation and "
                                         r"cannot apply an aggregator to them"):
        BatchEnvironment(ROBOT, obs, 2)


WELD = """
<mujoco>
  <worldbody>
    <body name="mocap" mocap="true"/>
    <body name="pole" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0"/>
      <geom type="capsule" size=".05" fromto="0 0 0 0 0 -.5"/>
    </body>
  </worldbody>
  <equality><weld body1="mocap" body2="pole"/></equality>
  <actuator><motor joint="hinge"/></actuator>
</mujoco>
"""


@needs_batch
def test_a_simulation_mujoco_raises_in_is_reported_for_it_alone():
    model = mujoco.MjModel.from_xml_string(WELD)
    obs = {"angle": sensorcfg.Feature("qpos", "joint:hinge", buffer_size=2)}
    obs["angle"].enabled = True
    env = BatchEnvironment(model, obs, 4, physics_steps_per_control_step=2)
    env.reset()
    eq_type = env.batch.expand("eq_type")
    eq_type[1] = 99  # an unknown constraint type: mj_step raises in simulation 1 only
    with pytest.warns(RuntimeWarning, match=r"1 of 4 simulations diverged \(\[1\]; simulation 1: MuJoCo raised"):
        ts = env.step(np.full((4, 1), 0.5))
    assert ts.step_type.tolist() == [1, 2, 1, 1] and ts.discount.tolist() == [1.0, 0.0, 1.0, 1.0]
    assert env.last_divergence[1].startswith("MuJoCo raised: ")
    assert (env.batch.bind("time")[[0, 2, 3]] > 0).all()
    eq_type[1] = model.eq_type[0]
    ts = env.step(np.full((4, 1), 0.5))
    assert ts.step_type.tolist() == [1, 0, 1, 1] and env.last_divergence[1] is None


# -- the bundled example suites ----------------------------------------------------------------------


CONFIGS = ROOT / "configs"


@needs_batch
@pytest.mark.parametrize("name, steps", [
    pytest.param("proprioception.yaml", 25, id="proprioception"),
    pytest.param("imu.yaml", 25, id="imu"),
    pytest.param("sim2real.yaml", 25, id="sim2real"),  # random latencies and noise
    pytest.param("vision.yaml", 4, id="vision"),  # cameras
])
def test_example_suites_run_bit_for_bit(name, steps):
    path = CONFIGS / name
    suite = sensorcfg.load(path)
    env = BatchEnvironment(suite.model, suite, 2, seed=21)
    singles = [sensorcfg.Environment(suite.model, sensorcfg.load(path), seed=sim_seed(21, i)) for i in range(2)]
    spec = env.action_spec()
    actions = np.random.default_rng(4).uniform(spec.minimum, spec.maximum, (steps, *spec.shape))
    b = [env.reset()] + [env.step(a) for a in actions]
    for i, e in enumerate(singles):
        check_sim(b, [e.reset()] + [e.step(a[i]) for a in actions], i, name)


@needs_batch
@pytest.mark.parametrize("suite_seed", [0, 3, 7])
def test_short_noise_blocks_draw_the_same_numbers(monkeypatch, suite_seed):
    # thousands of simulations draw their noise in shorter blocks than one simulation: same streams
    from sensorcfg.batch import noise

    monkeypatch.setattr(noise, "_BLOCK_BYTES", 8)  # blocks of one sample wherever the stream allows
    _, batch_steps, single_steps = run_pair(suite_seed, 3, 30, drawn=False, n=2)
    for i in range(3):
        check_sim(batch_steps, single_steps[i], i, f"suite {suite_seed}")


LEVELED_SUITE = """
version: 1
options: {control_interval: 4}
sensors:
  scan: {kind: heightscan, element: site:hand_site, scan: {pattern: ring, radii: [0.1], count: 4},
         noise: [{type: gaussian, std: 0.05}, {type: lowpass, cutoff: 50Hz}]}
  wrist: {kind: rgb, element: camera:wrist, camera: {width: 8, height: 6}, interval: 2,
          noise: [{type: gaussian, std: 20}]}
  hand: {kind: xpos, element: site:hand_site, noise: [{type: gaussian, std: 0.1}]}
"""


@needs_batch
def test_noise_levels_reach_height_scans_and_cameras():
    """Height scans and cameras run noise through a pipeline per simulation: each takes the level its sensor
    is set to at its next reset, so simulation i equals its Environment at every level (at 0: clean)."""
    nsim = 2
    env = BatchEnvironment(ROBOT, sensorcfg.loads(LEVELED_SUITE), nsim, seed=8)
    singles = [sensorcfg.Environment(ROBOT, sensorcfg.loads(LEVELED_SUITE), seed=sim_seed(8, i)) for i in range(nsim)]
    actions = np.random.default_rng(2).uniform(-1, 1, (6, nsim, 3)) * [1, 1, 0.04]
    b, s = [env.reset()], [[e.reset()] for e in singles]
    for level in (0.0, 0.4):
        env.set_noise_level(level)
        b.append(env.reset())
        for i, e in enumerate(singles):
            e.set_noise_level(level)
            s[i].append(e.reset())
        for a in actions:
            b.append(env.step(a))
            for i, e in enumerate(singles):
                s[i].append(e.step(a[i]))
    for i in range(nsim):
        check_sim(b, s[i], i, "levels")
    plain = BatchEnvironment(ROBOT, sensorcfg.loads(re.sub(r",\s*noise: \[.*?\]\}", "}", LEVELED_SUITE, flags=re.S)),
                             nsim, seed=8)
    clean = [plain.reset()] + [plain.step(a) for a in actions]
    for got, want in zip(b[1:2 + len(actions)], clean):  # the episode at level 0 reads the clean values
        for name in ("scan", "wrist", "hand"):
            assert same(got.observation[name], want.observation[name]), name
