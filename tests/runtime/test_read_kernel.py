"""A feature bank's read run by the compiled kernel (`runtime/read_kernel.py`) gives the numpy steps' bits:
each op against its numpy reference on values that tell orders apart (signed zeros, infinities, ties,
rounding), and whole Updaters (fixed and planned schedules, every bank noise stage, every family
reduction, padding) with and without the kernel; a bank's snapshot by the kernel and by numpy's take. Where
the kernel is meant to be built (SENSORCFG_REQUIRE_KERNEL=1) a missing kernel fails; without it the kernel
reads are None."""

from __future__ import annotations

import functools
import os

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets, compiled
from sensorcfg.observables.aggregators import AGGREGATORS
from sensorcfg.runtime import bank, planned, read_kernel
from sensorcfg.runtime.bank_noise import Layer, ops_of
from sensorcfg.runtime.bank_read import CompiledRead, Step
from test_planned_schedules import _ELEMENTS, _STAGES, _noisy_suite

KERNEL = getattr(compiled.MODULE, "read", None) is not None


@pytest.fixture(autouse=True)
def _kernel_present():
    if not KERNEL and os.environ.get("SENSORCFG_REQUIRE_KERNEL", "") not in ("", "0"):
        pytest.fail("the compiled kernel is not built (SENSORCFG_REQUIRE_KERNEL=1)", pytrace=False)


def _bits(a: np.ndarray) -> list[int]:
    return np.ascontiguousarray(a, np.float64).view(np.int64).ravel().tolist()


