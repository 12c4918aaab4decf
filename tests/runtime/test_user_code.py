"""User code and what it may return: generic sensors' values, when callables are called, truthful bounds."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from dm_env import specs

import sensorcfg
from sensorcfg import SuiteError, assets

ROBOT = str(assets.path("robot.xml"))

SENSORS_PY = '''
import numpy as np
from pathlib import Path

CALLS = Path(__file__).with_name("calls.txt")


def _called(name):
    with CALLS.open("a") as f:
        f.write(name + "\\n")


def growing(physics):
    """One value, then three after 5 ms."""
    return np.zeros(1 if physics.data.time < 0.005 else 3)


def text(physics):
    return "hello"


_CALLS = [0]


def grows_after_two_calls(physics):
    """The shape changes between the environment's construction (two calls) and its first episode."""
    _CALLS[0] += 1
    return np.zeros(1 if _CALLS[0] <= 2 else 2)


def ragged(physics):
    return [[1.0], [1.0, 2.0]]


def int_then_float(physics):
    return np.array([1]) if physics.data.time < 0.005 else np.array([0.5])


def marked(physics):
    _called("generic")
    return np.array([physics.data.time, 1.0])


def noise(value, random_state):
    _called("noise")
    return value
'''


@pytest.fixture
def sensors_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "user_sensors_robust.py").write_text(SENSORS_PY)
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("user_sensors_robust", None)
    return tmp_path


def suite_text(callable_: str) -> str:
    return f"""\
model: package://sensorcfg/assets/robot.xml
sensors:
  joints:
    kind: qpos
    element: joint:shoulder
  probe:
    kind: generic
    callable: user_sensors_robust:{callable_}
    buffer: 2
"""


@pytest.mark.parametrize("fn,message", [
    pytest.param("growing", r"generic sensor 'probe': returned shape \(3,\), but its first value had shape \(1,\); "
                            r"a sensor's value keeps one shape", id="changes-shape"),
    pytest.param("grows_after_two_calls", r"generic sensor 'probe': returned shape \(2,\), but its first value had "
                                          r"shape \(1,\)", id="changes-shape-before-the-first-episode"),
    pytest.param("text", r"generic sensor 'probe': returned 'hello' \(<U5 values\); a sensor returns numbers",
                 id="string"),
    pytest.param("ragged", r"generic sensor 'probe': returned \[\[1.0\], \[1.0, 2.0\]\], which is not an array of "
                           r"numbers", id="ragged"),
    pytest.param("int_then_float", r"generic sensor 'probe': returned float64 values, but its first value was int64, "
                                   r"which cannot hold them", id="int-then-float"),
])
def test_a_generic_sensor_returning_a_bad_value_is_named_at_its_line(sensors_module: Path, fn: str,
                                                                      message: str) -> None:
    suite = sensorcfg.loads(suite_text(fn), file="suite.yaml")
    made = []
    with pytest.raises(SuiteError, match=message) as info:
        made.append(sensorcfg.Environment(ROBOT, suite, seed=0))  # its first values are read for the specs
        made[0].reset()
        for _ in range(5):
            made[0].step(np.zeros(3))
    (problem,) = info.value.problems
    assert (problem.file, problem.line, problem.col, problem.loc) == ("suite.yaml", 8, 15, "sensors.probe.callable")
    if made and fn != "grows_after_two_calls":  # a value that goes bad mid-episode ends the episode
        assert made[0].step(np.zeros(3)).first()  # (one that is bad from the start stays bad: each reset raises)


def test_a_generic_observable_from_python_names_its_callable() -> None:
    def changes(physics):
        return np.zeros(1 + int(physics.data.time > 0))

    obs = sensorcfg.Generic(changes)
    obs.enabled = True
    env = sensorcfg.Environment(ROBOT, {"g": obs}, seed=0)
    env.reset()
    with pytest.raises(SuiteError, match=r"Generic\('test_a_generic_observable_from_python_names_its_callable."
                                         r"<locals>.changes'\): returned shape \(2,\), but its first value had "
                                         r"shape \(1,\)"):
        env.step(np.zeros(3))


NOISY = f"""\
model: package://sensorcfg/assets/robot.xml
sensors:
  probe:
    kind: generic
    callable: user_sensors_robust:marked
    noise: [{{type: gaussian, std: 0.1}}]
  joints:
    kind: qpos
    element: joint:shoulder
    noise: [{{type: custom, callable: "user_sensors_robust:noise"}}]
"""


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "sensorcfg", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def test_validate_import_calls_a_generic_only_for_the_shape_its_noise_needs(sensors_module: Path) -> None:
    """`validate --import` finds what the shape of a generic sensor's value decides (issue 30: check passed,
    the environment refused), so it calls a generic whose noise needs the shape once, as building does; custom
    noise is never called, and without --import nothing is."""
    (sensors_module / "s.yaml").write_text(NOISY)
    calls = sensors_module / "calls.txt"
    proc = _cli("validate", "s.yaml", cwd=sensors_module)
    assert proc.returncode == 0 and not calls.exists(), proc.stdout + proc.stderr
    proc = _cli("validate", "--import", "s.yaml", cwd=sensors_module)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert calls.read_text().split() == ["generic"]
    calls.unlink()
    suite = sensorcfg.load(sensors_module / "s.yaml")  # and Suite.check with imports the same
    assert suite.check() == [] and not calls.exists()
    assert suite.check(import_callables=True) == []
    assert calls.read_text().split() == ["generic"]


def test_spec_never_calls_custom_noise(sensors_module: Path) -> None:
    (sensors_module / "s.yaml").write_text(NOISY)
    proc = _cli("spec", "s.yaml", cwd=sensors_module)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    calls = (sensors_module / "calls.txt").read_text().split()
    assert "noise" not in calls and calls.count("generic") >= 1  # the generic one: its shape needs a value
    assert "(1, 2)" in proc.stdout


def test_a_bad_generic_value_in_run_is_one_positioned_line(sensors_module: Path) -> None:
    (sensors_module / "s.yaml").write_text(suite_text("growing"))
    proc = _cli("run", "s.yaml", "--steps", "5", cwd=sensors_module)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith(
        "s.yaml:8:15: error: sensors.probe.callable: generic sensor 'probe': returned shape (3,)")


# -- bounds --------------------------------------------------------------------------------------------

CAMERAS = f"""\
model: package://sensorcfg/assets/robot.xml
defaults:
  camera: {{width: 32, height: 24}}
sensors:
  depth_noisy:
    kind: depth
    element: camera:wrist
    noise: [{{type: gaussian, std: 0.5}}]
  depth_clipped:
    kind: depth
    element: camera:wrist
    noise: [{{type: gaussian, std: 0.5}}, {{type: clip, min: 0}}]
  depth_held:
    kind: depth
    element: camera:wrist
    noise: [{{type: dropout, p: 0.5, mode: hold}}, {{type: lowpass, cutoff: 50Hz}}]
  rgb_noisy:
    kind: rgb
    element: camera:overview
    noise: [{{type: gaussian, std: 80}}]
  joints_clipped:
    kind: qpos
    element: ["joint:shoulder", "joint:elbow"]
    noise: [{{type: gaussian, std: 1}}, {{type: clip, min: [-0.1, -0.2], max: 0.1}}]
    buffer: 3
    aggregator: max
  joints_zeroed:
    kind: qpos
    element: joint:shoulder
    noise: [{{type: clip, min: 0.5, max: 1}}, {{type: dropout, p: 0.5, mode: zero}}]
"""


def test_noisy_specs_keep_only_bounds_the_noise_keeps() -> None:
    env = sensorcfg.Environment(ROBOT, sensorcfg.loads(CAMERAS), seed=0)
    spec = env.observation_spec()
    assert not isinstance(spec["depth_noisy"], specs.BoundedArray)  # gaussian can go below 0
    assert (spec["depth_clipped"].minimum, spec["depth_clipped"].maximum) == (0, np.inf)
    assert (spec["depth_held"].minimum, spec["depth_held"].maximum) == (0, np.inf)
    assert (spec["rgb_noisy"].minimum, spec["rgb_noisy"].maximum) == (0, 255)
    np.testing.assert_array_equal(spec["joints_clipped"].minimum, [-0.1, -0.2])
    assert spec["joints_clipped"].maximum == pytest.approx(0.1)
    assert (spec["joints_zeroed"].minimum, spec["joints_zeroed"].maximum) == (0, 1)


def test_gymnasium_contains_every_noisy_observation() -> None:
    from sensorcfg.gym import GymEnv

    env = GymEnv(sensorcfg.Environment(ROBOT, sensorcfg.loads(CAMERAS), physics_steps_per_control_step=5, seed=0))
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    seen_negative = False
    for _ in range(15):
        for name, space in env.observation_space.items():
            assert space.contains(obs[name]), (name, space, obs[name].min(), obs[name].max())
        seen_negative |= bool((obs["depth_noisy"] < 0).any())
        obs, *_ = env.step(rng.uniform(-1, 1, 3))
    assert seen_negative  # the case that used to break `contains`


def test_spec_table_shows_the_bounds(tmp_path: Path) -> None:
    (tmp_path / "s.yaml").write_text(CAMERAS)
    proc = _cli("spec", "s.yaml", "--format", "json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    bounds = {row["name"]: row["bounds"] for row in json.loads(proc.stdout)["sensors"]}
    assert bounds == {"depth_noisy": "- (noise)", "depth_clipped": "0..inf", "depth_held": "0..inf", "rgb_noisy": "0..255",
                      "joints_clipped": "[-0.2,-0.1]..0.1", "joints_zeroed": "0..1"}
