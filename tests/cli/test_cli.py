"""The `sensorcfg` command line, run for real in a subprocess: exit codes, formats, files, never a traceback."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sensorcfg
import sensorcfg.assets

from conftest import ROOT

ROBOT = "package://sensorcfg/assets/robot.xml"
LINE = re.compile(r"^(?P<file>[^:\n]+):(?P<line>\d+):(?P<col>\d+): error: (?P<message>.+)$")

VALID = f"""\
model: {ROBOT}
options: {{control_interval: 10ms}}
sensors:
  joints:
    kind: qpos
    element: ["joint:shoulder", "joint:elbow"]
    interval: 4ms
    delay: 2ms
    buffer: 2
  gyro:
    kind: sensordata
    element: sensor:imu_gyro
    delay: {{uniform: [0, 3]}}
    noise: [{{type: gaussian, std: 0.01}}]
"""

# A wrong kind (did you mean), a unit that does not fit the 2 ms timestep, an unknown key.
INVALID = f"""\
model: {ROBOT}
sensors:
  joints:
    kind: qpoz
    element: joint:shoulder
  gyro:
    kind: sensordata
    element: sensor:imu_gyro
    interval: 3ms
    colour: red
"""

CAMERA = f"""\
model: {ROBOT}
options: {{control_interval: 20ms}}
sensors:
  joints: {{kind: qpos, element: "joint:*", within: "body:upper_arm"}}
  cam:
    kind: rgb
    element: camera:overview
    camera: {{width: 48, height: 32}}
    interval: 40ms
