"""A differential fuzz of the Warp engine (`sensorcfg.warp`) against the CPU engines.

Each seed writes a random suite as YAML text (`sensorcfg.loads`: the user's path, config validation and clean
twins included) on the bundled robot: several sensors of random kinds (mjData fields, MuJoCo sensor kinds the
suite compiles into the model, `index`, `within`), fixed or drawn (`{uniform}`, `{choice}`) intervals and
delays (steps, durations, rates), buffers, aggregators, chains of 1-4 noise stages with random parameters (some
drawn per episode, misalign on 3-vectors), twins, padding and strip on or off, 1-4 physics steps per control
step, 2-5 worlds.

- the sensor layer (`warp.sensors`, Warp's CPU device) against one Updater per world on world w's CPU
  trajectory: random worlds restart at random control steps, noise levels change mid-run, and more episodes
  run than the key table holds (its top-up is `layer.EpisodeKeys.top_up`). The suite's fields are rounded to
  float32 on that trajectory, so both engines sample the same values and only their arithmetic differs;
- `WarpEnvironment` against `BatchEnvironment` on suites of the controls (the same values whatever the
  physics): specs, reads, step types, rewards, discounts, time limits, `reset(ids)`, noise levels;
- `WarpEnvironment` end to end (height scans too) against an Updater per world reading MuJoCo Warp's own state.

Every read of every world is compared: plain noise-free reads bit for bit as float32 copies, the rest to
float32 rounding. `FUZZ_SEEDS=a:b` runs sensor-layer seeds a..b-1 instead of the CI-sized set (long local runs).
"""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402
from cpu_batch import cpu_batch  # noqa: E402
from fuzz_suites import WARP_KINDS, Draws, Kind, suite_text

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.draws import root_seed, sim_seed  # noqa: E402
from sensorcfg.loop.control import random_state_from  # noqa: E402
from sensorcfg.noise.level import leveled, set_level  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.plan.bind import bind, plan_suite  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from sensorcfg.warp.layer import EpisodeKeys, refuse  # noqa: E402
from sensorcfg.warp.sensors import Sensors  # noqa: E402

ROBOT = str(assets.path("robot.xml"))
MODEL = mujoco.MjModel.from_xml_path(ROBOT)

class WarpDraws(Draws):
    """A suite's parts as this fuzzer draws them: `Draws`'s recipes at its own odds (schedules now and then three
    times as long, always an interval and a delay, buffers up to 8, clean twins), each stage's type drawn before
    its parameters, no fused runs, no units in noise parameters, no densities, no bias means, and a misalign's
    angle in radians or else a matrix alone. A cutoff drawn per episode on a drawn interval is refused
    (`support`): fixed there."""

    drawn = 0.3
    stages = ("gaussian", "uniform", "bias", "scale", "random_walk", "quantize", "clip", "dropout", "outlier",
              "lowpass")
    long, constant, timed, rate, beyond = 0.15, 0.45, 0.6, 0.3, 2
    interval = delay = 1.0
    short_buffer, twin = 0.85, 0.4
    aggregators = (None, None, None, "min", "max", "sum", "mean", "median")
    units = density = bias_mean = drawn_cutoff = False

    def chain(self, count: int, fixed: bool) -> list[dict[str, Any]]:
        """`count` stages, each of a type drawn from `stages`."""
        return [self.stage(str(self.rng.choice(self.stages)), fixed) for _ in range(count)]

    def noise(self, vector: bool, fixed: bool) -> list[dict[str, Any]]:
        return self.misaligned(self.chain(int(self.rng.integers(1, 5)), fixed), vector)

    def misalign(self) -> dict[str, Any]:
        turn: dict[str, Any] = {"type": "misalign", "std": round(float(self.rng.uniform(0.01, 0.2)), 3)}
        if self.rng.random() < 0.3:
            turn = {"type": "misalign", "matrix": self.cross_axis()}
        return turn


