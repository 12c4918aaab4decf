"""`sensorcfg validate --engine warp`: what the Warp engine does not run, at the suite's lines, without Warp.

The checks come from `sensorcfg.warp.support` (the rules `WarpEnvironment` refuses by; tests/warp checks
that it refuses the same suite with the same problems). Every command here runs with Warp and MuJoCo Warp
made unimportable, as on a CI or pre-commit machine without them.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

import sensorcfg
from conftest import MODELS

# a suite the single-simulation Environment and the CPU batch both run, with one thing of each class the Warp
# engine does not (a lowpass whose cutoff is drawn per episode on a drawn interval, a camera on a model with
# visible sites, which MuJoCo Warp's renderer does not draw, a field MuJoCo Warp lacks), and what it runs besides
# (misalign, a parameter drawn per episode, a drawn interval)
WARP_SUITE = """model: arm.xml  # copied next to the suite
sensors:
  turned:
    kind: xpos
    element: site:tip
    noise: [{type: misalign, std: 1deg}, {type: gaussian, std: {uniform: [0.01, 0.02]}}]
  drawn: {kind: qvel, element: joint:elbow, interval: {uniform: [1, 3]},
          noise: [{type: lowpass, cutoff: {uniform: [10, 20]}}]}
  cam:
    kind: rgb
    element: camera:hand_cam
    camera: {width: 32, height: 24}
  tip_quat: {kind: xquat, element: site:tip}
"""

WARP_PROBLEMS = [
    "s.yaml:8:43: error: sensors.drawn.noise.0.cutoff: a lowpass whose cutoff is drawn per episode, on a drawn "
    "interval, is not run by the Warp engine (its coefficient per gap between samples is computed for a fixed "
    "cutoff); give a fixed cutoff or a constant interval, or run this suite on the CPU engines",
    "s.yaml:11:14: error: sensors.cam.element: the model has visible sites (imu, elbow_site, tip; give them "
    "group=\"3\" or higher, or rgba alpha 0), which the CPU camera draws and MuJoCo Warp's renderer does not; "
    "change the model so, or run this suite on the CPU engines",
    "s.yaml:13:20: error: sensors.tip_quat.kind: kind 'xquat' reads mjData's site_xquat, which MuJoCo Warp's Data "
    "does not hold as float32 values; read 'xmat' instead (the same orientation as a matrix), or run this suite "
    "on the CPU engines",
]
if not hasattr(mujoco.MjData, "site_xquat"):  # MuJoCo 3 has no site_xquat: that sensor is MuJoCo 4's case only
    WARP_SUITE = WARP_SUITE.replace("  tip_quat: {kind: xquat, element: site:tip}\n", "")
    WARP_PROBLEMS = WARP_PROBLEMS[:2]

# what the Warp engine runs: fixed and drawn schedules, its noise stages (misalign, parameters drawn per
# episode), aggregators, MuJoCo sensor kinds, clean twins, height scans
CLEAN_SUITE = """model: arm.xml
defaults: {twin: "{name}_clean"}
sensors:
  joints:
    kind: qpos
    element: [joint:shoulder, joint:elbow]
    delay: 4ms
    noise: [{type: gaussian, std: 0.01}, {type: quantize, step: 0.001}, {type: clip, min: -1, max: 1}]
  speed: {kind: qvel, element: joint:elbow, interval: 4ms, buffer: 3, aggregator: mean,
          noise: [{type: uniform, low: -0.1, high: 0.1}, {type: lowpass, cutoff: 20Hz}]}
  hand: {kind: xmat, element: site:tip, noise: [{type: dropout, p: 0.1}, {type: outlier, p: 0.01, scale: 1}]}
  gyro: {kind: gyro, element: site:imu, noise: [{type: misalign, std: 0.5deg}, {type: gaussian, std: 0.001}]}
  accel: {kind: accelerometer, element: site:imu, noise: [{type: gaussian, std: {uniform: [0.01, 0.02]}}]}
  ground: {kind: heightscan, element: body:base, interval: 4ms, delay: 2ms, noise: [{type: gaussian, std: 0.01}]}
  force: {kind: force, element: actuator:shoulder_motor,
          noise: [{type: bias, std: 0.1}, {type: scale, low: 0.9, high: 1.1}, {type: random_walk, std: 0.01}]}
  drawn: {kind: qvel, element: joint:shoulder, interval: {uniform: [1, 3]}, delay: {choice: [0, 2]}, buffer: 2,
          noise: [{type: gaussian, std: 0.01}, {type: lowpass, cutoff: 20Hz}]}