"""


def cli(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    full_env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), **(env or {})}
    proc = subprocess.run([sys.executable, "-m", "sensorcfg", *args], cwd=cwd, env=full_env, capture_output=True,
                          text=True, timeout=300)
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@pytest.fixture
def no_matplotlib(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """An environment in which `import matplotlib` fails, as on an install without the plot extra."""
    fake = write(tmp_path_factory.mktemp("fake") / "matplotlib" / "__init__.py",
                 "raise ImportError('No module named matplotlib')\n")
    return {"PYTHONPATH": os.pathsep.join([str(fake.parent.parent), os.environ.get("PYTHONPATH", "")])}


# -- the program ------------------------------------------------------------------------------------------

def test_version() -> None:
    proc = cli("--version")
    assert proc.returncode == 0
    # which path computes the noise numbers (the same numbers either way): the compiled kernel or numpy
    from sensorcfg import compiled
    from sensorcfg.noise import streams

    philox = f", Philox {compiled.PHILOX}" if compiled.PHILOX else ""  # intrinsics or the portable loop
    assert proc.stdout.strip() == f"sensorcfg {sensorcfg.__version__} (noise numbers: {streams.KERNEL}{philox})"


def test_console_script_is_installed() -> None:
    script = Path(sys.executable).with_name("sensorcfg")
    if not script.exists():
        pytest.skip("the sensorcfg console script is not installed next to this Python")
    proc = subprocess.run([str(script), "--version"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and sensorcfg.__version__ in proc.stdout


@pytest.mark.parametrize("command", [[], ["validate"], ["schema"], ["spec"], ["run"], ["demo"]],
                         ids=["top", "validate", "schema", "spec", "run", "demo"])
def test_help(command: list[str]) -> None:
    proc = cli(*command, "--help")
    assert proc.returncode == 0
    assert "examples:" in proc.stdout
    assert "exit status:" in proc.stdout and "2  usage or I/O error" in proc.stdout


@pytest.mark.parametrize("args", [pytest.param([], id="no-command"), pytest.param(["frobnicate"], id="unknown-command"),
                                  pytest.param(["validate", "--colour", "x.yaml"], id="unknown-option"),
                                  pytest.param(["validate"], id="missing-path"),
                                  pytest.param(["run", "s.yaml", "--steps", "0"], id="bad-steps"),
                                  pytest.param(["run", "s.yaml", "--substeps", "2", "--control-timestep", "0.01"],
                                               id="exclusive-options")])
def test_usage_errors_exit_2(args: list[str]) -> None:
    proc = cli(*args)
    assert proc.returncode == 2
    assert proc.stderr.strip()


# -- validate ---------------------------------------------------------------------------------------------

def test_validate_valid_file(tmp_path: Path) -> None:
    suite = write(tmp_path / "ok.yaml", VALID)
    proc = cli("validate", str(suite))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip() == "1 suite valid"


def test_validate_invalid_file_lists_every_problem_as_path_line_col(tmp_path: Path) -> None:
    write(tmp_path / "bad.yaml", INVALID)
    proc = cli("validate", "bad.yaml", cwd=tmp_path)
    assert proc.returncode == 1
    lines = proc.stdout.strip().splitlines()
    problems = [LINE.match(line) for line in lines[:-1]]
    assert all(problems), lines
    assert {(m["file"], m["line"]) for m in problems} >= {("bad.yaml", "10")}  # the unknown key, at its line
    assert lines[-1].startswith(f"{len(problems)} problem")
    # A schema problem in one sensor does not hide the model problems of the others (joints' kind).
    assert "bad.yaml:4:11: error: sensors.joints.kind:" in proc.stdout and "did you mean 'qpos'" in proc.stdout
    # Fix the schema problem and the rest of that sensor is checked against the model too.
    fixed = INVALID.replace("    colour: red\n", "")
    write(tmp_path / "bad.yaml", fixed)
    proc = cli("validate", "bad.yaml", cwd=tmp_path)
    assert proc.returncode == 1
    text = proc.stdout
    assert "bad.yaml:4:11: error: sensors.joints.kind:" in text and "did you mean 'qpos'" in text
    assert re.search(r"bad\.yaml:9:15: error: sensors\.gyro\.interval: .*3ms", text)


def test_validate_directory_of_mixed_suites(tmp_path: Path) -> None:
    write(tmp_path / "suites" / "a_ok.yaml", VALID)
    write(tmp_path / "suites" / "nested" / "b_bad.yml", INVALID)
    write(tmp_path / "suites" / "nested" / "c_ok.yaml", CAMERA)
    write(tmp_path / "suites" / "notes.txt", "not a suite")
    write(tmp_path / "suites" / ".hidden" / "skip.yaml", "garbage: [")
    proc = cli("validate", "suites", "--format", "json", cwd=tmp_path)
    assert proc.returncode == 1
    out = json.loads(proc.stdout)
    assert out["valid"] is False
    files = {Path(f["path"]).name: f for f in out["files"]}
    assert set(files) == {"a_ok.yaml", "b_bad.yml", "c_ok.yaml"}
    assert files["a_ok.yaml"]["valid"] and files["c_ok.yaml"]["valid"] and not files["b_bad.yml"]["valid"]
    assert out["summary"] == {"files": 3, "invalid_files": 1, "problems": files["b_bad.yml"]["problems"],
                              "checked_with_model": 3, "without_model": 0, "callables_not_imported": 0}
    assert {Path(p["file"]).name for p in out["problems"]} == {"b_bad.yml"}
    assert all(p["severity"] == "error" and p["line"] >= 1 and p["col"] >= 1 for p in out["problems"])
    # Text format: one line per problem, all in the invalid file, and the summary.
    text = cli("validate", "suites", cwd=tmp_path)
    assert text.returncode == 1
    lines = text.stdout.strip().splitlines()
    notes = [line for line in lines if ": note: " in line]  # the camera suite's rendering cost: advice, not a problem
    assert notes and all(line.split(":")[0].endswith("c_ok.yaml") for line in notes)
    lines = [line for line in lines if line not in notes]
    assert len(lines) == len(out["problems"]) + 1
    assert all(LINE.match(line)["file"].endswith("b_bad.yml") for line in lines[:-1])
    assert re.fullmatch(rf"{len(out['problems'])} problems? in 1 of 3 suites", lines[-1])


def test_validate_json_when_valid(tmp_path: Path) -> None:
    write(tmp_path / "ok.yaml", VALID)
    proc = cli("validate", "ok.yaml", "--format", "json", cwd=tmp_path)
    assert proc.returncode == 0
    out = json.loads(proc.stdout)
    assert out["valid"] is True and out["problems"] == []
    assert out["files"] == [{"path": "ok.yaml", "valid": True, "model": out["files"][0]["model"], "problems": 0}]


def test_validate_without_a_model_checks_syntax_and_schema_only(tmp_path: Path) -> None:
    no_model = VALID.replace(f"model: {ROBOT}\n", "").replace("joint:shoulder", "joint:no_such_joint")
    write(tmp_path / "s.yaml", no_model)
    proc = cli("validate", "s.yaml", cwd=tmp_path)
    assert proc.returncode == 0
    assert "1 without a model: syntax and schema only" in proc.stdout
    robot = str(sensorcfg.assets.path("robot.xml"))
    proc = cli("validate", "s.yaml", "--model", robot, cwd=tmp_path)
    assert proc.returncode == 1
    assert "s.yaml:" in proc.stdout and "no_such_joint" in proc.stdout


def test_validate_set_overrides(tmp_path: Path) -> None:
    write(tmp_path / "ok.yaml", VALID)
    broken = cli("validate", "ok.yaml", "--set", "sensors.joints.interval=3ms", cwd=tmp_path)
    assert broken.returncode == 1
    assert "sensors.joints.interval" in broken.stdout and "3ms" in broken.stdout
    write(tmp_path / "bad.yaml", INVALID)
    fixed = cli("validate", "bad.yaml", "--set", "sensors.joints.kind=qpos", "--set", "sensors.gyro.interval=4ms",
                "--set", "sensors.gyro.colour=null", cwd=tmp_path)
    assert fixed.returncode == 0, fixed.stdout
    unknown = cli("validate", "ok.yaml", "--set", "sensors.jionts.buffer=2", cwd=tmp_path)
    assert unknown.returncode == 1 and "did you mean 'joints'" in unknown.stdout
    malformed = cli("validate", "ok.yaml", "--set", "defaults.buffer", cwd=tmp_path)
    assert malformed.returncode == 2 and "KEY=VALUE" in malformed.stderr


def test_validate_import_callables_only_when_asked(tmp_path: Path) -> None:
    suite = VALID + "  far:\n    kind: generic\n    callable: no_such_module_xyz.sensors:distance\n"
    write(tmp_path / "g.yaml", suite)
    assert cli("validate", "g.yaml", cwd=tmp_path).returncode == 0
    proc = cli("validate", "g.yaml", "--import", cwd=tmp_path)
    assert proc.returncode == 1
    assert "g.yaml:17:15: error: sensors.far.callable: cannot import module 'no_such_module_xyz.sensors'" in proc.stdout
    # --import finds the project's own modules (the working directory), as `python -m` does.
    write(tmp_path / "no_such_module_xyz" / "__init__.py", "")
    write(tmp_path / "no_such_module_xyz" / "sensors.py", "def distance(physics):\n    return 1.0\n")
    assert cli("validate", "g.yaml", "--import", cwd=tmp_path).returncode == 0


def test_validate_says_how_many_callables_it_did_not_import(tmp_path: Path) -> None:
    """Issue 30: without --import, "1 suite valid" said nothing of the callables it had not checked."""
    suite = (VALID + "  far:\n    kind: generic\n    callable: no_such_module_xyz.sensors:distance\n"
             "  near: {kind: generic, callable: 'no_such_module_xyz.sensors:distance', enabled: false}\n"
             "  noisy: {kind: qpos, element: 'joint:elbow', noise: [{type: custom, callable: 'no_such:corrupt'}]}\n")
    write(tmp_path / "g.yaml", suite)
    proc = cli("validate", "g.yaml", cwd=tmp_path)
    assert proc.returncode == 0
    assert proc.stdout.splitlines()[-1] == "1 suite valid; 2 callables not imported (pass --import to check them)"
    out = json.loads(cli("validate", "g.yaml", "--format", "json", cwd=tmp_path).stdout)
    assert out["summary"]["callables_not_imported"] == 2
    assert "not imported" not in cli("validate", "g.yaml", "--import", cwd=tmp_path).stdout
    write(tmp_path / "ok.yaml", VALID)
    assert cli("validate", "ok.yaml", cwd=tmp_path).stdout == "1 suite valid\n"  # (no callables: nothing to say)


@pytest.mark.parametrize("spelling, reason", [
    pytest.param("'m:'", "the function's name after ':' is missing", id="no-function"),
    pytest.param("':f'", "the module's name before ':' is missing", id="no-module"),
    pytest.param("'1m:f'", "'1m' is not a Python name (a name starts with an ASCII letter or '_' and holds ASCII "
                 "letters, digits and '_')", id="digit-first"),
    pytest.param("'a-b:f'", "'a-b' is not a Python name (a name starts with an ASCII letter or '_' and holds ASCII "
                 "letters, digits and '_'); rename it, for example to 'a_b'", id="dash"),
    pytest.param("'m.:f'", "the module 'm.' has an empty part between dots", id="empty-part"),
    pytest.param("'m:f:g'", "it has more than one ':' (one separates the module from the function)", id="two-colons"),
])
def test_validate_with_a_model_reports_a_malformed_callable_at_its_line(tmp_path: Path, spelling: str,
                                                                       reason: str) -> None:
    """Issue 30: with a model, these printed "sensorcfg failed on this file (AssertionError: '')"."""
    write(tmp_path / "g.yaml", f"sensors:\n  g:\n    kind: generic\n    callable: {spelling}\n"
                               "  n: {kind: qpos, element: 'joint:elbow', noise: [{type: custom, callable: "
                               f"{spelling}}}]}}\n")
    proc = cli("validate", "g.yaml", "--model", str(sensorcfg.assets.path("robot.xml")), cwd=tmp_path)
    got = spelling.strip("'")
    assert proc.returncode == 1 and proc.stdout.splitlines() == [
        f"g.yaml:4:15: error: sensors.g.callable: a callable is written 'module:function' (for example "
        f"'my_pkg.sensors:distance'); got '{got}': {reason}",
        f"g.yaml:5:76: error: sensors.n.noise.0.callable: a callable is written 'module:function' (for example "
        f"'mypkg.noise:corrupt'); got '{got}': {reason}",
        "2 problems in 1 of 1 suite"]


def test_validate_reports_a_callable_that_is_not_text(tmp_path: Path) -> None:
    write(tmp_path / "g.yaml", "sensors:\n  g: {kind: generic, callable: 5}\n")
    proc = cli("validate", "g.yaml", "--model", str(sensorcfg.assets.path("robot.xml")), cwd=tmp_path)
    assert proc.stdout.splitlines() == ["g.yaml:2:32: error: sensors.g.callable: expected a string; got 5",
                                        "1 problem in 1 of 1 suite"]


@pytest.mark.parametrize("args, message", [
    pytest.param(["missing.yaml"], "missing.yaml: no such file or directory", id="missing-file"),
    pytest.param(["ok.yaml", "--model", "missing.xml"], "missing.xml: no such model file", id="missing-model"),
    pytest.param(["empty_dir"], "no *.yaml or *.yml files", id="empty-directory"),
])
def test_validate_io_errors_exit_2(tmp_path: Path, args: list[str], message: str) -> None:
    write(tmp_path / "ok.yaml", VALID)
    (tmp_path / "empty_dir").mkdir()
    proc = cli("validate", *args, cwd=tmp_path)
    assert proc.returncode == 2
    assert message in proc.stderr and proc.stdout == ""


def test_validate_unloadable_model_is_a_problem_at_the_model_line(tmp_path: Path) -> None:
    write(tmp_path / "robot.xml", "<mujoco><worldbody><body><geom type='nonsense'/></body></worldbody></mujoco>")
    write(tmp_path / "s.yaml", VALID.replace(ROBOT, "robot.xml"))
    proc = cli("validate", "s.yaml", cwd=tmp_path)
    assert proc.returncode == 1
    assert proc.stdout.startswith("s.yaml:1:8: error: model: cannot load the model")
    proc = cli("validate", "s.yaml", "--model", "robot.xml", cwd=tmp_path)
    assert proc.returncode == 1 and "robot.xml: error: MuJoCo cannot load this model" in proc.stderr


# -- schema -----------------------------------------------------------------------------------------------

def test_schema_prints_and_writes_the_committed_schema(tmp_path: Path) -> None:
    proc = cli("schema")
    assert proc.returncode == 0
    schema = json.loads(proc.stdout)
    assert schema["$schema"].startswith("https://json-schema.org/") and "sensors" in schema["properties"]
    committed = ROOT / "schemas" / "sensor-suite.schema.json"
    if committed.exists():
        assert json.loads(committed.read_text()) == schema
    proc = cli("schema", "-o", str(tmp_path / "s.json"))
    assert proc.returncode == 0 and json.loads((tmp_path / "s.json").read_text()) == schema
    proc = cli("schema", "-o", str(tmp_path / "no" / "such" / "dir" / "s.json"))
    assert proc.returncode == 2 and "cannot write the schema" in proc.stderr


# -- spec -------------------------------------------------------------------------------------------------

def test_spec_table_and_json(tmp_path: Path) -> None:
    write(tmp_path / "s.yaml", VALID)
    proc = cli("spec", "s.yaml", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = {line.split()[0]: line.split() for line in proc.stdout.splitlines() if line.startswith(("joints", "gyro"))}
    assert rows["joints"][:10] == ["joints", "qpos", "2", "(2,", "2)", "float64", "-", "2", "250", "1"]
    assert "control step 5 physics steps (10 ms, 100 Hz)" in proc.stdout
    out = json.loads(cli("spec", "s.yaml", "--format", "json", cwd=tmp_path).stdout)
    sensors = {s["name"]: s for s in out["sensors"]}
    assert sensors["joints"]["shape"] == [2, 2] and sensors["joints"]["interval_steps"] == 2
    assert sensors["joints"]["delay_ms"] == "2" and sensors["joints"]["elements"] == 2
    assert sensors["gyro"]["delay"] == "0..3" and sensors["gyro"]["delay_ms"] == "0..6"
    assert sensors["gyro"]["noise"] == "gaussian(std=0.01)" and sensors["gyro"]["shape"] == [1, 3]
    assert sensors["joints"]["bounds"] == "-"
    assert out["physics_steps_per_control_step"] == 5


def test_spec_says_under_its_table_that_a_drawn_delay_is_not_a_reads_age(tmp_path: Path) -> None:
    """The ms of a drawn delay are what samples draw; a read shows the sample that arrived last, which can be
    older than the largest delay: said under the table when some delay is drawn, and only then."""
    from sensorcfg.cli.spec import DRAWN_DELAYS

    write(tmp_path / "s.yaml", VALID)  # gyro: delay {uniform: [0, 3]}
    drawn = cli("spec", "s.yaml", cwd=tmp_path).stdout.splitlines()
    assert drawn[drawn.index("2 enabled observations") + 1] == DRAWN_DELAYS
    assert DRAWN_DELAYS.startswith("drawn delays: a read shows the sample that arrived last (dm_control's rule), "
                                   "which can be older than the largest delay")
    fixed = cli("spec", "s.yaml", "--set", "sensors.gyro.delay=2", cwd=tmp_path).stdout
    assert fixed.splitlines()[-1] == "2 enabled observations" and "drawn delays" not in fixed


def test_spec_lists_disabled_sensors_apart_and_applies_set(tmp_path: Path) -> None:
    write(tmp_path / "s.yaml", VALID)
    proc = cli("spec", "s.yaml", "--set", "sensors.gyro.enabled=false", "--set", "defaults.buffer=3",
               "--format", "json", cwd=tmp_path)
    out = json.loads(proc.stdout)
    assert [s["name"] for s in out["sensors"]] == ["joints"] and out["disabled"] == ["gyro"]
    assert out["sensors"][0]["shape"] == [2, 2]  # the sensor's own buffer wins over defaults


@pytest.mark.parametrize("setup, args, code, message", [
    pytest.param(INVALID, ["s.yaml"], 1, "s.yaml:10:5: error: sensors.gyro.colour: unknown key", id="invalid-suite"),
    pytest.param(VALID, ["nope.yaml"], 2, "nope.yaml: no such suite file", id="missing-suite"),
    pytest.param(VALID, ["."], 2, "is a directory", id="directory"),
    pytest.param(VALID.replace(f"model: {ROBOT}\n", ""), ["s.yaml"], 2, "the suite names no model", id="no-model"),
    pytest.param(VALID.replace(ROBOT, "gone.xml"), ["s.yaml"], 1, "s.yaml:1:8: error: model: the model file",
                 id="model-missing"),
    pytest.param("sensors: [", ["s.yaml"], 1, "s.yaml:1:", id="yaml-syntax"),
])
def test_spec_user_mistakes(tmp_path: Path, setup: str, args: list[str], code: int, message: str) -> None:
    write(tmp_path / "s.yaml", setup)
    proc = cli("spec", *args, cwd=tmp_path)
    assert proc.returncode == code
    assert message in proc.stderr


# -- run --------------------------------------------------------------------------------------------------

def test_run_writes_a_loadable_npz_matching_the_spec(tmp_path: Path) -> None:
    write(tmp_path / "s.yaml", CAMERA)
    proc = cli("run", "s.yaml", "--steps", "12", "--out", "obs.npz", "--seed", "3", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # no progress bar when stderr is not a terminal
    assert "ran 12 control steps (120 physics steps" in proc.stdout
    side = json.loads((tmp_path / "obs.json").read_text())
    spec = {s["name"]: s for s in side["observations"]}
    with np.load(tmp_path / "obs.npz") as data:
        assert set(data.files) == {"joints", "cam", "sensorcfg.time", "sensorcfg.action"}
        for name, s in spec.items():
            assert data[name].shape == (13, *s["shape"]) and str(data[name].dtype) == s["dtype"]
        assert data["cam"].shape == (13, 1, 32, 48, 3)
        np.testing.assert_allclose(data["sensorcfg.time"], np.arange(13) * 0.02, atol=1e-12)
        assert data["sensorcfg.action"].shape == (12, 3) and not data["sensorcfg.action"].any()
        assert data["cam"][-1].std() > 0  # a rendered image, not zeros
    assert side["settings"]["physics_steps_per_control_step"] == 10 and side["settings"]["seed"] == 3
    assert side["samples_taken"] == {"joints": 13, "cam": 7}  # every 20 steps over 120, and the reset sample
    assert re.search(r"^cam\s+rgb\s+7\s+7\s+0$", proc.stdout, re.M)
    assert "camera renders: 7 taken, 0 skipped by the schedule" in proc.stdout


def test_run_summary_counts_renders_the_schedule_skips(tmp_path: Path) -> None:
    # 2 ms renders, read every 20 ms with a buffer of one: only the render before each read is ever seen.
    write(tmp_path / "s.yaml", CAMERA.replace("interval: 40ms", "interval: 2ms"))
    proc = cli("run", "s.yaml", "--steps", "5", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"^cam\s+rgb\s+6\s+51\s+45$", proc.stdout, re.M)
    assert "camera renders: 6 taken, 45 skipped by the schedule (88%)" in proc.stdout


def test_run_substeps_control_timestep_and_random_actions(tmp_path: Path) -> None:
    write(tmp_path / "s.yaml", VALID)

    def run(*extra: str, out: str) -> dict[str, np.ndarray]:
        proc = cli("run", "s.yaml", "--steps", "8", "--out", out, *extra, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        with np.load(tmp_path / out) as data:
            return {k: data[k] for k in data.files}

    a = run("--substeps", "4", "--random-actions", "--seed", "1", out="a.npz")
    b = run("--control-timestep", "0.008", "--random-actions", "--seed", "1", out="b.npz")
    c = run("--substeps", "4", "--random-actions", "--seed", "2", out="c.npz")
    np.testing.assert_allclose(a["sensorcfg.time"], np.arange(9) * 0.008, atol=1e-12)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    action = a["sensorcfg.action"]
    assert np.all(np.abs(action[:, :2]) <= 1) and np.all((action[:, 2] >= 0) & (action[:, 2] <= 0.04))
    assert action.std() > 0 and not np.array_equal(action, c["sensorcfg.action"])
    bad = cli("run", "s.yaml", "--control-timestep", "0.003", cwd=tmp_path)
    assert bad.returncode == 2 and "not a whole number" in bad.stderr


def test_run_plot_writes_a_picture(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from matplotlib.image import imread

    write(tmp_path / "s.yaml", VALID + CAMERA.split("sensors:\n")[1].replace("joints:", "arm:"))
    proc = cli("run", "s.yaml", "--steps", "15", "--plot", "obs.png", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "wrote obs.png" in proc.stdout and not (tmp_path / "obs.npz").exists()
    image = imread(tmp_path / "obs.png")
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 800
    assert image[..., :3].std() > 0.05  # not blank: axes, ticks, traces and camera frames


def test_run_plot_without_matplotlib_says_how_to_install_it(tmp_path: Path, no_matplotlib: dict[str, str]) -> None:
    write(tmp_path / "s.yaml", VALID)
    proc = cli("run", "s.yaml", "--steps", "3", "--plot", "p.png", cwd=tmp_path, env=no_matplotlib)
    assert proc.returncode == 2
    assert proc.stderr == ("sensorcfg: error: plotting needs matplotlib, which is not installed: pip install matplotlib "
                           "(or, from a sensorcfg clone, pip install '.[plot]')\n")
    assert proc.stdout == "" and not (tmp_path / "p.png").exists()  # refused before simulating


@pytest.mark.parametrize("args, code, message", [
    pytest.param(["--out", "no/such/dir/o.npz"], 2, "does not exist", id="out-folder-missing"),
    pytest.param(["--out", "."], 2, "is a directory", id="out-is-directory"),
    pytest.param(["--model", "broken.xml"], 1, "broken.xml: error: MuJoCo cannot load this model", id="unreadable-model"),
    pytest.param(["--set", "sensors.joints.element=joint:knee"], 1, "override", id="bad-override-value"),
    pytest.param(["--steps", "100000000", "--out", "o.npz"], 2, "GiB; use fewer --steps", id="too-big-to-record"),
    pytest.param(["--out", "o.txt"], 2, "o.txt: writes .npz files only; name it 'o.npz'", id="out-not-npz"),
    pytest.param(["--plot", "p.txt"], 2, "p.txt: the file type must be one of .png, ", id="plot-type-unknown"),
])
def test_run_user_mistakes(tmp_path: Path, args: list[str], code: int, message: str) -> None:
    write(tmp_path / "s.yaml", VALID)
    write(tmp_path / "broken.xml", "<mujoco><worldbody><geom/>")
    proc = cli("run", "s.yaml", "--steps", "2", *args, cwd=tmp_path)
    assert proc.returncode == code, proc.stderr
    assert message in proc.stderr
    if "name it" in message:  # refused before simulating: nothing written, under any name
        assert proc.stdout == "" and sorted(p.name for p in tmp_path.iterdir()) == ["broken.xml", "s.yaml"]


def test_run_error_in_the_users_sensor_code_points_at_it(tmp_path: Path) -> None:
    write(tmp_path / "mysensors.py", "def far(physics):\n    if physics.data.time > 0.01:\n"
          "        raise ValueError('target site missing')\n    return 1.0\n")
    write(tmp_path / "s.yaml", VALID + "  far: {kind: generic, callable: 'mysensors:far'}\n")
    proc = cli("run", "s.yaml", "--steps", "10", cwd=tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.strip().endswith("mysensors.py:3: error: in far: ValueError: target site missing")


def test_run_that_diverges_keeps_its_record_and_exits_1(tmp_path: Path) -> None:
    write(tmp_path / "boom.xml", '<mujoco><option timestep="0.01" integrator="Euler"/><worldbody><body>'
          '<joint name="j" type="slide" stiffness="1e9" springref="1"/><geom size=".1" mass="1"/></body>'
          '</worldbody></mujoco>')
    write(tmp_path / "s.yaml", "model: boom.xml\nsensors:\n  x: {kind: qpos, element: 'joint:j'}\n")
    proc = cli("run", "s.yaml", "--steps", "50", "--out", "o.npz", cwd=tmp_path)
    assert proc.returncode == 1
    assert "sensorcfg: error: the simulation diverged after 2 control steps" in proc.stderr
    with np.load(tmp_path / "o.npz") as data:
        assert data["x"].shape == (3, 1, 1) and data["sensorcfg.action"].shape == (2, 0)
    assert json.loads((tmp_path / "o.json").read_text())["settings"]["steps_done"] == 2


# -- demo -------------------------------------------------------------------------------------------------

def test_demo_in_an_empty_folder(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from matplotlib.image import imread

    proc = cli("demo", "--steps", "40", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sensorcfg-demo.json", "sensorcfg-demo.npz",
                                                           "sensorcfg-demo.png"]
    assert proc.stdout.startswith("sensorcfg demo: the bundled sensor suite on the bundled robot, 40 control steps")
    header = next(line for line in proc.stdout.splitlines() if line.startswith("name "))
    assert header.split() == ["name", "kind", "elems", "shape", "dtype", "bounds", "interval", "Hz", "delay", "ms", "buffer",
                              "aggregator", "noise"]
    assert "ran 40 control steps" in proc.stdout and "camera renders:" in proc.stdout
    side = json.loads((tmp_path / "sensorcfg-demo.json").read_text())
    with np.load(tmp_path / "sensorcfg-demo.npz") as data:
        for s in side["observations"]:
            assert data[s["name"]].shape == (41, *s["shape"])
        assert data["sensorcfg.action"].std() > 0  # the demo drives the robot
    assert imread(tmp_path / "sensorcfg-demo.png")[..., :3].std() > 0.05


def test_demo_with_no_arguments(tmp_path: Path) -> None:
    proc = cli("demo", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "ran 300 control steps" in proc.stdout
    assert (tmp_path / "sensorcfg-demo.npz").exists()


def test_demo_without_matplotlib_skips_only_the_plot(tmp_path: Path, no_matplotlib: dict[str, str]) -> None:
    proc = cli("demo", "--steps", "5", cwd=tmp_path, env=no_matplotlib)
    assert proc.returncode == 0, proc.stderr
    assert ("note: matplotlib is not installed, so there will be no plot; pip install matplotlib (or, from a "
            "sensorcfg clone, pip install '.[plot]') to get one") in proc.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sensorcfg-demo.json", "sensorcfg-demo.npz"]


def _ignored(name: str) -> bool:
    """Whether the repository's .gitignore ignores a file `name` at its top (last matching pattern wins)."""
    import fnmatch

    ignored = False
    for pattern in (ROOT / ".gitignore").read_text().splitlines():
        negated = pattern.startswith("!")
        if pattern and not pattern.startswith("#") and fnmatch.fnmatch(name, pattern.removeprefix("!").strip("/")):
            ignored = not negated
    return ignored


