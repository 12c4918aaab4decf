"""A planning round's ordering, windows and samples to take compiled (`_kernel.plan`, runtime/drawn.py) equal
the numpy steps they stand for: the same rounds, tails and samples in flight, for one simulation's members and
for subsets of many simulations restarted at different times (the batch's use), with buffers of different
sizes, stateful noise (every sample taken) and delays longer than a round's reads apart. Where the kernel is
meant to be built (SENSORCFG_REQUIRE_KERNEL=1) a missing kernel fails."""

from __future__ import annotations

import functools
import os

import numpy as np
import pytest

from sensorcfg import compiled
from sensorcfg.draws import ChoiceSteps, UniformSteps
from sensorcfg.runtime import drawn
from sensorcfg.runtime.drawn import Drawn, Planner

KERNEL = getattr(compiled.MODULE, "plan", None) is not None
pytestmark = pytest.mark.skipif(not KERNEL, reason="the kernel is not built: numpy plans every round")


@pytest.fixture(autouse=True)
def _kernel_present():
    if not KERNEL and os.environ.get("SENSORCFG_REQUIRE_KERNEL", "") not in ("", "0"):
        pytest.fail("the compiled kernel is not built (SENSORCFG_REQUIRE_KERNEL=1)", pytrace=False)


def _schedules(rng: np.random.Generator, count: int, substeps: int) -> list[Drawn]:
    intervals = [1, 3, UniformSteps(1, 4), ChoiceSteps((2, 7)), UniformSteps(1, 2)]  # planned: at least 1
    delays = [0, 2, UniformSteps(0, 3), UniformSteps(1, 40), ChoiceSteps((1, 9), (0.7, 0.3))]
    return [Drawn(intervals[int(rng.integers(len(intervals)))], delays[int(rng.integers(len(delays)))],
                  int(rng.integers(1, 5)), substeps, bool(rng.random() < 0.2)) for _ in range(count)]


def _rounds(schedules: list[Drawn], seed: int, kernel: bool, monkeypatch: pytest.MonkeyPatch) -> list[object]:
    """Rounds of random lengths for random subsets of the simulations (restarted at random), and the state
    after each."""
    monkeypatch.setattr(drawn, "_ROUND_KERNEL", drawn._ROUND_KERNEL if kernel else None)
    rng = np.random.default_rng(seed)
    planner = Planner(schedules, len(schedules))
    everyone = np.arange(len(schedules))
    keys = rng.integers(0, 2**63, (len(schedules), 2), dtype=np.uint64)
    out: list[object] = [planner.start(everyone, keys)]
    substeps = schedules[0].substeps
    for _ in range(12):
        sims = everyone if rng.random() < 0.5 else np.sort(rng.choice(everyone, int(rng.integers(1, len(everyone) + 1)),
                                                                      replace=False))
        if rng.random() < 0.2:
            out.append(planner.start(sims, keys[sims] + np.uint64(1)))
        out.append(planner.round(sims, substeps * int(rng.integers(1, 60))))
        out += [planner.tail.copy(), planner.flight.copy(), planner.end.copy(), planner.next.copy()]
    return out


@pytest.mark.parametrize("seed", range(12))
def test_the_compiled_round_is_the_numpy_round(seed, monkeypatch) -> None:
    rng = np.random.default_rng(100 + seed)
    schedules = _schedules(rng, int(rng.integers(1, 7)), int(rng.integers(1, 6)))
    with_kernel = _rounds(schedules, seed, True, monkeypatch)
    numpy_only = _rounds(schedules, seed, False, monkeypatch)
    for i, (a, b) in enumerate(zip(with_kernel, numpy_only)):
        parts_a, parts_b = (tuple(a), tuple(b)) if isinstance(a, tuple) else ((a,), (b,))
        for x, y in zip(parts_a, parts_b):
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), f"output {i}"


def _columns(flight: np.ndarray) -> list[tuple[int, ...]]:
    return sorted(map(tuple, flight.T.tolist()))