def _awkward(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Values where the order of operations shows: signed zeros, infinities, halves, large and tiny."""
    pool = np.array([0.0, -0.0, np.inf, -np.inf, 0.5, -0.5, 1.5, 2.5, 1e300, -1e300, 1e-300, 3.0, -7.25])
    values = rng.normal(size=shape) * 10.0 ** rng.integers(-3, 4, shape)
    special = rng.random(shape) < 0.4
    values[special] = rng.choice(pool, int(special.sum()))
    return values


def _compiled_read(work: np.ndarray, gathered: np.ndarray, records: list[Step]) -> CompiledRead:
    return CompiledRead(np.zeros(0, np.intp), gathered, [s.run for s in records], records, work[None, :0],
                        lambda values: (), [], [], [])


@pytest.mark.skipif(not KERNEL, reason="the kernel is not built: numpy runs every read")
@pytest.mark.parametrize("seed", range(6))
def test_each_op_is_its_numpy_reference(seed) -> None:
    """Gather, noise layers, the stacking take, the families' reductions and the divisions, one program (or
    its two halves in turn)."""
    rng = np.random.default_rng(seed)
    n, width, buffer = 24, int(rng.integers(1, 6)), int(rng.integers(1, 5))
    history = _awkward(rng, (200,))
    field = _awkward(rng, (200,))
    index = rng.integers(-2, 202, n)  # some past either end: clipped, as numpy's mode="clip"
    values, cols = _awkward(rng, (9,)), rng.integers(0, 9, n)
    some = np.sort(rng.choice(n, 10, replace=False))
    layers = [Layer("term", np.arange(n), field, ()), Layer("add", some, values, (cols[some],)),
              Layer("term", some, field, ()), Layer("mul", np.arange(4, 12), values, (cols[4:12],)),
              Layer("quantize", some, None, (np.abs(_awkward(rng, (10,))) + 0.01,)),
              Layer("clip", np.arange(n), None, (np.minimum(_awkward(rng, (n,)), 0.0), np.maximum(_awkward(rng, (n,)), 0.0)))]
    runs = []
    for use_kernel in ("whole", "halves", False):  # (the awkward values overflow and divide infinities: no warnings)
        work = np.zeros(n + 3 * buffer * width + 3 * width)
        gathered, blocks = work[:n], work[n:n + 3 * buffer * width]
        take = np.resize(np.arange(n)[::-1], 3 * buffer * width)
        records = [Step("take", blocks, gathered, take, lambda: gathered.take(take, None, blocks, "clip"))]
        for f, kind in enumerate(("sum", "max", "min")):
            window = blocks[f * buffer * width:(f + 1) * buffer * width].reshape(buffer, width)
            out = work[n + 3 * buffer * width + f * width:][:width]
            reduce = AGGREGATORS[kind].reduce
            records.append(Step(kind, out, window, None, lambda r=reduce, w=window, o=out: r(w, o)))
        out, counts = work[n + 3 * buffer * width:][:width], np.full(width, float(buffer))
        records.append(Step("divide", out, counts, None, lambda: np.true_divide(out, counts, out)))
        read = _compiled_read(work, gathered, records)
        if use_kernel:
            kernel = read_kernel.kernel_read(read, layers, history)
            assert kernel is not None
            if use_kernel == "whole":
                kernel.run(np.ascontiguousarray(index, np.int64))
            else:  # the gather and noise, then the rest (a read writes padding between them)
                kernel.noised(np.ascontiguousarray(index, np.int64))
                assert _bits(gathered) != _bits(np.zeros(n)) and not work[n:].any()
                kernel.reduced(np.ascontiguousarray(index, np.int64))
        else:
            errors = np.seterr(all="ignore")
            history.take(index, None, gathered, "clip")
            for op in ops_of(layers, gathered):
                op(np.clip(index, 0, len(field) - 1))
            for step in read.steps:
                step()
            np.seterr(**errors)
        runs.append(work.copy())
    assert _bits(runs[0]) == _bits(runs[2]) and _bits(runs[1]) == _bits(runs[2])


def _suite(seed: int, drawn: bool) -> dict[str, sensorcfg.Observable]:
    """Every bank noise stage and every family (sum, mean and median of two, max, min, with plain members)."""
    stages = [*_STAGES, [{"type": "gaussian", "std": 0.01}, {"type": "scale", "std": 0.1}, {"type": "clip", "min": 0.0}]]
    fixed = {} if drawn else {"intervals": [1, 2, 3], "delays": [0, 1, 2, 3]}
    return _noisy_suite(seed, **fixed, stages=stages, aggregators=[None, "mean", "max", "sum", "min", "median"],
                        elements=[*_ELEMENTS, ("xpos", "body:base")])


def _run(seed: int, drawn: bool, pad: bool) -> tuple[list[dict[str, np.ndarray]], sensorcfg.Updater]:
    model = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
    physics = sensorcfg.Physics(model)
    updater = sensorcfg.Updater(_suite(seed, drawn), 3, pad_with_initial_value=pad)
    controls = np.random.default_rng(seed).uniform(-1, 1, (1500, model.nu))
    physics_step = functools.partial(mujoco.mj_step, model, physics.data)
    seen = []
    for episode, steps in enumerate((1500, 200)):  # past the fixed bank's early reads and over planning rounds
        mujoco.mj_resetData(model, physics.data)
        updater.reset(physics, np.random.RandomState(seed + episode))
        seen.append(updater.get_observation())
        for control in controls[:steps]:
            physics.data.ctrl[:] = control
            updater.control_step(physics_step)  # (the Environment's loop)
            seen.append(updater.get_observation())
    return seen, updater


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("drawn", [False, True], ids=["fixed", "planned"])
def test_updaters_read_the_same_bits_with_and_without_the_kernel(seed, drawn, monkeypatch) -> None:
    with_kernel, updater = _run(seed, drawn, pad=bool(seed % 2))
    banks = [updater._drawn] if drawn else [updater._bank]
    assert all(b is not None for b in banks)
    if drawn:
        assert (updater._drawn.kernel is not None) == KERNEL
    else:
        assert any(read.kernel is not None for read in updater._bank._gathers.values()) == KERNEL
    monkeypatch.setattr(bank, "kernel_read", lambda *args: None)
    monkeypatch.setattr(planned, "kernel_read", lambda *args: None)
    without, _ = _run(seed, drawn, pad=bool(seed % 2))
    assert len(with_kernel) == len(without)
    for read, (a, b) in enumerate(zip(with_kernel, without)):
        for name in a:
            assert _bits(a[name]) == _bits(b[name]), f"read {read} {name}"
            assert type(a[name]) is type(b[name]) and np.shape(a[name]) == np.shape(b[name])


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


@pytest.mark.skipif(not KERNEL, reason="the kernel is not built: numpy takes every snapshot")
def test_the_compiled_snapshot_is_the_numpy_snapshot(monkeypatch) -> None:
    """`_kernel.snapshot` copies the state into the history row of a step: for the drawn bank where and only
    where a sample is taken then (clearing the mark), for the fixed bank at every call; the same history and
    marks as numpy's take, over steps past the history's length (rows wrap), the state changing every step."""
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