def test_demo_says_its_notes_and_suite_once_and_git_ignores_what_it_writes(tmp_path: Path) -> None:
    """Run from the folder above the bundled suite, the demo names it as the spec does (relative), prints the
    suite's note once, and writes only files a clone's git ignores."""
    assets = Path(sensorcfg.assets.path("demo.yaml")).parent
    proc = cli("demo", "--steps", "2", "--prefix", str(tmp_path / "sensorcfg-demo"), cwd=assets.parent)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[2] == f"assets/demo.yaml on {assets / 'robot.xml'}"
    assert lines[-1] == f"next: open {tmp_path / 'sensorcfg-demo.png'}; the suite it ran is assets/demo.yaml"
    notes = [line for line in lines if ": note: " in line]
    assert len(notes) == 1 and notes[0].startswith("assets/demo.yaml:39:3: note: sensors.wrist_cam: this camera")
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == ["sensorcfg-demo.json", "sensorcfg-demo.npz", "sensorcfg-demo.png"]
    assert [name for name in written if not _ignored(name)] == []


def test_pre_commit_hook_runs_validate() -> None:
    yaml = pytest.importorskip("yaml")
    hooks = yaml.safe_load((ROOT / ".pre-commit-hooks.yaml").read_text())
    hook = {h["id"]: h for h in hooks}["sensorcfg-validate"]
    assert hook["entry"].split()[:2] == ["sensorcfg", "validate"] and hook["language"] == "python"
    assert re.search(hook["files"], "configs/arm.yaml") and re.search(hook["files"], "a/b.yml")
    assert not re.search(hook["files"], "README.md")