def fuzz_suite(seed: int, kinds: list[Kind] = WARP_KINDS, scans: bool = False) -> tuple[str, dict[str, Any]]:
    """A random suite's YAML text (JSON, which YAML reads) of sensors of `kinds` (and, with `scans`, a height
    scan now and then), and the run's settings: substeps, restarts, levels."""
    draws = WarpDraws(np.random.default_rng(seed))
    rng = draws.rng
    substeps = int(rng.integers(1, 5))
    strip = bool(rng.random() < 0.3)
    sensors = draws.sensors(kinds, strip)
    options = {"pad_with_initial_value": bool(rng.random() < 0.5), "control_interval": f"{2 * substeps}ms",
               "strip_singleton_buffer_dim": strip}
    # every sensor delivered clean too (a sensor's own `twin` wins)
    defaults = {"twin": "{name}_twin"} if rng.random() < 0.2 else None
    nworld = int(rng.integers(2, 6))
    control_steps = 24
    restarts = {t: [w for w in range(nworld) if rng.random() < 0.2] for t in range(1, control_steps + 1)}
    levels = {int(t): float(rng.choice([0.0, 1.0, round(float(rng.uniform(0.0, 1.0)), 2)]))
              for t in rng.integers(1, control_steps, 2)}
    if scans and rng.random() < 0.6:  # a constant schedule and no aggregator: the Warp engine's scans
        scan = {"size": [0.4, 0.2], "resolution": 0.2, "alignment": str(rng.choice(["yaw", "full", "world"]))}
        entry = {"kind": "heightscan", "element": "site:hand_site", "scan": scan,
                 "interval": int(rng.integers(1, 5)), "delay": int(rng.integers(0, 6)),
                 "buffer": int(rng.integers(1, 4))}
        if rng.random() < 0.7:
            entry["noise"] = draws.chain(int(rng.integers(1, 4)), True)
        sensors["scan"] = entry
    run = {"substeps": substeps, "nworld": nworld, "control_steps": control_steps, "seed": seed,
           "restarts": {t: ws for t, ws in restarts.items() if ws}, "levels": levels}
    return suite_text(sensors, options, defaults), run


def fields_of(datas: list[mujoco.MjData], names: list[str]) -> dict[str, wp.array]:
    return {f: wp.array(np.stack([np.ravel(getattr(d, f)) for d in datas]).astype(np.float32), dtype=wp.float32,
                        device="cpu") for f in names}


def _round(data: mujoco.MjData, names: list[str]) -> None:
    """The fields the suite reads rounded to float32 in place: both engines then see the same values (the
    trajectory goes on from them), so what differs is the engines' arithmetic alone."""
    for name in names:
        array = getattr(data, name)
        array[...] = array.astype(np.float32)


