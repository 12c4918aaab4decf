"""Planned schedules (`{uniform}` / `{choice}` intervals and delays): the stream rule of runtime/drawn.py.

A brute force of the rule (every sample of the schedule taken, delivered in (arrival, time) order, the last
`buffer` shown) against the Updater, on a clock sensor; windows independent of other sensors; the feature bank
path against the per-sample path, bit for bit, noise included.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.draws import ChoiceSteps, UniformSteps, episode_entropy, sensor_key
from sensorcfg.noise import build_noise
from sensorcfg.noise.streams import philox

ROBOT = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
MODEL = """<mujoco><option timestep="0.001"/><worldbody><body><joint name="slide" type="slide"/><geom size=".1"/>
</body></worldbody><actuator><motor joint="slide"/></actuator></mujoco>"""


def step_of(physics) -> np.ndarray:
    return np.array([round(physics.data.time / 0.001) + 1.0])  # +1: padding zeros stay distinguishable


def draws(setting, key: np.ndarray, lane: int, count: int) -> np.ndarray:
    """The first `count` draws of a schedule stream, straight from the rule: the first word of Philox4x32-10
    at counter (j, lane << 22, lo32(k1'), hi32(k1')), key (lo32(k0), hi32(k0)), with k1' = k1 xor 2^63; a
    uniform u = word / 2^32 gives low + floor(u (high - low + 1)), or the choice whose cumulative
    probability first exceeds u."""
    if isinstance(setting, int):
        return np.full(count, setting)
    k0, k1 = int(key[0]), int(key[1]) ^ (1 << 63)
    j = np.arange(count, dtype=np.uint32)
    word = philox([j, np.full(count, lane << 22, np.uint32), np.full(count, k1 & 0xFFFFFFFF, np.uint32),
                   np.full(count, k1 >> 32, np.uint32)],
                  [np.full(count, k0 & 0xFFFFFFFF, np.uint32), np.full(count, k0 >> 32, np.uint32)])[0]
    u = word.astype(np.float64) / 2**32
    if isinstance(setting, UniformSteps):
        return setting.low + np.floor(u * (setting.high - setting.low + 1)).astype(np.int64)
    p = np.full(len(setting.values), 1 / len(setting.values)) if setting.p is None else np.asarray(setting.p)
    index = [next((i for i, c in enumerate(np.cumsum(p)) if x < c), len(p) - 1) for x in u]
    return np.asarray(setting.values)[index]


def brute_force(interval, delay, buffer: int, substeps: int, key: np.ndarray, steps: int) -> list[list[int]]:
    """Per read (every `substeps` steps, from step 0): the sample steps shown, oldest first (-1: padding)."""
    count = steps + 1
    gaps = draws(interval, key, 0, count)
    times = np.arange(count) * interval if isinstance(interval, int) else np.cumsum(gaps) - gaps[0]
    arrivals = times + draws(delay, key, 1, count)
    order = sorted(range(count), key=lambda j: (arrivals[j], times[j]))
    out = []
    for read in range(0, steps + 1, substeps):
        delivered = [int(times[j]) for j in order if arrivals[j] <= read]
        window = ([-1] * buffer + delivered)[-buffer:]
        out.append(window)
    return out


@pytest.mark.parametrize("interval, delay, buffer, substeps", [
    (1, UniformSteps(1, 3), 1, 5),
    (1, UniformSteps(0, 9), 3, 2),
    (UniformSteps(1, 4), UniformSteps(0, 6), 3, 5),
    (7, ChoiceSteps((2, 9), (0.5, 0.5)), 2, 3),
    (UniformSteps(2, 5), 4, 4, 1),
    (ChoiceSteps((1, 3)), ChoiceSteps((5, 10), (0.8, 0.2)), 2, 10),
])
def test_updater_follows_the_stream_rule(interval, delay, buffer, substeps) -> None:
    model = mujoco.MjModel.from_xml_string(MODEL)
    physics = sensorcfg.Physics(model)
    clock = sensorcfg.Generic(step_of, update_interval=interval, delay=delay, buffer_size=buffer)
    clock.enabled = True
    other = sensorcfg.Generic(step_of, update_interval=UniformSteps(1, 3), delay=UniformSteps(0, 2))
    other.enabled = True
    steps = 1200  # several planning rounds
    for observables in ({"clock": clock}, {"a_first": other, "clock": clock}):
        mujoco.mj_resetData(model, physics.data)
        updater = sensorcfg.Updater(observables, substeps)
        random_state = np.random.RandomState(3)
        updater.reset(physics, random_state)
        key = sensor_key(episode_entropy(np.random.RandomState(3)), "clock")
        expected = brute_force(interval, delay, buffer, substeps, key, steps)
        seen = [updater.get_observation()["clock"].ravel()]
        for _ in range(steps // substeps):
            updater.prepare_for_next_control_step()
            for _ in range(substeps):
                mujoco.mj_step(model, physics.data)
                updater.update()
            seen.append(updater.get_observation()["clock"].ravel())
        for read, (got, want) in enumerate(zip(seen, expected)):
            np.testing.assert_array_equal(got, np.array(want) + 1, err_msg=f"read {read} ({list(observables)})")


_STAGES = [[{"type": "gaussian", "std": 0.01}], [{"type": "bias", "std": 0.1}, {"type": "quantize", "step": 0.01}],
           [{"type": "random_walk", "std": 0.01, "correlation_time": 0.05}, {"type": "clip", "min": -0.2, "max": 0.2}],
           None]
_ELEMENTS = [("qpos", "joint:*"), ("qvel", "joint:*"), ("xpos", "site:fingertip"), ("qpos", "joint:wrist")]


def _noisy_suite(seed: int, intervals: list[Any] | None = None, delays: list[Any] | None = None,
                 stages: list[Any] = _STAGES, aggregators: list[Any] = [None, "mean", "max", "sum"],
                 elements: list[tuple[str, str]] = _ELEMENTS) -> dict[str, sensorcfg.Observable]:
    """Features of the bundled robot with random schedules (drawn ones by default), buffers, aggregators and
    noise stages (also `tests/runtime/test_read_kernel.py`'s)."""
    rng = np.random.default_rng(seed)
    model = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
    physics = sensorcfg.Physics(model)
    intervals = intervals or [1, UniformSteps(1, 4), ChoiceSteps((2, 5))]
    delays = delays or [UniformSteps(0, 3), ChoiceSteps((1, 7), (0.7, 0.3)), 2]
    out = {}
    for j, (kind, element) in enumerate(elements * 2):
        interval = intervals[int(rng.integers(len(intervals)))]
        delay = delays[int(rng.integers(len(delays)))]
        buffer = int(rng.integers(1, 5))
        aggregator = aggregators[int(rng.integers(len(aggregators)))]
        obs = sensorcfg.Feature(kind, element, update_interval=interval, delay=delay, buffer_size=buffer,
                                aggregator="mean" if aggregator == "median" and buffer > 2 else aggregator)
        obs.reader(physics)
        noise = stages[int(rng.integers(len(stages)))]
        if noise:
            obs.noise = build_noise(noise, obs.array_spec.shape, np.float64, physics.timestep)
        obs.enabled = True
        out[f"s{j}"] = obs
    return out


def _bank_and_per_sample(make, monkeypatch, episodes, pad: bool = False, counts_every: int = 0):
    """Runs the observables `make()` builds through the bank and per sample, 3 substeps per control step, over
    `episodes` ((random state seed, controls) each); asserts both give the same observations and sample
    counts (after each episode, and every `counts_every` control steps), and returns the banked Updater."""
    from sensorcfg.runtime import updater as updater_module

    model = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
    runs = []
    for banked in (True, False):
        if not banked:
            monkeypatch.setattr(updater_module, "joins", lambda ch: False)
        physics = sensorcfg.Physics(model)
        updater = sensorcfg.Updater(make(), 3, pad_with_initial_value=pad)
        seen, taken = [], []
        for seed, controls in episodes:
            updater.reset(physics, np.random.RandomState(seed))
            assert (updater._drawn is not None) == banked
            seen.append(updater.get_observation())
            for i, control in enumerate(controls):
                physics.data.ctrl[:] = control
                updater.prepare_for_next_control_step()
                for _ in range(3):
                    mujoco.mj_step(model, physics.data)
                    updater.update()
                seen.append(updater.get_observation())
                if counts_every and i % counts_every == 0:
                    taken.append(updater.samples_taken())
            taken.append(updater.samples_taken())
        runs.append((seen, taken, updater))
    (a_seen, a_taken, banked_updater), (b_seen, b_taken, _) = runs
    assert a_taken == b_taken
    assert len(a_seen) == len(b_seen) == sum(len(controls) + 1 for _, controls in episodes)
    for s, (a, b) in enumerate(zip(a_seen, b_seen)):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name], err_msg=f"read {s} {name}")
    return banked_updater


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_bank_reads_what_the_per_sample_path_reads(seed, monkeypatch) -> None:
    controls = np.random.default_rng(seed).uniform(-1, 1, (400, ROBOT.nu))
    _bank_and_per_sample(lambda: _noisy_suite(seed), monkeypatch, [(seed, controls)], pad=bool(seed % 2))