@pytest.mark.parametrize("name, message", [
    ("sub/o.txt", "sub/o.txt: writes .npz files only; name it 'sub/o.npz'"),
    (".npz", ".npz: writes .npz files only; name it 'npz.npz'"),
    ("foo.", "foo.: writes .npz files only; name it 'foo.npz'"),
    ("sub/", "sub/: is a directory; give a file name"),
    ("o.npz/", "o.npz/: is a directory; give a file name"),
])
def test_an_output_name_is_refused_with_the_name_to_use(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                        name: str, message: str) -> None:
    from sensorcfg.cli.common import UsageError, writable

    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UsageError) as e:
        writable(name, ("npz",))
    assert str(e.value) == message
    assert writable("sub/o.NPZ", ("npz",)) == Path("sub/o.NPZ")


@pytest.mark.parametrize("sensor, defaults, message", [
    pytest.param("buffer: 0, ", "{}", "5:47: error: sensors.q.buffer: expected a value >= 1; got 0", id="buffer-0"),
    pytest.param("buffers: 3, ", "{}", "5:39: error: sensors.q.buffers: unknown key 'buffers' (did you mean 'buffer'?); "
                 "allowed keys: kind, ...", id="buffers"),
    pytest.param("buffer: 100000, ", "{}", "5:47: error: sensors.q.buffer: a buffer keeps at most 10,000 samples (the "
                 "latest delivered ones); got 100000", id="buffer-too-large"),
    pytest.param("", "{buffer: 0}", "3:20: error: defaults.buffer: expected a value >= 1; got 0",
                 id="defaults-buffer-0"),
])
def test_a_rejected_buffer_is_one_problem_not_also_one_about_the_aggregator(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], sensor: str, defaults: str, message: str) -> None:
    """The aggregator is judged against the buffer: when the buffer is rejected it cannot be judged, and the
    user made one mistake, not two."""
    from sensorcfg.cli import main

    suite = write(tmp_path / "s.yaml", f"model: {ROBOT}\noptions: {{strip_singleton_buffer_dim: true}}\n"
                  f"defaults: {defaults}\nsensors:\n  q: {{kind: qpos, element: 'joint:*', {sensor}aggregator: mean}}\n")
    assert main(["validate", str(suite)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[1] == "1 problem in 1 of 1 suite", lines
    want = f"{suite}:{message}"
    assert lines[0].startswith(want[:-4]) if want.endswith(" ...") else lines[0] == want


# -- what the plot says about each value ------------------------------------------------------------------------

def _demo_groups() -> dict[str, tuple]:
    from sensorcfg.cli.quantities import value_groups

    suite = sensorcfg.load(sensorcfg.assets.path("demo.yaml"))
    model = suite.compile()
    widths = {"joint_pos": 3, "joint_vel": 6, "imu": 6, "motor_force": 3, "hand_to_target": 3}
    return {name: value_groups(model, suite.sensors[name], width) for name, width in widths.items()}


def test_values_are_grouped_by_quantity_and_unit_with_labels() -> None:
    """A gyro's rad/s and an accelerometer's m/s² are two axes, as are a hinge's radians and a slide's metres."""
    groups = _demo_groups()
    assert [(g.quantity, g.unit, g.columns, g.labels) for g in groups["imu"]] == [
        ("angular velocity", "rad/s", (0, 1, 2), ("imu_gyro.x", "imu_gyro.y", "imu_gyro.z")),
        ("linear acceleration", "m/s²", (3, 4, 5), ("imu_accel.x", "imu_accel.y", "imu_accel.z"))]
    assert [(g.quantity, g.unit, g.columns, g.labels) for g in groups["joint_pos"]] == [
        ("joint angle", "rad", (0, 1), ("shoulder", "elbow")), ("joint position", "m", (2,), ("finger_slide",))]
    assert [(g.unit, g.labels) for g in groups["joint_vel"]] == [
        ("rad/s", ("shoulder", "elbow", "wrist.x", "wrist.y", "wrist.z")), ("m/s", ("finger_slide",))]
    assert [(g.quantity, g.unit) for g in groups["motor_force"]] == [("force or torque", "N or N·m")]
    assert [(g.quantity, g.unit, g.labels) for g in groups["hand_to_target"]] == [
        ("value", "unit not known", ("[0]", "[1]", "[2]"))]


# The recipes' frame sensors on the Menagerie stand-ins. `gravity` adds a site to the world body, whose sites
# come first in the compiled model: a label looked up by compiled id in the file's own list named the next site
# (the G1 pelvis gyro was labelled left_foot.x/y/z), or none (an IndexError on Go2).
@pytest.mark.parametrize("recipe, elements", [
    pytest.param("humanoid", {"imu_ang_vel": ("imu_in_pelvis",), "projected_gravity": ("imu_in_pelvis",),
                              "base_lin_vel_clean": ("imu_in_pelvis",), "feet_pos": ("left_foot", "right_foot"),
                              "torso_up": ("torso_link",)}, id="g1"),
    pytest.param("quadruped", {"base_lin_vel": ("base",), "base_ang_vel": ("imu",), "projected_gravity": ("imu",)},
                 id="go2"),
])
def test_plot_labels_name_the_elements_the_values_are_of(recipe: str, elements: dict[str, tuple[str, ...]]) -> None:
    from conftest import MODELS
    from test_recipes import RECIPES, _recipe

    from sensorcfg.cli.quantities import value_groups

    suite = _recipe(recipe)[1]
    model = suite.compile(str(MODELS / RECIPES[recipe][1]))
    assert any(model.site(i).name.startswith("sensorcfg:") for i in range(model.nsite))  # added sites come first
    for name, named in elements.items():
        labels = [label for group in value_groups(model, suite.sensors[name], 3 * len(named)) for label in group.labels]
        assert labels == [f"{element}.{axis}" for element in named for axis in "xyz"], name


def test_run_plot_of_the_go2_recipe_on_its_stand_in(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from conftest import MODELS

    text = (ROOT / "docs" / "recipes" / "quadruped.yaml").read_text()
    write(tmp_path / "go2.yaml", "\n".join(line for line in text.splitlines() if not line.startswith("model: ")))
    proc = cli("run", "go2.yaml", "--model", str(MODELS / "go2_like.xml"), "--steps", "3", "--plot", "go2.png",
               cwd=tmp_path)
    assert proc.returncode == 0 and "wrote go2.png" in proc.stdout, proc.stderr


def test_the_plot_has_an_axis_per_unit_with_a_legend_and_explains_its_ticks() -> None:
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from sensorcfg.cli.describe import SensorRow
    from sensorcfg.cli.plot import _signal, _timing_legend

    row = SensorRow("imu", "sensordata", 2, (6,), "float64", "2", "250", "0", "0", 1, None, "-", 2, 0, False)
    fig = Figure()
    t = np.arange(5) * 0.02
    axes = _signal(fig, fig.add_gridspec(1, 1)[0, 0], t, np.zeros((5, 6)), row, _demo_groups()["imu"], None)
    assert [ax.get_ylabel() for ax in axes] == ["rad/s", "m/s²"]
    assert [(ax.get_legend().get_title().get_text(), [x.get_text() for x in ax.get_legend().get_texts()])
            for ax in axes] == [("angular velocity", ["imu_gyro.x", "imu_gyro.y", "imu_gyro.z"]),
                                ("linear acceleration", ["imu_accel.x", "imu_accel.y", "imu_accel.z"])]
    _timing_legend(fig)
    assert [x.get_text() for x in fig.legends[0].get_texts()] == [
        "sampled", "delivered (after the delay)", "skipped: no read can show it, so the Updater does not take it",
        "control step (a read)"]


@pytest.mark.parametrize("count, seconds, shown", [
    (300, 16.3, "18.4"), (3, 7.3, "0.411"), (1, 1e4, "0.0001"), (150_000, 10.0, "15,000"), (999, 10.0, "99.9")])
def test_rates_keep_their_significant_digits(count: int, seconds: float, shown: str) -> None:
    from sensorcfg.cli.run import _per_second

    assert _per_second(count, seconds) == shown