def replay(make: Callable[[], dict[str, Any]], model: mujoco.MjModel, options: dict[str, Any], nworld: int,
           control_steps: int, seed: int, restarts: dict[int, list[int]], levels: dict[int, float],
           key_episodes: int = 4) -> int:
    """World w of the sensor layer against an Updater over `make()`'s (leveled) observables, both reading world
    w's CPU trajectory (random actions; the fields the suite reads rounded to float32 at each step). At control
    step t the worlds `restarts[t]` start a new episode instead of stepping, and from `levels[t]` on new
    episodes have that noise level; `options`: the Updater's keywords; the key table holds `key_episodes`
    episodes ahead, topped up every `key_episodes // 4` control steps by `EpisodeKeys.top_up`. Plain
    noise-free reads are compared bit for bit, the rest to float32 rounding. Returns the most episodes a world
    started."""
    substeps, strip = options["physics_steps_per_control_step"], options["strip_singleton_buffer_dim"]
    pad = options["pad_with_initial_value"]
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    observables = make()
    bound = bind(observables, physics, substeps, strip)
    refuse(bound, model)
    plan = plan_suite(bound, physics, bound.sources(), nworld, substeps, pad)
    sensors = Sensors(plan, wp.get_device("cpu"), key_episodes)
    names = [f for f, _ in plan.fields]
    plain = {s.name for s in plan.sensors if s.noise is None and s.aggregator is None}
    keys = EpisodeKeys(sensors, key_episodes)
    keys.start([np.random.RandomState(100 + w) for w in range(nworld)])

    def top_up() -> None:
        keys.top_up()

    worlds = [(sensorcfg.Updater(obs, **options), Physics(model), np.random.RandomState(100 + w), obs)
              for w, obs in enumerate([make() for _ in range(nworld)])]
    steps = np.zeros(nworld, np.int64)
    device_steps = wp.zeros(nworld, dtype=wp.int64, device="cpu")
    lo, hi = model.actuator_ctrlrange.T
    actions = np.random.default_rng(seed).uniform(lo, hi, (control_steps, nworld, model.nu)).astype(np.float32)

    def restart(chosen: list[int]) -> None:
        for w in chosen:
            u, p, rs, _ = worlds[w]
            mujoco.mj_resetData(model, p.data)
            mujoco.mj_forward(model, p.data)
            _round(p.data, names)
            u.reset(p, rs)
            steps[w] = 0
        device_steps.assign(steps)
        mask = np.zeros(nworld, np.int32)
        mask[chosen] = 1
        sensors.reset(wp.array(mask, dtype=wp.int32, device="cpu"), fields_of([p.data for _, p, _, _ in worlds], names),
                      device_steps)

    top_up()
    restart(list(range(nworld)))
    for t in range(control_steps + 1):
        if t:
            if t in levels:
                for *_, obs in worlds:
                    set_level(obs, levels[t])
                sensors.episodes.next_level.fill_(levels[t])
            chosen = restarts.get(t, [])
            running = [w for w in range(nworld) if w not in chosen]
            snapshots: list[list[mujoco.MjData]] = [[] for _ in range(substeps)]
            for w in running:
                u, p, _, _ = worlds[w]
                p.data.ctrl[:] = actions[t - 1, w]
                done: list[mujoco.MjData] = []

                def step(p: Physics = p, done: list = done) -> None:
                    mujoco.mj_step(model, p.data)
                    _round(p.data, names)
                    copy = mujoco.MjData(model)
                    mujoco.mj_copyData(copy, model, p.data)
                    done.append(copy)
                u.control_step(step)
                for k in range(substeps):
                    snapshots[k].append(done[k])
            mask = np.zeros(nworld, np.int32)
            mask[running] = 1
            for k in range(substeps):
                steps[running] += 1
                device_steps.assign(steps)
                datas = [worlds[w][1].data for w in range(nworld)]
                for w, d in zip(running, snapshots[k]):
                    datas[w] = d
                sensors.record(fields_of(datas, names), device_steps, wp.array(mask, dtype=wp.int32, device="cpu"))
            if chosen:
                restart(chosen)
            if t % (key_episodes // 4) == 0:  # as `EpisodeKeys.ahead` tops it up
                top_up()
        got = {name: array.numpy() for name, array in sensors.read(device_steps).items()}
        for w, (u, *_) in enumerate(worlds):
            for name, value in u.get_observation().items():
                assert got[name][w].shape == value.shape, name
                if name in plain:  # a noise-free plain read is a copy of the float32 field
                    assert got[name][w].tobytes() == value.astype(np.float32).tobytes(), (w, t, name)
                else:
                    np.testing.assert_allclose(got[name][w], value, rtol=1e-5, atol=1e-6,
                                               err_msg=f"world {w} control step {t} {name}")
    assert not sensors.key_names or (keys.keyed >= sensors.episodes.count.numpy()).all()
    return int(sensors.episodes.count.numpy().max())


def run_seed(seed: int) -> int:
    text, run = fuzz_suite(seed)
    return run_text(text, run, f"fuzz{seed}.yaml")


def run_text(text: str, run: dict[str, Any], file: str = "<string>") -> int:
    """`replay` of the suite `text` with the settings `run` (`fuzz_suite`'s)."""
    seed = run["seed"]
    suite = sensorcfg.loads(text, file=file)
    model = suite.compile(ROBOT, batch=True)
    options = suite.updater_kwargs(model)
    assert options["physics_steps_per_control_step"] == run["substeps"]

    def make() -> dict[str, Any]:
        built = {name: obs for name, obs in suite.build(model, batch=True).items() if obs.enabled}
        leveled(built)
        return built

    return replay(make, model, options, run["nworld"], run["control_steps"], seed, run["restarts"], run["levels"],
                  4 + seed % 9)


def _seeds() -> list[int]:
    chosen = os.environ.get("FUZZ_SEEDS")
    if chosen:
        first, stop = (int(x) for x in chosen.split(":"))
        return list(range(first, stop))
    return list(range(20))


@pytest.mark.parametrize("seed", _seeds())
def test_world_i_reads_what_the_updater_reads_on_a_fuzzed_suite(seed: int) -> None:
    run_seed(seed)


# sensors of the controls: the same values on both engines whatever their physics (float32 actions)
CONTROLS: list[Kind] = [
    Kind("ctrl", ["actuator:shoulder_motor", "actuator:elbow_motor"], {}, False),
    Kind("ctrl", "actuator:*", {}, True),
    Kind("ctrl", "actuator:finger_servo", {}, False),
]


class Injected(Exception):
    """What a scripted reward or termination raises (`Scripted`)."""


class Scripted:
    """A `reward_fn` or `termination_fn` for both engines: its call k returns row k of `values` (a numpy array
    for `BatchEnvironment`; a Warp array on `device` for `WarpEnvironment`) or raises `Injected` when k is in
    `raises`. Both engines call them once per step, the termination after the reward."""

    def __init__(self, values: np.ndarray, raises: set[int], device: str | None = None):
        self.values, self.raises, self.device, self.calls = values, raises, device, 0

    def __call__(self, env: Any) -> Any:
        k, self.calls = self.calls, self.calls + 1
        if k in self.raises:
            raise Injected(f"call {k}")
        return self.values[k] if self.device is None else wp.array(self.values[k], device=self.device)


def episode_rules(seed: int, nworld: int, control_steps: int, substeps: int, nu: int) -> dict[str, Any]:
    """A run's episode events, from their own stream (the suite's stream stays the one `fuzz_suite` draws): the
    time limit (by `seed % 4`: a few control steps, none as None, none as inf, more steps than an int32 holds),
    bad actions (NaN, +-inf, beyond mjMAXVAL: a NaN ends the world's episode, a clamped one does not), rewards,
    terminations and the calls at which `reward_fn` or `termination_fn` raise."""
    rng = np.random.default_rng([seed, 1])
    timestep = substeps * float(MODEL.opt.timestep)
    limit = [int(rng.integers(3, 8)) * timestep, None, math.inf, (2**32 + 3) * timestep][seed % 4]
    bad = {t: [(int(w), int(rng.integers(nu)), float(rng.choice([np.nan, np.inf, -np.inf, 1e11])))
               for w in rng.choice(nworld, int(rng.integers(1, nworld + 1)), replace=False)]
           for t in range(1, control_steps + 1) if rng.random() < 0.15}
    calls = 3 * control_steps
    return {"time_limit": limit, "bad_actions": bad,
            "rewards": rng.normal(0, 1, (calls, nworld)).astype(np.float32),
            "terminations": rng.random((calls, nworld)) < 0.05,
            "reward_raises": {int(k) for k in rng.integers(1, control_steps, 2)},
            "termination_raises": {int(k) for k in rng.integers(1, control_steps, 1)}}


def _step_both(warp: WarpEnvironment, batch: Any, actions: np.ndarray) -> tuple[Any, Any]:
    """Both engines' step of `actions`; where a user function raised (in both: the same call of each), the step
    after it, which restarts every world of both."""
    results, raised = [], []
    for env, given in ((warp, actions), (batch, actions.astype(np.float64))):
        try:
            results.append(env.step(given))
        except Injected as e:
            raised.append(str(e))
    assert len(raised) in (0, 2) and len(set(raised)) <= 1, raised
    if not raised:
        return results[0], results[1]
    ours, theirs = _step_both(warp, batch, actions)
    assert (np.asarray(theirs.step_type) == 0).all() and (ours.step_type.numpy() == 0).all()
    return ours, theirs


def run_environments(seed: int, control_steps: int = 30, autoreset: str = "next_step") -> None:
    """`WarpEnvironment` against `BatchEnvironment` on a fuzzed suite of the controls: specs, every read of every
    world, step types, rewards and discounts, through time limits (none, huge), `reset(ids)`, noise levels, a
    reseed, bad actions and exceptions in `reward_fn` / `termination_fn` (`episode_rules`), both engines
    restarting ended episodes as `autoreset` says."""
    text, run = fuzz_suite(seed, CONTROLS)
    rng = np.random.default_rng(seed)
    substeps, nworld = run["substeps"], run["nworld"]
    rules = episode_rules(seed, nworld, control_steps, substeps, MODEL.nu)
    functions = {f"{kind}_fn": (rules[f"{kind}s"], rules[f"{kind}_raises"]) for kind in ("reward", "termination")}
    options = dict(seed=seed, time_limit=rules["time_limit"], autoreset=autoreset)
    warp = WarpEnvironment(ROBOT, sensorcfg.loads(text), nworld, device="cpu", key_episodes=4 + 4 * (seed % 3),
                           **{f: Scripted(*v, device="cpu") for f, v in functions.items()},
                           **options)  # its key table topped up every control step, every second, every third
    batch = cpu_batch(ROBOT, lambda: sensorcfg.loads(text), nworld, **{f: Scripted(*v) for f, v in functions.items()},
                      **options)
    ours_spec, their_spec = warp.observation_spec(), batch.observation_spec()
    assert list(ours_spec) == list(their_spec)
    for name, spec in ours_spec.items():
        assert spec.shape == their_spec[name].shape, name
        for bound in ("minimum", "maximum"):
            if hasattr(their_spec[name], bound):
                np.testing.assert_array_equal(  # (float32 bounds: the Warp engine's values are float32)
                    np.broadcast_to(getattr(spec, bound), spec.shape),
                    np.broadcast_to(getattr(their_spec[name], bound), spec.shape).astype(np.float32))
    plain = {s.name for s in warp._sensors.plan.sensors if s.noise is None and s.aggregator is None}
    lo, hi = warp._model.actuator_ctrlrange.T
    ours, theirs = warp.reset(), batch.reset()
    for t in range(control_steps + 1):
        assert ours.step_type.numpy().tolist() == [int(s) for s in theirs.step_type], t
        np.testing.assert_array_equal(ours.reward.numpy(), np.asarray(theirs.reward, np.float32))
        np.testing.assert_array_equal(ours.discount.numpy(), np.asarray(theirs.discount, np.float32))
        for name, value in theirs.observation.items():
            got = ours.observation[name].numpy()
            assert got.shape == value.shape, name
            if name in plain:
                assert got.tobytes() == np.asarray(value, np.float32).tobytes(), (t, name)
            else:
                np.testing.assert_allclose(got, value, rtol=1e-5, atol=1e-6, err_msg=f"control step {t} {name}")
        if t in run["levels"]:
            warp.set_noise_level(run["levels"][t])
            batch.set_noise_level(run["levels"][t])
        chosen = run["restarts"].get(t + 1, [])
        if t == control_steps // 2:  # reseeded: every world restarts at the next step, with new keys
            warp.seed(seed + 1000)
            batch.seed(seed + 1000)
        if chosen and t % 3 == 0:  # by hand, mid-episode
            ours, theirs = warp.reset(chosen), batch.reset(chosen)
        else:
            actions = rng.uniform(lo, hi, (nworld, warp._model.nu)).astype(np.float32)
            for w, a, value in rules["bad_actions"].get(t + 1, []):
                actions[w, a] = value
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # (the batch's divergence warnings)
                ours, theirs = _step_both(warp, batch, actions)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])  # (every kind of time limit: `episode_rules`)
