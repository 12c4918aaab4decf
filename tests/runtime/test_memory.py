"""Memory in proportion to the data a sensor keeps, whatever its buffer and delay (docs/semantics.md, "Memory").

A 14-value sensor with buffer 1000 and delay 5000 steps keeps 0.67 MB of samples; buffer 20000 keeps
2.2 MB. The Updater and the batch hold those samples once or twice, plus read layouts kept within a budget
(`sensorcfg.cache`), and stop growing once every phase has been read.
"""

from __future__ import annotations

import tracemalloc

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.cache import DEFAULT_BUDGET

MODEL = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
MB = 1 << 20
needs_batch = pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4,
                                 reason=f"mujoco.batch needs MuJoCo 4; this is {mujoco.__version__}")


def traced(step, warmup: int, more: int) -> tuple[int, int]:
    """Traced bytes after `warmup` calls of `step` and after `more` further calls."""
    tracemalloc.start()
    try:
        for _ in range(warmup):
            step()
        early = tracemalloc.get_traced_memory()[0]
        for _ in range(more):
            step()
        return early, tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("buffer,delay,aggregator", [(1000, 5000, None), (20000, 0, None), (20000, 0, "mean"),
                                                     (300, 2000, None)])
def test_updater_memory_is_bounded_by_the_data_kept(buffer, delay, aggregator):
    observable = sensorcfg.Feature("qpos", "joint:*", buffer_size=buffer, delay=delay, aggregator=aggregator)
    observable.enabled = True
    physics = sensorcfg.Physics(MODEL)
    updater = sensorcfg.Updater({"q": observable}, 1)
    kept = (buffer + delay) * 14 * 8

    def step():
        updater.prepare_for_next_control_step()
        mujoco.mj_step(MODEL, physics.data)
        updater.update()
        updater.get_observation()

    tracemalloc.start()
    try:
        updater.reset(physics, np.random.RandomState(0))
        built = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    early, late = traced(step, 50, 400)
    assert built < 4 * kept + MB, f"{built / MB:.1f} MB at reset for {kept / MB:.2f} MB of samples"
    # read layouts are kept within the cache budgets, whatever the number of phases
    assert late < 4 * kept + 2 * max(DEFAULT_BUDGET, 2 * kept) + MB, f"{late / MB:.1f} MB"
    assert observable.buffer_size == buffer


@needs_batch
def test_batch_memory_is_bounded_by_the_data_kept():
    from sensorcfg.batch import BatchEnvironment

    suite = sensorcfg.loads("version: 1\nmodel: package://sensorcfg/assets/robot.xml\noptions: {control_interval: 2ms}\n"
                            "sensors:\n  q: {kind: qpos, element: 'joint:*', buffer: 1000, delay: 10s}\n")
    nsim = 4
    env = BatchEnvironment(suite.model, suite, nsim, seed=0)
    env.reset()
    action = np.zeros((nsim, *env.action_spec().shape[1:]))
    kept = nsim * (1000 + 5000) * 14 * 8
    early, late = traced(lambda: env.step(action), 10, 300)
    assert late - early < 3 * max(DEFAULT_BUDGET, 2 * kept), f"grew by {(late - early) / MB:.1f} MB"