@pytest.mark.parametrize("suite", ["late-alone", "suite", "long-span"])
def test_the_bank_follows_the_per_sample_path_over_rounds_and_episodes(suite, monkeypatch) -> None:
    """The bank plans every member in one planner (buffers of different sizes), each round shortly before it
    starts (a whole round ahead when a member's span is longer than a round), and is kept across resets:
    the same observations and sample counts as the per-sample path, over several rounds and episodes. A
    sensor alone (no other member's snapshot at its steps) with long delays takes samples just before a
    round whose first read is in that round."""
    def make() -> dict[str, sensorcfg.Observable]:
        observables = {} if suite == "late-alone" else _noisy_suite(3)
        observables["late"] = sensorcfg.Feature("qpos", "joint:*", delay=UniformSteps(0, 9))
        if suite == "long-span":
            observables["long"] = sensorcfg.Feature("qvel", "joint:*", update_interval=ChoiceSteps((20, 30)),
                                                    delay=UniformSteps(0, 5), buffer_size=40, aggregator="mean")
        for observable in observables.values():
            observable.enabled = True
        return observables

    controls = np.random.default_rng(4).uniform(-1, 1, (1300, ROBOT.nu))
    banked = _bank_and_per_sample(make, monkeypatch, [(0, controls), (1, controls[:400])], counts_every=97)
    assert (banked._drawn.ahead == banked._drawn.chunk) == (suite == "long-span")


@pytest.mark.parametrize("aggregator", ["", ", aggregator: sum"])
def test_a_second_reset_in_a_row_reads_its_own_episode(aggregator: str) -> None:
    """Two resets with no step between them: the second episode's first read is its own (the planned bank once
    kept the first episode's read, as both are at step 0), and no sample is due before its step 8, so the
    first step shows the same window."""
    text = ("version: 1\nsensors:\n  x: {kind: qvel, element: 'joint:elbow', interval: {uniform: [8, 9]}, buffer: 3"
            f"{aggregator}, noise: [{{type: gaussian, std: 1.0}}]}}\n")
    env = sensorcfg.Environment(str(assets.path("robot.xml")), sensorcfg.loads(text), seed=0,
                                physics_steps_per_control_step=5)
    first = env.reset().observation["x"]
    second = env.reset().observation["x"]
    assert not np.array_equal(first, second)  # a new episode: new noise
    np.testing.assert_array_equal(env.step(np.zeros(env.action_spec().shape)).observation["x"], second)