def test_the_warp_environment_reads_what_the_batch_reads_on_a_fuzzed_suite_of_the_controls(seed: int) -> None:
    run_environments(seed)


@pytest.mark.parametrize("seed", [0, 4])  # (a time limit of a few control steps: `episode_rules`)
def test_the_engines_agree_with_same_step_resets_on_a_fuzzed_suite_of_the_controls(seed: int) -> None:
    run_environments(seed, autoreset="same_step")


def run_environment_physics(seed: int, nworld: int = 2, control_steps: int = 14) -> None:
    """`WarpEnvironment` end to end on a fuzzed suite of every kind (height scans too), one physics step per
    control step: after each step each world's Updater reads MuJoCo Warp's own state (the suite's fields and the
    scans' frames copied into an MjData), resetting where the step says FIRST, with the world's own seed; every
    read of every world is compared, as `replay` compares them. Every world restarts at once (the time limit,
    `reset()`): a restart runs MuJoCo Warp's forward of every world after the step's samples were taken, so the
    fields a continuing world shows then are no longer those its sensors sampled (the test against
    `BatchEnvironment` restarts some worlds alone)."""
    text, run = fuzz_suite(seed, scans=True)
    document = json.loads(text)
    document["options"]["control_interval"] = "2ms"
    suite = sensorcfg.loads(json.dumps(document), file=f"fuzz{seed}.yaml")
    rng = np.random.default_rng(seed)
    env = WarpEnvironment(ROBOT, suite, nworld, device="cpu", key_episodes=4, seed=seed,
                          time_limit=int(rng.integers(3, 8)) * float(MODEL.opt.timestep))
    model = env._model
    names = [f for f, _ in env._sensors.plan.fields if f not in env._scans.heights] + env._scans.pose_fields
    plain = {s.name for s in env._sensors.plan.sensors  # (heights: MuJoCo Warp's float32 casts, to float32 rounding)
             if s.noise is None and s.aggregator is None and s.source.field not in env._scans.heights}
    options = suite.updater_kwargs(model)

    def make() -> dict[str, Any]:
        built = {name: obs for name, obs in suite.build(model, batch=True).items() if obs.enabled}
        leveled(built)
        return built

    worlds = [(sensorcfg.Updater(obs, **options), Physics(model),
               random_state_from(sim_seed(root_seed(seed), w)), obs)
              for w, obs in enumerate(make() for _ in range(nworld))]

    def copy_state() -> None:
        for f in names:
            values = getattr(env.data, f).numpy().reshape(nworld, -1)
            for w, (_, p, _, _) in enumerate(worlds):
                getattr(p.data, f).flat[:] = values[w]

    lo, hi = model.actuator_ctrlrange.T
    step = env.reset()
    for t in range(control_steps + 1):
        copy_state()
        for w, (u, p, rs, _) in enumerate(worlds):
            if int(step.step_type.numpy()[w]) == 0:
                u.reset(p, rs)
            else:
                u.control_step(lambda: None)  # (MuJoCo Warp's step, copied in)
        for w, (u, *_) in enumerate(worlds):
            for name, value in u.get_observation().items():
                got = step.observation[name].numpy()[w]
                assert got.shape == value.shape, name
                if name in plain:
                    assert got.tobytes() == value.astype(np.float32).tobytes(), (w, t, name, got, value)
                else:
                    np.testing.assert_allclose(got, value, rtol=1e-5, atol=1e-6,
                                               err_msg=f"world {w} control step {t} {name}")
        if t in run["levels"]:
            env.set_noise_level(run["levels"][t])
            for *_, obs in worlds:
                set_level(obs, run["levels"][t])
        if run["restarts"].get(t + 1) and t % 4 == 0:
            step = env.reset()
        else:
            step = env.step(rng.uniform(lo, hi, (nworld, model.nu)).astype(np.float32))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_warp_environment_reads_its_own_physics_as_the_updater_reads_it(seed: int) -> None:
    run_environment_physics(seed)