@pytest.mark.parametrize("noise", [None, [{"type": "gaussian", "std": 0.01}]], ids=["plain", "noisy"])
def test_each_phase_is_compiled_once(noise, monkeypatch):
    """Read layouts of every phase fit the cache: after one cycle of the history, reads compile nothing (a
    noisy bank's compiled reads refer to its noise fields, which must not count against the budget once per read)."""
    from sensorcfg.noise import build_noise
    from sensorcfg.runtime.bank import FeatureBank

    observable = sensorcfg.Feature("qpos", "joint:*", buffer_size=4, aggregator="mean")
    observable.enabled = True
    physics = sensorcfg.Physics(MODEL)
    updater = sensorcfg.Updater({"q": observable}, 5)
    updater.reset(physics, np.random.RandomState(0))
    if noise:
        observable.noise = build_noise(noise, observable.array_spec.shape, np.float64, MODEL.opt.timestep)
    updater.reset(physics, np.random.RandomState(0))
    bank = updater._bank
    assert bank is not None and (bank.noise is not None) == bool(noise)
    compiled = []
    original = FeatureBank._compile
    monkeypatch.setattr(FeatureBank, "_compile", lambda self, phase: compiled.append(phase) or original(self, phase))

    def control_step():
        updater.prepare_for_next_control_step()
        for _ in range(5):
            mujoco.mj_step(MODEL, physics.data)
            updater.update()
        updater.get_observation()

    for _ in range(bank.rows // 5):
        control_step()
    assert len(compiled) == bank.rows // 5
    for _ in range(2 * bank.rows // 5):
        control_step()
    assert len(compiled) == bank.rows // 5


@pytest.mark.parametrize("sensor", [
    pytest.param("{kind: heightscan, element: body:base, delay: 3000}", id="scan-delay"),
    pytest.param("{kind: heightscan, element: body:base, delay: 300, buffer: 4}", id="scan-doubled-ring"),
    pytest.param("{kind: heightscan, element: body:base, delay: {uniform: [0, 3000]}, buffer: 20}", id="scan-drawn"),
    pytest.param("{kind: qpos, element: 'joint:*', delay: 20000}", id="bank-delay"),
    pytest.param("{kind: qpos, element: 'joint:*', buffer: 200, interval: 100}", id="bank-buffer"),
    pytest.param("{kind: qpos, element: 'joint:*', delay: 10000, noise: [{type: gaussian, std: 0.1}]}", id="bank-noisy"),
    pytest.param("{kind: gyro, element: site:imu, delay: 20000}", id="bank-narrow"),
    pytest.param("{kind: qpos, element: 'joint:*', delay: {uniform: [0, 10000]}}", id="drawn-bank-delay"),
    pytest.param("{kind: qpos, element: 'joint:*', interval: {uniform: [1, 50]}, buffer: 100}", id="drawn-bank-buffer"),
])
@pytest.mark.parametrize("substeps", [1, 10])
def test_what_a_sensor_keeps_is_estimated_above_what_the_updater_allocates(sensor: str, substeps: int) -> None:
    """The memory check's estimate (`sensorcfg.memory.kept`) for each path a schedule takes (ring, doubled
    ring, drawn channel, feature bank, noisy bank, drawn bank) is at least what the Updater holds after
    some control steps (1 MB for what does not grow with the schedule)."""
    from sensorcfg.memory import kept

    suite = sensorcfg.loads(f"options: {{control_interval: {substeps}}}\nsensors:\n  s: {sensor}\n")
    model = suite.compile(str(assets.path("robot.xml")))
    observables = suite.build(model)
    physics = sensorcfg.Physics(model)
    updater = sensorcfg.Updater(observables, substeps)

    def step():
        updater.prepare_for_next_control_step()
        for _ in range(substeps):
            mujoco.mj_step(model, physics.data)
            updater.update()
        updater.get_observation()

    tracemalloc.start()
    try:
        updater.reset(physics, np.random.RandomState(0))
        for _ in range(10):
            step()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    estimate = kept(observables["s"], substeps)
    assert estimate is not None and peak < estimate.bytes() + MB, f"{peak / MB:.1f} MB > {estimate.bytes() / MB:.1f} MB"


@pytest.mark.parametrize("sensor, expected", [
    pytest.param("{kind: heightscan, element: body:base, delay: 1000000}",
                 "2:52: error: sensors.s.delay: a delay of 1,000,000 steps keeps 1,000,002 samples of 1,496 bytes "
                 "(17x11 float64): 1.6 GiB; a sensor may keep at most 1 GiB between its samples and its reads: use a "
                 "shorter delay or a longer interval, or a smaller value", id="scan"),
    pytest.param("{kind: rgb, element: camera:wrist, delay: 1000000}",
                 "2:48: error: sensors.s.delay: a delay of 1,000,000 steps keeps 1,000,002 samples of 230,400 bytes "
                 "(240x320x3 uint8): 214.8 GiB; a sensor may keep at most 1 GiB between its samples and its reads: "
                 "use a shorter delay or a longer interval, or a smaller value", id="camera"),
    pytest.param("{kind: rgb, element: camera:wrist, delay: {uniform: [0, 10000]}, interval: 2}",
                 "2:48: error: sensors.s.delay: a delay of up to 10,000 steps at an interval of 2 keeps 35,008 samples "
                 "of 230,400 bytes (240x320x3 uint8): 7.5 GiB; a sensor may keep at most 1 GiB between its samples "
                 "and its reads: use a shorter delay or a longer interval, or a smaller value", id="camera-drawn"),
    pytest.param("{kind: qpos, element: 'joint:*', interval: {uniform: [1, 50]}, buffer: 1000}",
                 "2:77: error: sensors.s.buffer: a buffer of 1,000 at intervals up to 50 steps keeps 52,736 steps of "
                 "history of 112 bytes (14 float64): 11.0 GiB; a sensor may keep at most 1 GiB between its samples "
                 "and its reads: use a smaller buffer or a longer interval, or a smaller value", id="drawn-bank"),
])
def test_a_sensor_that_would_keep_too_much_is_a_problem_at_the_line_that_sets_it(sensor: str, expected: str) -> None:
    """Found by review: a delay of 1,000,000 steps on a height scan or a camera validated, then failed to
    allocate gigabytes; the check counted only the buffer."""
    suite = sensorcfg.loads(f"sensors:\n  s: {sensor}\n", file="f.yaml")
    assert [p.format() for p in suite.check(MODEL)] == ["f.yaml:" + expected]
    with pytest.raises(sensorcfg.SuiteError):
        sensorcfg.Environment(MODEL, suite)


def test_one_long_history_lengthens_every_plain_features_rows() -> None:
    suite = sensorcfg.loads("sensors:\n  a: {kind: xmat, element: 'body:*'}\n  b: {kind: cinert, element: 'body:*'}\n"
                            "  t: {kind: qpos, element: 'joint:shoulder', buffer: 10000, interval: 60}\n", file="f.yaml")
    assert [p.format() for p in suite.check(MODEL)] == [
        "f.yaml:4:54: error: sensors.t.buffer: a buffer of 10,000 at an interval of 60 steps makes the plain features' "
        "shared history 600,060 steps long, each of 920 bytes (the 3 float64 features' values): 1.3 GiB; a sensor "
        "may keep at most 1 GiB between its samples and its reads: use a smaller buffer or a longer interval, or "
        "observe fewer values"]


@pytest.mark.parametrize("sensor, substeps", [
    pytest.param("{kind: qpos, element: 'joint:*', interval: 7, buffer: 100}", 10, id="fixed"),
    pytest.param("{kind: qpos, element: 'joint:*', interval: 7, buffer: 100, noise: [{type: gaussian, std: 0.1}]}", 3,
                 id="noisy"),
    pytest.param("{kind: qpos, element: 'joint:*', interval: 3, delay: {uniform: [3, 50]}, buffer: 100}", 2, id="drawn-delay"),
    pytest.param("{kind: qpos, element: 'joint:*', interval: {uniform: [1, 50]}, buffer: 100}", 1, id="drawn-interval"),
])
def test_the_history_the_check_counts_is_the_one_the_updater_allocates(sensor: str, substeps: int) -> None:
    """Found by review: a history's rows are its span rounded up to a multiple of the sampling period (or of
    the chunk drawn ahead), and the check counted the span alone. Both now call `schedule.history_rows`."""
    from sensorcfg.memory import kept

    suite = sensorcfg.loads(f"options: {{control_interval: {substeps}}}\nsensors:\n  s: {sensor}\n")
    model = suite.compile(str(assets.path("robot.xml")))
    observables = suite.build(model)
    updater = sensorcfg.Updater(observables, substeps)
    updater.reset(sensorcfg.Physics(model), np.random.RandomState(0))
    bank = updater._bank or updater._drawn
    estimate = kept(observables["s"], substeps)
    assert bank is not None and estimate is not None
    assert bank.rows % substeps == 0 and estimate.steps == bank.rows


def test_plain_features_whose_intervals_repeat_together_rarely_are_a_problem_at_an_interval() -> None:
    """The shared history's rows are a multiple of every member's period: three short schedules whose intervals
    have a large common multiple make it long, though each member alone keeps a few hundred steps."""
    suite = sensorcfg.loads("sensors:\n  a: {kind: xmat, element: 'body:*', interval: 97}\n"
                            "  b: {kind: cinert, element: 'body:*', interval: 89}\n"
                            "  t: {kind: qpos, element: 'joint:shoulder', interval: 61}\n", file="f.yaml")
    assert [p.format() for p in suite.check(MODEL)] == [
        "f.yaml:2:48: error: sensors.a.interval: the plain features' intervals (61, 89, 97 steps) repeat together "
        "only every 526,613 steps, which makes their shared history 526,613 steps long, each of 920 bytes (the 3 "
        "float64 features' values): 1.1 GiB; a sensor may keep at most 1 GiB between its samples and its reads: use "
        "intervals with a smaller common multiple, or observe fewer values"]


@needs_batch
def test_a_batch_history_is_counted_as_its_layout_allocates_it() -> None:
    """The batch's history is a multiple of every fixed interval's period (7 x 11 = 77 steps): 231 rows, where
    the longest member alone needs 217. The check counts the rows the layout allocates."""
    from sensorcfg.batch import BatchEnvironment
    from sensorcfg.memory import kept_problems

    suite = sensorcfg.loads("sensors:\n  a: {kind: qpos, element: 'joint:*', interval: 7, buffer: 30}\n"
                            "  b: {kind: qvel, element: 'joint:*', interval: 11}\n", file="f.yaml")
    env = BatchEnvironment(MODEL, suite, 2, seed=0)
    assert env._updater.layout.rows == 231
    observables = suite.build(MODEL, batch=True)
    assert [m for _, _, m in kept_problems(observables, MODEL, 1, 23_500, batch=True)] == [
        "the plain features' intervals (7, 11 steps) repeat together only every 77 steps, which makes their shared "
        "history 231 steps long, each of 208 bytes (the 2 float64 features' values) in each of 23,500 simulations: "
        "1.1 GiB in all; a sensor may keep at most 1 GiB between its samples and its reads: use intervals with a "
        "smaller common multiple, or observe fewer values"]


@needs_batch
def test_a_batch_counts_what_each_simulation_keeps() -> None:
    from sensorcfg.batch import BatchEnvironment

    suite = sensorcfg.loads("sensors:\n  s: {kind: heightscan, element: body:base, delay: 100000}\n", file="f.yaml")
    assert suite.check(MODEL, batch=True) == []  # one simulation keeps 0.2 GiB
    with pytest.raises(sensorcfg.SuiteError) as info:
        BatchEnvironment(MODEL, suite, 16)
    assert str(info.value) == (
        "f.yaml:2:52: error: sensors.s.delay: a delay of 100,000 steps keeps 100,002 samples of 1,496 bytes (17x11 "
        "float64) in each of 16 simulations: 2.5 GiB in all; a sensor may keep at most 1 GiB between its samples and "
        "its reads: use a shorter delay or a longer interval, or a smaller value")


@needs_batch
def test_a_batch_of_thousands_of_noisy_proprioceptive_simulations_is_not_refused() -> None:
    """Found by review: the batch was estimated with the single Updater's stores (a noise block of 1,024
    steps drawn ahead, a numpy view per history row), 100 times what its flat history holds, so a noisy qpos
    over 4,096 simulations was refused as 3.1 GiB. The estimate stays above what the layout allocates."""
    from sensorcfg.batch import BatchEnvironment
    from sensorcfg.memory import kept

    suite = sensorcfg.loads("sensors:\n  q: {kind: qpos, element: 'joint:*', buffer: 10, noise: [{type: gaussian, std: 0.1}]}\n"
                            "  s: {kind: sensordata, element: 'sensor:*', delay: {uniform: [0, 20]}, buffer: 5}\n",
                            file="f.yaml")
    nsim = 4096
    env = BatchEnvironment(MODEL, suite, nsim, seed=0)
    env.reset()
    observables = suite.build(MODEL, batch=True)
    physics = sensorcfg.Physics(MODEL)
    for observable in observables.values():
        observable.reader(physics)
    estimate = sum(k.bytes(nsim) for o in observables.values() for k in [kept(o, 1, batch=True)] if k)
    assert env._updater.layout.flat.nbytes <= estimate