@pytest.mark.parametrize("seed", range(8))
def test_the_reset_round_in_closed_form_is_the_general_round(seed, monkeypatch) -> None:
    """`Planner.start` plans the reset read in closed form (`_reset_round`): the same windows, samples taken,
    tails, samples in flight (as a set: their order changes nothing) and positions as `round(sims, 0)`, for
    every simulation and for subsets restarted between rounds."""
    rng = np.random.default_rng(300 + seed)
    schedules = _schedules(rng, int(rng.integers(1, 7)), int(rng.integers(1, 6)))
    closed, general = Planner(schedules, len(schedules)), Planner(schedules, len(schedules))
    everyone = np.arange(len(schedules))
    keys = rng.integers(0, 2**63, (len(schedules), 2), dtype=np.uint64)

    def start(planner: Planner, sims: np.ndarray, k: np.ndarray, closed_form: bool) -> object:
        if not closed_form:
            monkeypatch.setattr(planner, "_reset_round", lambda s: planner.round(s, 0))
        out = planner.start(planner.all if sims is everyone else sims, k)
        monkeypatch.undo()
        return out

    for r in range(6):
        sims = everyone if r == 0 or rng.random() < 0.3 else np.sort(
            rng.choice(everyone, int(rng.integers(1, len(everyone) + 1)), replace=False))
        shifted = keys[sims] + np.uint64(r)
        a, b = start(closed, sims, shifted, True), start(general, sims, shifted, False)
        for x, y in zip(a, b):
            assert np.array_equal(x, y) and x.shape == y.shape
        assert _columns(closed.flight) == _columns(general.flight)
        for name in ("tail", "end", "next", "last", "keys"):
            assert np.array_equal(getattr(closed, name), getattr(general, name)), name
        length = schedules[0].substeps * int(rng.integers(1, 40))
        for x, y in zip(closed.round(everyone, length), general.round(everyone, length)):
            assert np.array_equal(x, y)


SNAPSHOT_SUITE = """
version: 1
sensors:
  q: {kind: qpos, element: "joint:*", delay: {uniform: [0, 3]}, buffer: 2}
  v: {kind: qvel, element: "joint:*", interval: {choice: [1, 3]}, delay: 1}
  f: {kind: force, element: "actuator:*", interval: {uniform: [1, 4]}}
  fixed_q: {kind: qpos, element: "joint:*", interval: 2, delay: 1, buffer: 3}
  fixed_v: {kind: qvel, element: "joint:elbow"}
"""


def _snapshots(bank, marks, task, physics, model) -> tuple[np.ndarray, np.ndarray | None]:
    """The history (and marks) after `task` ran at steps past the history's length, the state changing every
    step, `marks` setting the drawn bank's rows sampled (None: a fixed bank, sampled at every call)."""
    bank.history[:] = -1.0
    state = np.random.default_rng(1)
    for step in range(bank.rows + 50):
        if marks is not None:
            bank.need[step % bank.rows] = marks[step]
        physics.data.qpos[:] = state.standard_normal(model.nq)
        physics.data.qvel[:] = state.standard_normal(model.nv)
        physics.data.actuator_force[:] = state.standard_normal(model.nu)
        task(step)
    return bank.history.copy(), None if marks is None else bank.need.copy()


def test_the_compiled_snapshot_is_the_numpy_snapshot(monkeypatch) -> None:
    """`_kernel.snapshot` copies the state into the history row of a step: for the drawn bank where and only
    where a sample is taken then (clearing the mark), for the fixed bank at every call; the same history and
    marks as numpy's take, over steps past the history's length (rows wrap), the state changing every step."""
    import mujoco

    import sensorcfg
    from sensorcfg import assets

    model = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
    env = sensorcfg.Environment(model, sensorcfg.loads(SNAPSHOT_SUITE), physics_steps_per_control_step=2, seed=3)
    env.reset()
    drawn, fixed = env.updater._drawn, env.updater._bank
    assert drawn is not None and fixed is not None
    kernel_tasks = drawn.snapshot_task(), fixed._snapshot_task(None)
    monkeypatch.setattr(compiled, "MODULE", None)
    numpy_tasks = drawn.snapshot_task(), fixed._snapshot_task(None)
    assert all(isinstance(task, functools.partial) for task in kernel_tasks)
    assert not any(isinstance(task, functools.partial) for task in numpy_tasks)
    marks = np.random.default_rng(0).random(drawn.rows + 50) < 0.5
    (kernel_history, kernel_need), (numpy_history, numpy_need) = (
        _snapshots(drawn, marks, task, env.physics, model) for task in (kernel_tasks[0], numpy_tasks[0]))
    assert np.array_equal(kernel_history, numpy_history)
    assert kernel_need is not None and numpy_need is not None
    assert np.array_equal(kernel_need, numpy_need) and not kernel_need.any()
    assert (kernel_history != -1.0).any() and (kernel_history == -1.0).any()  # rows written and rows skipped
    (kernel_history, _), (numpy_history, _) = (_snapshots(fixed, None, task, env.physics, model)
                                               for task in (kernel_tasks[1], numpy_tasks[1]))
    assert np.array_equal(kernel_history, numpy_history) and not (kernel_history == -1.0).any()