"""


def validate(suite: Path, *args: str) -> subprocess.CompletedProcess:
    """`sensorcfg validate` of `suite` (named from its folder) in a process where `import warp` and `import
    mujoco_warp` fail."""
    code = ("import sys, runpy; sys.modules['warp'] = sys.modules['mujoco_warp'] = None; "
            f"sys.argv = ['sensorcfg', 'validate', *{[suite.name, *args]!r}]; "
            "runpy.run_module('sensorcfg', run_name='__main__')")
    here = str(Path(sensorcfg.__file__).parents[1])  # the sensorcfg under test, whatever the working directory
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"),
           "PYTHONPATH": os.pathsep.join([here, *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                          cwd=suite.parent, env=env)
    assert "Traceback" not in done.stderr, done.stderr
    return done


def suite_file(tmp_path: Path, text: str) -> Path:
    shutil.copy(MODELS / "arm.xml", tmp_path)  # a suite's model lies in its folder tree
    suite = tmp_path / "s.yaml"
    suite.write_text(text)
    return suite


def test_validate_engine_warp_reports_what_the_warp_engine_does_not_run_at_its_line(tmp_path: Path) -> None:
    suite = suite_file(tmp_path, WARP_SUITE)
    for args in [(), ("--batch",), ("--engine", "batch")]:  # Environment and BatchEnvironment run all of it
        done = validate(suite, *args)
        assert (done.returncode, done.stdout) == (0, "1 suite valid\n"), args
    for args in [("--engine", "warp"), ("--engine", "warp", "--batch"), ("--batch", "--engine", "warp")]:
        done = validate(suite, *args)
        assert done.returncode == 1 and done.stdout.splitlines() == [
            *WARP_PROBLEMS, f"{len(WARP_PROBLEMS)} problems in 1 of 1 suite"]


def test_validate_engine_warp_checks_what_the_batch_refuses_too(tmp_path: Path) -> None:
    suite = suite_file(tmp_path, "model: arm.xml\nsensors:\n  mass: {kind: mass, element: body:hand, constant: true}\n")
    expected = ["s.yaml:3:52: error: sensors.mass.constant: a BatchEnvironment reads mjData fields across "
                "simulations, not model constants; remove it, or use the single-simulation Environment",
                "1 problem in 1 of 1 suite"]
    assert validate(suite, "--engine", "warp").stdout.splitlines() == expected


@pytest.mark.skipif(not hasattr(mujoco.MjData, "site_xquat"), reason="MuJoCo 3 has no site_xquat")
def test_validate_engine_warp_says_a_defaults_line_once_and_a_twins_at_its_sources_line(tmp_path: Path) -> None:
    suite = suite_file(tmp_path, """model: arm.xml
defaults:
  interval: {uniform: [1, 3]}
  noise: [{type: lowpass, cutoff: {uniform: [10, 20]}}]
sensors:
  a: {kind: qpos, element: joint:elbow}
  b: {kind: qvel, element: joint:elbow}
  c: {kind: xquat, element: site:tip, twin: c_clean, enabled: false, buffer: 2, interval: {choice: [1, 2]},
      noise: []}
