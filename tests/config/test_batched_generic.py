"""`batched: true` on a generic sensor: a callable of every world's MuJoCo Warp Model and Data, which only the
Warp engine runs (tests/warp/test_warp_generic.py). The key belongs to kind generic only, and the CPU engines
(Environment, BatchEnvironment) refuse such a sensor at its `batched` line, or, built in Python, at its use."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

import sensorcfg
from sensorcfg import SuiteError, assets
from sensorcfg.batch import BatchEnvironment
from sensorcfg.observables.generic import BatchedGeneric

ROBOT = str(assets.path("robot.xml"))
REFUSAL = ("sensors.z.batched: a batched generic callable takes MuJoCo Warp's Model and Data of every world and "
           "runs on the Warp engine (WarpEnvironment) only; run this suite there, or drop 'batched' for a callable "
           "of one simulation's physics")


def reach(model, data):  # never called here
    raise AssertionError("the CPU engines must not call a batched callable")


def suite_file(tmp_path: Path, sensor: str) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(f"sensors:\n  pos: {{kind: qpos, element: joint:elbow}}\n  z:\n{sensor}")
    return path


# BatchEnvironment runs on MuJoCo 4's mujoco.batch (on MuJoCo 3 it is an UnsupportedError before any suite)
ENGINES = ["single", pytest.param("batch", marks=pytest.mark.skipif(
    int(mujoco.__version__.split(".")[0]) < 4, reason=f"mujoco.batch needs MuJoCo 4; this is {mujoco.__version__}"))]


def test_batched_is_only_for_generic_sensors(tmp_path: Path) -> None:
    path = suite_file(tmp_path, "    kind: qpos\n    element: joint:elbow\n    batched: true\n")
    with pytest.raises(SuiteError) as raised:
        sensorcfg.load(str(path))
    assert str(raised.value) == (f"{path}:6:5: error: sensors.z.batched: 'batched' is only for kind 'generic'; "
                                 "this sensor's kind is 'qpos': remove it or change the kind")
    path.write_text(path.read_text().replace("kind: qpos\n    element: joint:elbow", f"kind: generic\n    callable: "
                                             f"'{__name__}:reach'").replace("true", "'yes'"))
    with pytest.raises(SuiteError, match=r"s.yaml:6:\d+: error: sensors.z.batched: "):
        sensorcfg.load(str(path))


@pytest.mark.parametrize("engine", ENGINES)
def test_the_cpu_engines_refuse_a_batched_generic_at_its_line(tmp_path: Path, engine: str) -> None:
    path = suite_file(tmp_path, f"    kind: generic\n    callable: '{__name__}:reach'\n    batched: true\n")
    with pytest.raises(SuiteError) as raised:
        if engine == "single":
            sensorcfg.Environment(ROBOT, str(path))
        else:
            BatchEnvironment(ROBOT, str(path), 2)
    assert str(raised.value) == f"{path}:6:14: error: {REFUSAL}"
    suite = sensorcfg.load(str(path))
    assert [p.format() for p in suite.check(ROBOT, batch=engine == "batch")] == [f"{path}:6:14: error: {REFUSAL}"]
    assert suite.check(ROBOT, warp=True) == []


@pytest.mark.parametrize("engine", ENGINES)
def test_the_cpu_engines_refuse_a_batched_generic_built_in_python(engine: str) -> None:
    observables = {"pos": sensorcfg.Feature("qpos", "joint:elbow"), "z": BatchedGeneric(reach)}
    for observable in observables.values():
        observable.enabled = True
    with pytest.raises(SuiteError, match=r"a batched generic callable takes MuJoCo Warp's Model and Data of every "
                                         r"world and runs on the Warp engine \(WarpEnvironment\) only"):
        env = sensorcfg.Environment(ROBOT, observables) if engine == "single" else \
            BatchEnvironment(ROBOT, observables, 2)
        env.reset()
