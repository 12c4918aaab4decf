"""What the Warp engine's noise draws per episode (`sensorcfg.warp.episode`): parameters drawn per episode
(`{uniform: [low, high]}`) of every stage type, and `misalign` on one, two and three 3-vectors, against the
single-simulation Updater on the same trajectory, over several episodes per world (resets of some worlds
mid-run, noise levels, more episodes than the key table holds: its top-up)."""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.noise.bounds import noisy_bounds  # noqa: E402
from sensorcfg.noise.level import leveled, own_bounds, set_level  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.plan.bind import bind, plan_suite  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from sensorcfg.warp.sensors import Sensors  # noqa: E402

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


def fields_of(datas: list[mujoco.MjData], names: list[str]) -> dict[str, wp.array]:
    return {f: wp.array(np.stack([np.ravel(getattr(d, f)) for d in datas]).astype(np.float32), dtype=wp.float32,
                        device="cpu") for f in names}


def replay_episodes(make: Callable[[], dict[str, Any]], nworld: int, substeps: int, control_steps: int, seed: int,
                    restarts: dict[int, list[int]], levels: dict[int, float], key_episodes: int = 4) -> int:
    """World w of the Warp sensor layer against an Updater over `make()`'s observables, both reading world w's
    CPU trajectory (random actions), to float32 rounding. At control step t the worlds `restarts[t]` start a
    new episode (the others step), and from `levels[t]` on new episodes have that noise level. Episode keys
    come from `WarpEnvironment`'s own key table and top-up (`key_episodes` episodes ahead, topped up after
    every control step as `key_episodes // 4 == 1` makes it). Returns the most episodes a world started."""
    model = mujoco.MjModel.from_xml_path(ROBOT)
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    observables = make()
    bound = bind(observables, physics, substeps, False, False)
    plan = plan_suite(bound, physics, bound.sources(), nworld, substeps, False)
    bounds = {e.name: b for e in bound.fixed if e.channel.noise is not None
              for b in [noisy_bounds(getattr(e.channel.noise, "_inner", e.channel.noise), own_bounds(e.observable))]
              if b is not None}
    sensors = Sensors(plan, wp.get_device("cpu"), key_episodes, bounds)
    assert sensors.noisy_names
    names = [f for f, _ in plan.fields]
    # the host's key table, topped up by WarpEnvironment's own code
    host = SimpleNamespace(_sensors=sensors, _key_episodes=key_episodes, _keyed=np.zeros(nworld, np.int64),
                           _table=np.zeros(sensors.key_table.shape, np.uint64),
                           _values=np.zeros(sensors.episode_table.shape),
                           _pipelines={e.name: e.channel.noise for e in bound.fixed},
                           _random_states=[np.random.RandomState(100 + w) for w in range(nworld)])

    def top_up() -> None:
        WarpEnvironment._top_up(host, sensors.episodes.numpy().astype(np.int64))  # type: ignore[arg-type]

    # the CPU side: one Updater, MjData and random state per world
    worlds = [(sensorcfg.Updater(obs, substeps), Physics(model), np.random.RandomState(100 + w), obs)
              for w, obs in enumerate([make() for _ in range(nworld)])]
    steps = np.zeros(nworld, np.int64)
    device_steps = wp.zeros(nworld, dtype=wp.int64, device="cpu")
    lo, hi = model.actuator_ctrlrange.T
    actions = np.random.default_rng(seed).uniform(lo, hi, (control_steps, nworld, model.nu))

    def restart(chosen: list[int]) -> None:
        for w in chosen:
            u, p, rs, _ = worlds[w]
            mujoco.mj_resetData(model, p.data)
            mujoco.mj_forward(model, p.data)
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
                sensors.next_level.fill_(levels[t])
            chosen = restarts.get(t, [])
            running = [w for w in range(nworld) if w not in chosen]
            snapshots: list[list[mujoco.MjData]] = [[] for _ in range(substeps)]
            for w in running:
                u, p, _, _ = worlds[w]
                p.data.ctrl[:] = actions[t - 1, w]
                done: list[mujoco.MjData] = []

                def step(p: Physics = p, done: list = done) -> None:
                    mujoco.mj_step(model, p.data)
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
            top_up()
        got = {name: array.numpy() for name, array in sensors.read(device_steps).items()}
        for w, (u, *_) in enumerate(worlds):
            for name, value in u.get_observation().items():
                np.testing.assert_allclose(got[name][w], value, rtol=1e-5, atol=1e-6,
                                           err_msg=f"world {w} control step {t} {name}")
    assert (host._keyed >= sensors.episodes.numpy()).all()
    return int(sensors.episodes.numpy().max())


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
        obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"])  # a leveled blend kept in bounds after a walk
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