""")
    assert validate(suite, "--engine", "warp").stdout.splitlines() == [
        "s.yaml:4:35: error: defaults.noise.0.cutoff: a lowpass whose cutoff is drawn per episode, on a drawn "
        "interval, is not run by the Warp engine (its coefficient per gap between samples is computed for a fixed "
        "cutoff); give a fixed cutoff or a constant interval, or run this suite on the CPU engines",
        "s.yaml:8:13: error: sensors.c.kind: its clean twin 'c_clean' runs (enabled; 'twin: false' drops it): "
        "kind 'xquat' reads mjData's site_xquat, which MuJoCo Warp's Data does not hold as float32 values; read "
        "'xmat' instead (the same orientation as a matrix), or run this suite on the CPU engines",
        "2 problems in 1 of 1 suite"]


def test_a_suite_the_warp_engine_runs_validates_clean(tmp_path: Path) -> None:
    done = validate(suite_file(tmp_path, CLEAN_SUITE), "--engine", "warp")
    assert (done.returncode, done.stdout) == (0, "1 suite valid\n"), done.stdout


def test_validate_engine_warp_refuses_a_height_scan_whose_rays_would_meet_an_sdf(tmp_path: Path) -> None:
    """MuJoCo Warp's ray caster reads an SDF geom as a miss: a scan that would see one is refused at its kind,
    one whose geomgroup leaves it out is not."""
    model = (MODELS / "arm.xml").read_text().replace(
        "<worldbody>", '<asset><mesh name="tet" vertex="0 0 0  1 0 0  0 1 0  0 0 1"/></asset>\n  <worldbody>'
    ).replace('<geom name="floor"',
              '<geom name="blob" type="sdf" mesh="tet" pos="1 1 0" group="4"/>\n    <geom name="floor"')
    (tmp_path / "arm.xml").write_text(model)
    suite = tmp_path / "s.yaml"
    suite.write_text("model: arm.xml\nsensors:\n  sees: {kind: heightscan, element: body:base}\n"
                     "  blind: {kind: heightscan, element: body:base, scan: {geomgroup: [0, 1, 2, 3]}}\n")
    assert validate(suite, "--engine", "batch").stdout == "1 suite valid\n"
    assert validate(suite, "--engine", "warp").stdout.splitlines() == [
        "s.yaml:3:16: error: sensors.sees.kind: its rays would meet geom 'blob' (type sdf), which MuJoCo Warp's ray "
        "caster does not cast (it would read as a miss); leave it out of this scan's geomgroup, or run this suite "
        "on the CPU engines",
        "1 problem in 1 of 1 suite"]


NOT_IMPORTED = "{}; 1 callable not imported (pass --import to check it)"  # the summary, without --import
BATCHED_SUITE = """model: arm.xml
sensors:
  reach:
    kind: generic
    callable: reach_sensors:reach
    batched: true
    noise: [{type: gaussian, std: 0.01}]
"""


def test_a_batched_generic_is_refused_at_its_line_by_the_cpu_engines_and_checked_for_warp(tmp_path: Path) -> None:
    """`batched: true` (a callable of every world's MuJoCo Warp Model and Data) runs on the Warp engine only:
    `validate` and `--engine batch` refuse it at its `batched` line, `--engine warp` accepts it, and with
    `--import` checks that its callable imports."""
    suite = suite_file(tmp_path, BATCHED_SUITE)
    refusal = ("s.yaml:6:14: error: sensors.reach.batched: a batched generic callable takes MuJoCo Warp's Model and "
               "Data of every world and runs on the Warp engine (WarpEnvironment) only; run this suite there, or "
               "drop 'batched' for a callable of one simulation's physics")
    for args in [(), ("--engine", "batch")]:
        done = validate(suite, *args)
        summary = NOT_IMPORTED.format("1 problem in 1 of 1 suite")
        assert done.returncode == 1 and done.stdout.splitlines() == [refusal, summary], args
    assert validate(suite, "--engine", "warp").stdout == NOT_IMPORTED.format("1 suite valid") + "\n"
    done = validate(suite, "--engine", "warp", "--import")
    assert done.returncode == 1 and "s.yaml:5:15: error: sensors.reach.callable: cannot import module " \
        "'reach_sensors'" in done.stdout, done.stdout
    (tmp_path / "reach_sensors.py").write_text("def reach(model, data):\n    return data.site_xpos\n")
    assert validate(suite, "--engine", "warp", "--import").stdout == "1 suite valid\n"
    suite.write_text(BATCHED_SUITE.replace("reach_sensors:reach", "reach_sensors:teach"))
    assert "sensors.reach.callable: module 'reach_sensors' has no 'teach' (did you mean 'reach'?)" in \
        validate(suite, "--engine", "warp", "--import").stdout


def test_a_per_simulation_generic_on_the_warp_engine_is_told_of_batched(tmp_path: Path) -> None:
    suite = suite_file(tmp_path, BATCHED_SUITE.replace("    batched: true\n", ""))
    assert validate(suite).stdout == NOT_IMPORTED.format("1 suite valid") + "\n"
    assert validate(suite, "--engine", "warp").stdout.splitlines() == [
        "s.yaml:4:11: error: sensors.reach.kind: a generic callable runs Python per sample and simulation, which a "
        "BatchEnvironment cannot vectorise; use the single-simulation Environment for it, or, on the Warp engine "
        "(WarpEnvironment), 'batched: true' with a callable that takes every world at once",
        NOT_IMPORTED.format("1 problem in 1 of 1 suite")]
