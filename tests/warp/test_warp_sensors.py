"""The Warp engine's sensor layer (`sensorcfg.warp.sensors`) on Warp's CPU device, fed a CPU MuJoCo trajectory:
world i reads what the single-simulation Updater reads on the same trajectory. Noise-free values are the
float32 copies of the Updater's (exactly); noisy ones agree to float32 rounding, with the same random numbers
(the same keys, samples, stages and values)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import mujoco
import numpy as np
import pytest

from conftest import MODELS, ROOT, warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.draws import episode_entropy  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.plan.bind import bind, plan_suite  # noqa: E402
from sensorcfg.warp.layer import episode_keys  # noqa: E402
from sensorcfg.warp.sensors import Sensors  # noqa: E402

ROBOT = str(assets.path("robot.xml"))
FEATURES = [
    ("qpos", ["joint:shoulder", "joint:elbow"]),
    ("qvel", "joint:elbow"),
    ("sensordata", "sensor:imu_accel"),
    ("xpos", "site:hand_site"),
    ("xquat", "body:hand"),
]
NOISE = [
    {"type": "gaussian", "std": 0.01},
    {"type": "gaussian", "mean": 0.001, "std": 0.02},
    {"type": "uniform", "low": -0.01, "high": 0.02},
    {"type": "quantize", "step": 0.001},
    {"type": "clip", "min": -0.5, "max": 0.5},
    {"type": "dropout", "p": 0.3, "mode": "hold"},
    {"type": "dropout", "p": 0.3, "mode": "zero", "per": "value"},
    {"type": "outlier", "p": 0.1, "scale": 1.0},
    {"type": "lowpass", "cutoff": 20.0},
    {"type": "bias", "std": 0.1},
    {"type": "scale", "low": 0.9, "high": 1.1},
    {"type": "random_walk", "std": 0.01, "correlation_time": 0.05},
    {"type": "random_walk", "std": 0.01},
]


def suite(seed: int, noise: bool) -> dict[str, sensorcfg.Observable]:
    rng = np.random.default_rng(seed)
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
    out = {}
    for j in range(int(rng.integers(3, 7))):
        kind, element = FEATURES[int(rng.integers(len(FEATURES)))]
        obs = sensorcfg.Feature(kind, element, update_interval=int(rng.integers(1, 6)), delay=int(rng.integers(0, 7)),
                                buffer_size=int(rng.integers(1, 6)),
                                aggregator=[None, None, "min", "max", "sum", "mean", "median"][int(rng.integers(7))])
        obs.reader(physics)
        if noise and rng.random() < 0.7:
            picks = rng.choice(len(NOISE), size=int(rng.integers(1, 4)), replace=False)
            obs.noise = build_noise([NOISE[int(p)] for p in picks], obs.array_spec.shape, obs.array_spec.dtype,
                                    physics.timestep)
        obs.enabled = True
        out[f"s{j}_{kind}"] = obs
    return out


def fields_of(datas: list[mujoco.MjData], names: list[str]) -> dict[str, wp.array]:
    return {f: wp.array(np.stack([np.ravel(getattr(d, f)) for d in datas]).astype(np.float32), dtype=wp.float32,
                        device="cpu") for f in names}


def replay(make: Callable[[], dict[str, Any]], model: mujoco.MjModel, nworld: int, substeps: int, pad: bool,
           control_steps: int, seed: int, resets: Mapping[int, Sequence[int]] | None = None) -> None:
    """World w of the Warp sensor layer against an Updater over `make()`'s observables, both reading world w's
    CPU trajectory (random actions): plain noise-free reads bit for bit, the rest to float32 rounding.
    `resets`: control step -> the worlds that start a second episode after its physics (one each at most)."""
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    bound = bind(make(), physics, substeps, False)
    plan = plan_suite(bound, physics, bound.sources(), nworld, substeps, pad)
    sensors = Sensors(plan, wp.get_device("cpu"), 2)
    names = [f for f, _ in plan.fields]
    plain = {s.name for s in plan.sensors if s.noise is None and s.aggregator is None}
    # the CPU side: one Updater and MjData per world, seeded per world
    updaters, physicss = [], []
    table = np.zeros(sensors.episodes.key_table.shape, np.uint64)
    values = np.zeros(sensors.episodes.value_table.shape)
    for w in range(nworld):
        p = Physics(model)
        mujoco.mj_resetData(model, p.data)
        mujoco.mj_forward(model, p.data)
        u = sensorcfg.Updater(make(), substeps, pad_with_initial_value=pad)
        u.reset(p, np.random.RandomState(100 + w))
        if sensors.key_names:
            for e in range(2):  # the episodes' keys, as the Updater draws them from their random states
                entropy = episode_entropy(np.random.RandomState(100 * (e + 1) + w))
                table[w, e], values[w, e] = episode_keys(sensors, entropy)
        updaters.append(u)
        physicss.append(p)
    sensors.episodes.key_table.assign(table)
    sensors.episodes.value_table.assign(values)
    steps = wp.zeros(nworld, dtype=wp.int64, device="cpu")
    age = np.zeros(nworld, np.int64)
    everyone = wp.ones(nworld, dtype=wp.int32, device="cpu")
    sensors.reset(everyone, fields_of([p.data for p in physicss], names), steps)
    lo, hi = model.actuator_ctrlrange.T
    actions = np.random.default_rng(seed).uniform(lo, hi, (control_steps, nworld, model.nu))
    for t in range(control_steps + 1):
        if t:  # each world's control step through its Updater, keeping the states it sampled
            snapshots: list[list[mujoco.MjData]] = [[] for _ in range(substeps)]
            for w, (u, p) in enumerate(zip(updaters, physicss)):
                p.data.ctrl[:] = actions[t - 1, w]

                def step(p: Physics = p, w: int = w) -> None:
                    mujoco.mj_step(model, p.data)
                    copy = mujoco.MjData(model)
                    mujoco.mj_copyData(copy, model, p.data)
                    snapshots[sum(len(s) > w for s in snapshots)].append(copy)
                u.control_step(step)
            for k in range(substeps):
                steps.assign(age + k + 1)
                sensors.record(fields_of(snapshots[k], names), steps)
            age += substeps
            again = list((resets or {}).get(t, ()))
            if again:  # a second episode of these worlds, from the model's initial state
                for w in again:
                    mujoco.mj_resetData(model, physicss[w].data)
                    mujoco.mj_forward(model, physicss[w].data)
                    updaters[w].reset(physicss[w], np.random.RandomState(200 + w))
                age[again] = 0
                steps.assign(age)
                mask = np.zeros(nworld, np.int32)
                mask[again] = 1
                sensors.reset(wp.array(mask, dtype=wp.int32, device="cpu"),
                              fields_of([p.data for p in physicss], names), steps)
        got = {name: array.numpy() for name, array in sensors.read(steps).items()}
        for w, u in enumerate(updaters):
            for name, value in u.get_observation().items():
                assert got[name][w].shape == value.shape, name
                if name in plain:  # a noise-free plain read is a copy of the float32 field
                    assert got[name][w].tobytes() == value.astype(np.float32).tobytes(), (w, t, name)
                else:  # sums of float32 samples and noise arithmetic: to float32 rounding
                    np.testing.assert_allclose(got[name][w], value, rtol=1e-5, atol=1e-6,
                                               err_msg=f"world {w} step {t} {name}")


@pytest.mark.parametrize("seed, noise", [(s, s % 3 != 0) for s in (*range(9), 11, 13)])
def test_world_i_reads_what_the_updater_reads_on_the_same_trajectory(seed: int, noise: bool) -> None:
    replay(lambda: suite(seed, noise), mujoco.MjModel.from_xml_path(ROBOT), 3, 1 + seed % 3, bool(seed % 2), 30, seed)


@pytest.mark.parametrize("recipe, like", [("quadruped", "go2_like.xml"), ("humanoid", "g1_like.xml")])
def test_the_recipes_read_the_same_on_both_engines(recipe: str, like: str) -> None:
    """docs/recipes.md's suites on our stand-ins of Menagerie's Go2 and G1 (their height scans aside: this replay
    feeds mjData fields; tests/warp/test_warp_rays.py replays height scans)."""
    text = (ROOT / "docs" / "recipes" / f"{recipe}.yaml").read_text()
    line = next(line for line in text.splitlines() if line.startswith("model: "))
    loaded = sensorcfg.loads(text.replace(line, ""), file=f"{recipe}.yaml")
    model = loaded.compile(str(MODELS / like), batch=True)

    def make() -> dict[str, Any]:
        built = loaded.build(model, batch=True)
        return {name: obs for name, obs in built.items() if obs.enabled and not getattr(obs, "per_simulation", False)}

    substeps = loaded.updater_kwargs(model).get("physics_steps_per_control_step") or 4
    replay(make, model, 2, int(substeps), False, 12, 0)


def test_a_padded_read_shows_the_reset_sample_noised_though_no_window_shows_it() -> None:
    """Interval 2, delay 1, 3 physics steps per control step: no read's window shows sample 0 (the read at 3
    shows sample 1), so the plan's `taken` mask leaves step 0 out; but the reset sample is always taken, and a
    padded read shows it (at step 0): noised as on the CPU, misalign's turn included."""
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))

    def make() -> dict[str, sensorcfg.Observable]:
        out = {"joints": sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], update_interval=2, delay=1),
               "hand": sensorcfg.Feature("xpos", "site:hand_site", update_interval=2, delay=1)}
        stages = {"joints": [{"type": "gaussian", "std": 0.1}],
                  "hand": [{"type": "gaussian", "std": 0.1}, {"type": "misalign", "std": 0.2}]}
        for name, obs in out.items():
            obs.reader(physics)
            obs.noise = build_noise(stages[name], obs.array_spec.shape, obs.array_spec.dtype, physics.timestep)
            obs.enabled = True
        return out

    replay(make, mujoco.MjModel.from_xml_path(ROBOT), 2, 3, True, 2, 0)