# fields MuJoCo fills in a step only as its sensors need them, and the derived fields of a step
DERIVED = {"cacc": "body:hand", "cfrc_int": "body:forearm", "subtree_linvel": "body:upper_arm",
           "subtree_angmom": "body:upper_arm", "subtree_com": "body:upper_arm", "qfrc_bias": "joint:*",
           "qfrc_passive": "joint:*", "qfrc_actuator": "joint:*", "qacc": "joint:*", "force": "actuator:*",
           "cvel": "body:hand", "xipos": "body:hand", "cinert": "body:hand", "xanchor": "joint:elbow",
           "framelinacc": "site:hand_site", "frameangacc": "site:hand_site", "accelerometer": "site:imu"}


def test_what_the_warp_environment_reads_is_mujocos_forward_of_the_state_it_stepped_from() -> None:
    """Every field a sensor reads is filled by MuJoCo Warp's step as MuJoCo fills it (no field left at zero or
    stale): the values read after a step of one physics step are MuJoCo's `mj_forward` of the state the step
    started from (a step computes them before it integrates), to float32 physics."""
    sensors = {name: {"kind": name, "element": element} for name, element in DERIVED.items()}
    env = WarpEnvironment(ROBOT, sensorcfg.loads(json.dumps({"sensors": sensors})), 1, device="cpu", seed=0,
                          physics_steps_per_control_step=1)
    model = env._model
    data = mujoco.MjData(model)
    sources = {s.name: s.source for s in env._sensors.plan.sensors}
    rng = np.random.default_rng(0)
    env.reset()
    for _ in range(10):
        for f in ("qpos", "qvel", "act", "qacc_warmstart", "time"):
            setattr(data, f, getattr(env.data, f).numpy()[0])
        actions = rng.uniform(*model.actuator_ctrlrange.T).astype(np.float32)
        data.ctrl[:] = actions
        mujoco.mj_forward(model, data)
        step = env.step(actions[None])
        for name, source in sources.items():
            want = np.ravel(getattr(data, source.field))[source.positions.ravel()]
            got = step.observation[name].numpy().ravel()
            scale = max(1.0, float(np.abs(want).max()))
            assert np.abs(got - want).max() <= 1e-3 * scale, (name, got, want)  # (accelerations: float32 solves)
