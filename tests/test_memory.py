"""Memory in proportion to the data a sensor keeps, whatever its buffer and delay (README, Performance).

A 14-value sensor with buffer 1000 and delay 5000 steps keeps 0.67 MB of samples; buffer 20000 keeps
2.2 MB. The Updater and the batch hold those samples once or twice, plus read plans kept within a budget
(`runtime.cache`), and stop growing once every phase has been read.
"""

from __future__ import annotations

import tracemalloc

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.runtime.cache import DEFAULT_BUDGET

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
    # read plans are kept within the cache budgets, whatever the number of phases
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
    """Read plans of every phase fit the cache: after one cycle of the history, reads compile nothing (a noisy
    bank's plans refer to its noise fields, which must not count against the budget once per plan)."""
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
