"""Hostile and odd input: every one ends in a positioned problem (or, for usage and I/O errors, one line
and exit 2), in bounded time and memory, without disclosing files that are not suites and without
printing anything that could pass for a line of its own.

Inputs that once hung (a FIFO, /dev/zero, symlink loops) run in a subprocess with a timeout and a memory
limit, so a regression fails instead of hanging the test session.
"""

from __future__ import annotations

import json
import os
import re
import resource
import socket
import subprocess
import sys
from pathlib import Path

import pytest

import sensorcfg
import sensorcfg.assets
import sensorcfg.errors
from sensorcfg import ArgumentError, SensorcfgError, SuiteError, UnsupportedError
from sensorcfg.cli import main
from sensorcfg.config import limits, parse_text

ROBOT = "package://sensorcfg/assets/robot.xml"
OK = f"model: {ROBOT}\nsensors:\n  arm: {{kind: qpos, element: 'joint:elbow'}}\n"
LINE = re.compile(r"^(?P<file>[^\n]+?):(?P<line>\d+):(?P<col>\d+): error: (?P<message>.+)$")
MEMORY = 2 << 30  # bytes a checked subprocess may map


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY, MEMORY))


def cli(*args: str, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    """The command line in a subprocess with a memory limit and a timeout (a hang fails the test)."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run([sys.executable, "-m", "sensorcfg", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout, preexec_fn=_limited)
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc


def run_main(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def problems_of(text: str, **kwargs) -> list[str]:
    with pytest.raises(SuiteError) as info:
        sensorcfg.loads(text, **kwargs)
    return [p.format() for p in info.value.problems]


# -- the error types ---------------------------------------------------------------------------------------

def test_error_types_share_one_base_and_are_exported() -> None:
    for error in (SuiteError, ArgumentError, UnsupportedError):
        assert issubclass(error, SensorcfgError) and error.__name__ in sensorcfg.__all__
    assert "SensorcfgError" in sensorcfg.__all__
    assert issubclass(SuiteError, ValueError) and issubclass(ArgumentError, ValueError)  # as before
    with pytest.raises(ArgumentError, match="loads takes the suite's YAML text as a str; got bytes"):
        sensorcfg.loads(b"sensors: {}")  # type: ignore[arg-type]


def test_loading_returns_a_result_not_a_decorated_exception() -> None:
    text = ("sensors:\n  good: {kind: qpos, element: 'joint:elbow'}\n"
            "  bad: {kind: qpos, element: 'joint:elbow', buffer: 0}\n")
    result = parse_text(text)
    assert not result.ok and [p.loc for p in result.problems] == ["sensors.bad.buffer"]
    # the part that stands, to check against a model: a sensor without its rejected key (issue 12: a schema
    # mistake must not hide the same sensor's model mistakes)
    assert list(result.suite.sensors) == ["good", "bad"] and "buffer" not in result.suite.sensors["bad"].model_fields_set
    with pytest.raises(SuiteError) as info:
        result.unwrap()
    assert not hasattr(info.value, "_partial")
    assert parse_text(OK).unwrap().model is not None


# -- YAML past the limits, and standard tags with bad text ------------------------------------------------

@pytest.mark.parametrize("text, expected", [
    pytest.param("sensors:\n  s: " + "[" * 400 + "]" * 400 + "\n",
                 "<string>:2:68: error: values nest more than 64 levels deep; a suite needs about 6", id="nest-400"),
    pytest.param("sensors:\n  s: " + "[" * 2000 + "]" * 2000 + "\n",
                 "<string>:2:68: error: values nest more than 64 levels deep; a suite needs about 6", id="nest-2000"),
    pytest.param("sensors:\n" + "".join("  " * (i + 1) + f"k{i}:\n" for i in range(400)),
                 "<string>:64:127: error: values nest more than 64 levels deep; a suite needs about 6",
                 id="nest-block"),
    pytest.param("sensors:\n  s: {kind: qpos, element: 'joint:elbow', buffer: !!int abc}\n",
                 "<string>:2:51: error: sensors.s.buffer: 'abc' is not a valid !!int; fix it, or quote it to make it "
                 "text",
                 id="int-tag"),
    pytest.param("sensors:\n  s: {kind: qpos, element: 'joint:elbow', buffer: !!timestamp x}\n",
                 "<string>:2:51: error: sensors.s.buffer: 'x' is not a valid !!timestamp; fix it, or quote it to make "
                 "it text", id="timestamp-tag"),
    pytest.param("sensors:\n  s: {kind: qpos, element: 'joint:elbow', enabled: !!bool maybe}\n",
                 "<string>:2:52: error: sensors.s.enabled: 'maybe' is not a valid !!bool; fix it, or quote it to make "
                 "it text", id="bool-tag"),
    pytest.param("sensors:\n  s: {kind: qpos, element: 'joint:elbow', buffer: !!float x}\n",
                 "<string>:2:51: error: sensors.s.buffer: 'x' is not a valid !!float; fix it, or quote it to make "
                 "it text", id="float-tag"),
    pytest.param("sensors:\n  !!int zz: {kind: qpos}\n",
                 "<string>:2:3: error: sensors: 'zz' is not a valid !!int; fix it, or quote it to make it text",
                 id="key-tag"),
    pytest.param("sensors:\n  s: {kind: qpos, element: 'joint:elbow', buffer: " + "9" * 5000 + "}\n",
                 "<string>:2:51: error: sensors.s.buffer: an integer of 5000 digits is too large (at most 30); no "
                 "setting needs more", id="int-5000-digits"),
    pytest.param("sensors:\n  s: {kind: qpos, element: 'joint:elbow', delay: 0x" + "f" * 200 + "}\n",
                 "<string>:2:50: error: sensors.s.delay: an integer of 202 digits is too large (at most 30); no "
                 "setting needs more", id="int-hex"),  # YAML 1.2 has no 0b integers (0b... is text)
])
def test_yaml_past_the_limits_is_a_positioned_problem(text: str, expected: str) -> None:
    assert problems_of(text) == [expected]


def test_aliases_nested_through_aliases_stop_at_the_depth_limit() -> None:
    lines = ["a0: &a0 [1]"] + [f"a{i}: &a{i} [[[[[[[[[[*a{i - 1}]]]]]]]]]]" for i in range(1, 10)]
    text = "\n".join(lines) + "\nsensors: {}\n"
    [problem] = [p for p in problems_of(text) if "nest" in p]
    assert problem.endswith("values nest more than 64 levels deep (through aliases); a suite needs about 6")


def test_an_alias_bomb_is_its_one_problem() -> None:
    """A document stopped at a limit reports that limit only: not the keys it never finished building, nor
    the valid `sensors: {}` after it as null (issue 24)."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]  # 9**9 values
    assert problems_of("\n".join(lines) + "\nsensors: {}\n") == [
        "<string>:1:17: error: a5.0.3.3.7.2.1: the file expands to more than 100,000 values (through aliases); write "
        "it out plainly"]
    lines = ["a0: &a0 [1]"] + [f"a{i}: &a{i} [[[[[[[[[[*a{i - 1}]]]]]]]]]]" for i in range(1, 10)]
    assert problems_of("\n".join(lines) + "\nsensors: {}\n") == [
        "<string>:2:13: error: values nest more than 64 levels deep (through aliases); a suite needs about 6"]


def test_node_count_and_file_size_limits(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(limits, "MAX_NODES", 50)
    assert problems_of("sensors: {}\nx: [" + ", ".join(["1"] * 60) + "]\n") == [
        "<string>:2:140: error: the file holds more than 50 values; a suite is far smaller"]
    monkeypatch.setattr(limits, "MAX_SUITE_BYTES", 1024)
    big = tmp_path / "big.yaml"
    big.write_text("# " + "x" * 2000 + "\nsensors: {}\n")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(big)
    assert [p.message for p in info.value.problems] == [
        "cannot read this suite: it is 2,015 bytes; a suite may be at most 1,024"]


# -- schedules: sizes that would allocate terabytes, times that are not finite -------------------------------

@pytest.mark.parametrize("key, value, expected", [
    pytest.param("buffer", "1000000000000", "3:51: error: sensors.s.buffer: a buffer keeps at most 10,000 samples "
                 "(the latest delivered ones); got 1000000000000", id="buffer-1e12"),
    pytest.param("buffer", "1e12", "3:51: error: sensors.s.buffer: expected an integer; got 1000000000000.0",
                 id="buffer-1e12-float"),  # YAML 1.2 reads 1e12 as a number (a float), as editors do
    pytest.param("delay", "1000000000", "3:50: error: sensors.s.delay: 1000000000 physics steps is more than "
                 "1,000,000, the most a schedule may take", id="delay-1e9"),
    pytest.param("interval", "{uniform: [1, 100000000]}", "3:53: error: sensors.s.interval: 100000000 physics steps "
                 "is more than 1,000,000, the most a schedule may take", id="interval-draw"),
    pytest.param("interval", "'1e999s'", "3:53: error: sensors.s.interval: '1e999s' is not a finite number; use a "
                 "time like '4ms', '0.02s', '500us', '50Hz'", id="interval-1e999s"),
    pytest.param("noise", "[{type: quantize, step: 5.0e-324}]", "3:74: error: sensors.s.noise.0.step: a quantisation "
                 "step must be >= 1e-100, got 5e-324", id="quantize-subnormal"),  # found by test_fuzz: read inf
])
def test_schedule_sizes_are_problems_at_their_line(key: str, value: str, expected: str) -> None:
    text = f"model: {ROBOT}\nsensors:\n  s: {{kind: qpos, element: 'joint:elbow', {key}: {value}}}\n"
    assert problems_of(text, file="s.yaml") == ["s.yaml:" + expected]


@pytest.mark.parametrize("key, value, expected", [
    pytest.param("delay", "'1e9s'", "sensors.s.delay: 1e9s is 5e+11 physics steps of 2ms; a schedule may take at most "
                 "1,000,000 steps", id="delay-1e9s"),
    pytest.param("interval", "'1e-300Hz'", "sensors.s.interval: 1e-300Hz is 5e+302 physics steps of 2ms; a schedule "
                 "may take at most 1,000,000 steps", id="rate-tiny"),
    pytest.param("interval", "'1e-320Hz'", "sensors.s.interval: 1e-320Hz is infinitely many physics steps of 2ms; a "
                 "schedule may take at most 1,000,000 steps", id="rate-overflow"),
])
def test_check_returns_problems_for_times_that_are_too_long(key: str, value: str, expected: str) -> None:
    suite = sensorcfg.loads(f"model: {ROBOT}\nsensors:\n  s: {{kind: qpos, element: 'joint:elbow', {key}: {value}}}\n")
    assert [f"{p.loc}: {p.message}" for p in suite.check()] == [expected]
    with pytest.raises(SuiteError):
        suite.build()


def test_an_observation_too_large_to_hold_is_a_problem_at_its_buffer() -> None:
    text = (f"model: {ROBOT}\nsensors:\n  cam: {{kind: rgb, element: 'camera:wrist', buffer: 10000, "
            "camera: {width: 640, height: 480}}\n")
    suite = sensorcfg.loads(text, file="s.yaml")
    assert [p.format() for p in suite.check()] == [
        "s.yaml:3:53: error: sensors.cam.buffer: 10000 samples of 921,600 bytes (480x640x3 uint8) make 8.6 GiB; an "
        "observation may hold at most 1 GiB: use a smaller buffer or image"]
    with pytest.raises(SuiteError, match="make 8.6 GiB"):
        suite.build()


def test_control_interval_past_the_limit_is_a_problem() -> None:
    suite = sensorcfg.loads(f"model: {ROBOT}\noptions: {{control_interval: '1e99s'}}\nsensors: {{}}\n")
    with pytest.raises(SuiteError, match=r"options.control_interval: 1e99s is 5e\+101 physics steps"):
        suite.updater_kwargs()


# -- files: only regular ones, never blocking, inside the suite's folder tree --------------------------------

def _extends(tmp_path: Path, target: str | Path) -> Path:
    suite = tmp_path / "suite.yaml"
    suite.write_text(f"extends: {target}\nsensors: {{}}\n")
    return suite


def test_extends_a_fifo_is_an_error_without_reading(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.yaml")
    _extends(tmp_path, "pipe.yaml")
    proc = cli("validate", "suite.yaml", cwd=tmp_path, timeout=60)
    assert proc.returncode == 1
    assert proc.stdout.splitlines()[0] == ("suite.yaml:1:10: error: extends: cannot read 'pipe.yaml' (resolved to "
                                           f"{tmp_path.resolve()}/pipe.yaml): it is a FIFO (named pipe), not a "
                                           "regular file; extends paths are relative to the file that names them")


@pytest.mark.parametrize("device, what", [("/dev/zero", "a character device"), ("/dev/urandom", "a character device")])
def test_extends_a_device_is_an_error_without_reading(tmp_path: Path, device: str, what: str) -> None:
    _extends(tmp_path, device)
    proc = cli("validate", "suite.yaml", "--extends-root", "/", cwd=tmp_path, timeout=60)
    assert proc.returncode == 1 and f"it is {what}, not a regular file" in proc.stdout


def test_extends_a_directory_or_a_socket_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "folder.yaml").mkdir()
    with pytest.raises(SuiteError, match="it is a directory, not a regular file"):
        sensorcfg.load(_extends(tmp_path, "folder.yaml"))
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(tmp_path / "sock.yaml"))
        with pytest.raises(SuiteError, match="it is a socket, not a regular file"):
            sensorcfg.load(_extends(tmp_path, "sock.yaml"))


def test_a_suite_that_is_a_fifo_is_an_io_error(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "pipe.yaml")
    proc = cli("spec", "pipe.yaml", cwd=tmp_path, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip() == "sensorcfg: error: pipe.yaml: is not a regular file, expected a suite file"
    (tmp_path / "ok.yaml").write_text(OK)
    proc = cli("validate", ".", cwd=tmp_path, timeout=60)
    assert proc.returncode == 2 and proc.stdout.strip() == "1 suite valid"
    assert proc.stderr.strip() == ("sensorcfg: error: pipe.yaml: cannot read this suite: it is a FIFO (named pipe), "
                                   "not a regular file")


def test_extends_stays_in_the_suite_folder_tree_unless_allowed(tmp_path: Path) -> None:
    (tmp_path / "outside.yaml").write_text(OK)
    (tmp_path / "project" / "sub").mkdir(parents=True)
    (tmp_path / "project" / "base.yaml").write_text(OK)
    top = tmp_path / "project" / "top.yaml"
    top.write_text("extends: ../outside.yaml\nsensors: {}\n")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(top)
    [problem] = info.value.problems
    assert (problem.line, problem.col, problem.loc) == (1, 10, "extends")
    assert problem.message.startswith(f"'../outside.yaml' is outside the folder of the suite being loaded "
                                      f"({(tmp_path / 'project').resolve()}), where extends may reach; allow more with "
                                      "--extends-root DIR")
    assert list(sensorcfg.load(top, extends_root=tmp_path).sensors) == ["arm"]
    # A suite below may extend a file above it only when the root says so; a symlink out is outside too.
    (tmp_path / "project" / "sub" / "s.yaml").write_text("extends: ../base.yaml\nsensors: {}\n")
    with pytest.raises(SuiteError, match="is outside the folder"):
        sensorcfg.load(tmp_path / "project" / "sub" / "s.yaml")
    assert list(sensorcfg.load(tmp_path / "project" / "sub" / "s.yaml", extends_root=tmp_path / "project").sensors)
    (tmp_path / "project" / "link.yaml").symlink_to(tmp_path / "outside.yaml")
    top.write_text("extends: link.yaml\nsensors: {}\n")
    with pytest.raises(SuiteError, match="'link.yaml' is outside the folder"):
        sensorcfg.load(top)
    proc = cli("validate", "project/top.yaml", "--extends-root", ".", cwd=tmp_path)
    assert proc.returncode == 0 and proc.stdout.strip() == "1 suite valid"


def test_extends_a_symlink_loop_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").symlink_to(tmp_path / "b.yaml")
    (tmp_path / "b.yaml").symlink_to(tmp_path / "a.yaml")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(_extends(tmp_path, "a.yaml"))
    assert [p.format() for p in info.value.problems] == [
        f"{tmp_path.resolve()}/suite.yaml:1:10: error: extends: cannot read 'a.yaml': a symlink loop"]


SECRET = "hunter2-" + "s" * 60


def test_a_file_that_is_not_a_suite_is_never_quoted(tmp_path: Path) -> None:
    (tmp_path / "shadow").write_text(f"root:$6${SECRET}:19000:0:99999:7:::\nuser: {SECRET}\n"
                                     f"{SECRET}: 1\n")
    for target in ("shadow", str(tmp_path / "shadow")):
        proc = cli("validate", "suite.yaml", cwd=tmp_path) if _extends(tmp_path, target) else None
        assert proc.returncode == 1 and "hunter2" not in proc.stdout + proc.stderr
        assert proc.stdout.startswith(f"suite.yaml:1:10: error: extends: {target!r} is not a suite: 3 of its "
                                      "top-level keys are not suite keys")
    (tmp_path / "list").write_text(f"- {SECRET}\n")
    proc = cli("validate", str(_extends(tmp_path, "list")), cwd=tmp_path)
    assert "hunter2" not in proc.stdout and "'list' is not a suite (its top level is not a mapping)" in proc.stdout


def test_values_from_an_extended_suite_are_quoted_short(tmp_path: Path) -> None:
    (tmp_path / "base.yaml").write_text(f"model: package://{SECRET}\nsensors:\n  a: {{kind: {SECRET}}}\n")
    proc = cli("validate", str(_extends(tmp_path, "base.yaml")), cwd=tmp_path)
    assert proc.returncode == 1
    quoted = re.findall(r"hunter2-s*", proc.stdout)
    assert quoted and max(map(len, quoted)) <= sensorcfg.errors.QUOTE_LIMIT, proc.stdout


# -- nothing from input prints as a line of its own --------------------------------------------------------

FORGED = "a\nsrc/main.py:1:1: error: forged\x1b[31m\u2028x"


def _suite_with_forged_names(tmp_path: Path) -> Path:
    suite = tmp_path / "s.yaml"
    suite.write_text(f"model: {ROBOT}\nsensors:\n  {json.dumps(FORGED)}: {{kind: qpos}}\n"
                     f"  ok: {{kind: {json.dumps(FORGED)}, element: {json.dumps(FORGED)}}}\n")
    return suite


def test_text_output_escapes_newlines_and_ansi(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _suite_with_forged_names(tmp_path)
    code, out, err = run_main(capsys, "validate", str(tmp_path / "s.yaml"))
    assert code == 1 and "\x1b" not in out + err and "\u2028" not in out + err
    lines = out.splitlines()
    assert all(LINE.match(line)["file"] == str(tmp_path / "s.yaml") for line in lines[:-1]), lines
    assert lines[-1].startswith(f"{len(lines) - 1} problem")
    assert "a\\nsrc/main.py:1:1: error: forged\\x1b[31m\\u2028x" in out


def test_json_output_escapes_newlines_and_ansi(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _suite_with_forged_names(tmp_path)
    code, out, _ = run_main(capsys, "validate", str(tmp_path / "s.yaml"), "--format", "json")
    report = json.loads(out)
    assert code == 1 and report["problems"]
    for p in report["problems"]:
        for field in ("message", "loc", "file"):
            assert p[field].isprintable(), p[field]


def test_a_file_name_with_a_newline_cannot_forge_a_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "suites"
    folder.mkdir()
    (folder / "x\nsrc_main.py:1:1: error: forged.yaml").write_text("sensors: {s: {kind: qpos, buffer: 0}}\n")
    code, out, _ = run_main(capsys, "validate", str(folder))
    assert code == 1
    assert not any(line.startswith("src_main.py") for line in out.splitlines())
    assert "x\\nsrc_main.py:1:1: error: forged.yaml:1:" in out


# -- validate DIR: loops, unreadable folders, long names, one file failing ----------------------------------

@pytest.mark.parametrize("links", [1, 2])
def test_validate_a_folder_with_self_symlinks_checks_each_file_once(tmp_path: Path, links: int) -> None:
    (tmp_path / "suites").mkdir()
    (tmp_path / "suites" / "a.yaml").write_text(OK)
    for i in range(links):
        (tmp_path / "suites" / f"loop{i}").symlink_to(tmp_path / "suites")
    (tmp_path / "suites" / "alias.yaml").symlink_to(tmp_path / "suites" / "a.yaml")
    proc = cli("validate", "suites", "--format", "json", cwd=tmp_path, timeout=60)
    assert proc.returncode == 0
    assert [f["path"] for f in json.loads(proc.stdout)["files"]] == ["suites/a.yaml"]


def test_validate_a_folder_does_not_follow_links_out_of_it(tmp_path: Path) -> None:
    """Found by review: `validate configs/` read a link `configs/x.yaml` to any file (or a linked folder
    outside) and quoted the file's text in its problems; `extends` and `model:` stay in the tree already."""
    (tmp_path / "secret").write_text("Host example\n  User private_name\n")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "b.yaml").write_text(OK)
    (tmp_path / "suites" / "sub").mkdir(parents=True)
    (tmp_path / "suites" / "sub" / "a.yaml").write_text(OK)
    (tmp_path / "suites" / "x.yaml").symlink_to(tmp_path / "secret")
    (tmp_path / "suites" / "out").symlink_to(tmp_path / "elsewhere")
    (tmp_path / "suites" / "inner.yaml").symlink_to(tmp_path / "suites" / "sub" / "a.yaml")  # inside: followed
    proc = cli("validate", "suites", "--format", "json", cwd=tmp_path, timeout=60)
    assert "private_name" not in proc.stdout + proc.stderr
    assert [f["path"] for f in json.loads(proc.stdout)["files"]] == ["suites/inner.yaml"]
    assert proc.stderr.count("a link out of the folder being validated") == 2, proc.stderr
    assert cli("validate", "suites/x.yaml", cwd=tmp_path, timeout=60).returncode == 1  # named: checked


def test_an_unreadable_folder_is_reported_and_the_rest_is_checked(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "a" / "locked").mkdir(parents=True)
    (tmp_path / "a" / "locked" / "x.yaml").write_text(OK)
    (tmp_path / "a" / "ok.yaml").write_text(OK)
    (tmp_path / "a" / "z.yaml").write_text("sensors: {s: {kind: qpos, buffer: 0}}\n")
    real = os.scandir

    def scandir(path):  # what a folder without read permission does (the tests may run as root)
        if Path(path).name == "locked":
            raise PermissionError(13, "Permission denied")
        return real(path)

    monkeypatch.setattr(os, "scandir", scandir)
    monkeypatch.chdir(tmp_path)
    code, out, err = run_main(capsys, "validate", "a", "--format", "json")
    report = json.loads(out)
    assert code == 2
    assert [Path(f["path"]).name for f in report["files"]] == ["ok.yaml", "z.yaml"]
    assert report["errors"] == [{"path": "a/locked", "message": "cannot read this folder: Permission denied"}]
    assert err.strip() == "sensorcfg: error: a/locked: cannot read this folder: Permission denied"


def test_a_file_name_too_long_is_an_io_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    name = "x" * 300 + ".yaml"
    code, out, err = run_main(capsys, "validate", str(tmp_path / name))
    assert code == 2 and out == ""
    assert err.strip() == f"sensorcfg: error: {tmp_path / name}: the file name is too long"
    code, _, err = run_main(capsys, "spec", name)
    assert code == 2 and err.strip().endswith(": the file name is too long")
    with pytest.raises(SuiteError, match="cannot read this suite: the file name is too long"):
        sensorcfg.load(tmp_path / name)


def test_one_failing_file_does_not_hide_the_others(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from sensorcfg.cli import validate

    for name in ("a.yaml", "b.yaml", "c.yaml"):
        (tmp_path / name).write_text(OK)
    real = validate.check_file

    def check_file(path, *args):
        if path.name == "b.yaml":  # a bug inside sensorcfg, not in the user's code
            sensorcfg.errors.printable(None)  # type: ignore[arg-type]
        return real(path, *args)

    monkeypatch.setattr(validate, "check_file", check_file)
    code, out, _ = run_main(capsys, "validate", str(tmp_path), "--format", "json")
    report = json.loads(out)
    assert code == 1
    assert [(Path(f["path"]).name, f["valid"]) for f in report["files"]] == [
        ("a.yaml", True), ("b.yaml", False), ("c.yaml", True)]
    [problem] = report["problems"]
    assert problem["message"].startswith("sensorcfg failed on this file (AttributeError: ")


# -- overrides and options --------------------------------------------------------------------------------

def test_an_override_with_a_python_tag_is_an_error_not_a_deletion(tmp_path: Path) -> None:
    (tmp_path / "s.yaml").write_text(OK)
    proc = cli("validate", "s.yaml", "--set", "sensors.arm=!!python/object/apply:os.system ['true']", cwd=tmp_path)
    assert proc.returncode == 1 and "valid" not in proc.stdout.splitlines()[-1].split(" in ")[0]
    assert proc.stdout.splitlines()[0].startswith(
        "override 'sensors.arm=!!python/object/apply:os.system ['true']':1:13: error: sensors.arm: the tag "
        "'!!python/object/apply:os.system' is not allowed")
    with pytest.raises(SuiteError, match="is not allowed"):
        sensorcfg.loads(OK, overrides=["sensors.arm=!!python/name:os.system"])


def test_an_override_index_with_a_non_ascii_digit_is_a_clean_problem() -> None:
    text = OK.replace("}", ", noise: [{type: gaussian, std: 0.1}]}")
    assert sensorcfg.loads(text, overrides=["sensors.arm.noise.0.std=0.2"]).sensors["arm"].noise[0].std == 0.2
    for index in ("\u0661", "\u00b2", "\uff10"):  # Arabic-Indic one, superscript two, fullwidth zero
        problems = problems_of(text, overrides=[f"sensors.arm.noise.{index}.std=0.2"])
        assert problems == [f"override 'sensors.arm.noise.{index}.std=0.2':1:1: error: sensors.arm.noise.{index}.std: "
                            "sensors.arm.noise is a list of 1; use an index 0..0"]


@pytest.mark.parametrize("seed", ["-1", "4294967296", "1.5", "\u0661"])
def test_run_seed_out_of_range_is_a_usage_error(seed: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_main(capsys, "run", "x.yaml", "--seed", seed)
    assert code == 2 and out == "" and "--seed: expected a seed from 0 to 4294967295" in err


# -- the Python API raises sensorcfg's own errors ----------------------------------------------------------

@pytest.mark.parametrize("text", [
    pytest.param("sensors: !!set {a}", id="set-tag"),
    pytest.param("sensors:\n  s: {kind: qpos, element: !!binary 'AAAA'}\n", id="binary"),
    pytest.param("sensors:\n  ? [a, b]\n  : 1\n", id="complex-key"),
    pytest.param("sensors: {s: {kind: qpos, element: 'joint:*', interval: {uniform: [3, 1e999]}}}", id="draw-text"),
    pytest.param("sensors: {s: {kind: qpos, element: 'joint:*', noise: [{type: gaussian, std: .inf}]}}", id="inf"),
    pytest.param("model: 'package://'\nsensors: {}\n", id="package-empty"),
    pytest.param("model: 'package://a-b/x.xml'\nsensors: {}\n", id="package-bad-name"),
    pytest.param("model: \"\\0\"\nsensors: {}\n", id="model-nul"),
    pytest.param("extends: \"\\0\"\nsensors: {}\n", id="extends-nul"),
    pytest.param("extends: '" + "x" * 5000 + "'\nsensors: {}\n", id="extends-long"),
    pytest.param("\ufeffsensors: {}\n\x00", id="nul-byte"),
])
def test_odd_suites_raise_only_suite_errors(text: str, tmp_path: Path) -> None:
    try:
        suite = sensorcfg.loads(text, base_dir=tmp_path)
    except SuiteError as e:
        assert e.problems and all(p.format().isprintable() for p in e.problems)
        return
    assert isinstance(suite.check(str(sensorcfg.assets.path("robot.xml"))), list)


# -- size: many keys cost time in proportion ------------------------------------------------------------

def test_too_many_sensors_is_one_problem() -> None:
    text = "sensors:\n" + "".join(f"  s{i}: {{kind: qpos, element: 'joint:elbow'}}\n" for i in range(1001))
    assert problems_of(text) == ["<string>:2:3: error: sensors: at most 1000 sensors in a suite; got 1001"]


def _composed(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The files whose text `extends` composes from now on (the structural sign that a file was read and built)."""
    from sensorcfg.config import extends

    files: list[str] = []
    compose = extends.compose

    def recorded(text: str, file: str, **kwargs) -> object:
        files.append(Path(file).name)
        return compose(text, file, **kwargs)

    monkeypatch.setattr(extends, "compose", recorded)
    return files


def _chain(tmp_path: Path, texts: list[str]) -> Path:
    """Files f0.yaml extends f1.yaml ... extends the last; file i holds texts[i]."""
    for i, text in enumerate(texts):
        parent = f"extends: f{i + 1}.yaml\n" if i + 1 < len(texts) else ""
        (tmp_path / f"f{i}.yaml").write_text(parent + text)
    return tmp_path / "f0.yaml"


def test_the_bytes_of_an_extends_chain_are_bounded_together(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 30: each file of a 32-file chain was allowed 1 MiB (113 s, 1.4 GiB before a problem): the files of
    a suite share one budget, and a parent past what its children left is refused before it is read."""
    comment = "# " + "x" * 500_000 + "\n"  # (cheap to read: the budget is what is tested)
    top = _chain(tmp_path, [comment + "sensors: {}\n", comment, comment, "sensors: {}\n"])
    composed = _composed(monkeypatch)
    assert problems_of_file(top) == [
        "f1.yaml:1:10: error: extends: cannot read 'f2.yaml' (resolved to f2.yaml): it is 500,020 bytes, and the "
        "files that extend it 1,000,052; a suite's files together may be at most "
        "1,048,576 bytes; extends paths are relative to the file that names them"]
    assert composed == ["f1.yaml"]  # f2.yaml is refused by its size alone, f3.yaml never reached


def test_the_values_of_an_extends_chain_are_bounded_together(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each file under MAX_NODES, an alias in each, the chain far past it: stopped in the file that passes it."""
    monkeypatch.setattr(limits, "MAX_NODES", 1_000)
    flags = "defaults:\n  camera:\n    scene: &s {" + ", ".join(f"k{i}: true" for i in range(200)) + "}\n"
    aliased = flags + "cameras:\n  c: {element: body:base}\nsensors:\n" + "".join(
        f"  s{i}: {{kind: rgb, element: camera:c, camera: {{scene: *s}}}}\n" for i in range(2))  # about 600 values
    top = _chain(tmp_path, [aliased] * 32)
    composed = _composed(monkeypatch)
    [problem] = problems_of_file(top)
    assert problem.startswith("f0.yaml:1:10: error: extends: 'f1.yaml' takes the suite past a limit (at its line ")
    assert problem.endswith("the suite's files hold more than 1,000 values together (619 of them in the files that "
                            "extend this one); a suite is far smaller")
    assert composed == ["f1.yaml"]  # nothing past the file that passed the limit is read


def test_the_sensors_of_a_merged_suite_are_counted_before_any_is_validated(tmp_path: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 30: 9,600 sensors cost 54 s of validation (a problem each) before "at most 1000 sensors"."""
    from sensorcfg.config.models import SuiteConfig

    def sensors(first: int) -> str:
        return "sensors:\n" + "".join(f"  s{i}: {{kind: qpos, element: 'joint:elbow', buffers: 2}}\n"
                                       for i in range(first, first + 600))
    top = _chain(tmp_path, [sensors(0), sensors(600)])  # each file under the limit, the suite past it
    validated: list[object] = []
    validate = SuiteConfig.model_validate
    monkeypatch.setattr(SuiteConfig, "model_validate", lambda value, **kw: validated.append(value) or validate(value))
    assert problems_of_file(top) == ["f1.yaml:2:3: error: sensors: at most 1000 sensors in a suite; got 1200"]
    assert validated == []  # no sensor validated (each would have been a problem, 'buffers')
    assert problems_of(sensors(0), file="one.yaml")[0].startswith("one.yaml:2:")  # (600 are checked as usual)


def test_a_chain_of_large_files_stops_at_the_budget_in_bounded_time(tmp_path: Path) -> None:
    """The issue's chain at the real limits, in a subprocess with a memory limit: 32 files of 900 kB each."""
    comment = "".join("# " + "x" * 1_000 + "\n" for _ in range(900))
    _chain(tmp_path, [comment + f"sensors:\n  s{i}: {{kind: qpos, element: 'joint:elbow'}}\n" for i in range(32)])
    proc = cli("validate", "f0.yaml", cwd=tmp_path, timeout=60)
    assert proc.returncode == 1 and proc.stdout.splitlines()[-1] == "1 problem in 1 of 1 suite", proc.stdout
    assert "a suite's files together may be at most 1,048,576 bytes" in proc.stdout


def problems_of_file(path: Path) -> list[str]:
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(path)
    return [p.format().replace(str(path.parent) + "/", "") for p in info.value.problems]


def test_extends_that_deletes_many_keys_takes_linear_time(tmp_path: Path) -> None:
    n = 20_000  # was quadratic: four minutes; now seconds (the timeout fails a regression)
    scene = "defaults:\n  camera:\n    scene:\n"
    (tmp_path / "base.yaml").write_text("sensors: {}\n" + scene + "".join(f"      k{i}: true\n" for i in range(n)))
    deletions = "".join(f"      k{i}: null\n" for i in range(n))
    (tmp_path / "top.yaml").write_text("extends: base.yaml\n" + scene + deletions)
    proc = cli("validate", "top.yaml", cwd=tmp_path, timeout=90)
    assert proc.returncode == 0, proc.stdout


def test_wrong_arguments_to_the_python_api_are_argument_errors(tmp_path: Path) -> None:
    with pytest.raises(ArgumentError, match="load takes a path to a suite file; got int"):
        sensorcfg.load(3)  # type: ignore[arg-type]
    with pytest.raises(ArgumentError, match=r"overrides is a list of 'dotted.key=value' strings, .*; got 'a=b'"):
        sensorcfg.loads(OK, overrides="a=b")  # type: ignore[arg-type]
    with pytest.raises(ArgumentError, match="base_dir '/x\\\\x00' cannot be resolved: the path holds a NUL"):
        sensorcfg.loads(OK, base_dir="/x\0")
    with pytest.raises(ArgumentError, match="model: expected a sensorcfg.Physics"):
        sensorcfg.loads(OK).check(3)


def test_a_model_that_is_not_a_regular_file_is_a_problem_before_mujoco_opens_it(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "robot.xml")  # MuJoCo would block on it forever
    suite = sensorcfg.loads("model: robot.xml\nsensors: {}\n", base_dir=tmp_path, file="s.yaml")
    assert [p.format() for p in suite.check()] == [
        f"s.yaml:1:8: error: model: cannot load the model '{tmp_path.resolve()}/robot.xml': it is a FIFO (named "
        "pipe), not a regular file"]
    assert [p.message for p in suite.check("/dev/zero")] == [
        "cannot load the model '/dev/zero': it is a character device, not a regular file"]


def test_a_yaml_error_in_an_extended_file_says_where_but_quotes_nothing(tmp_path: Path) -> None:
    (tmp_path / "secret.txt").write_text(f"a: 1\nb: *{SECRET}\n")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(_extends(tmp_path, "secret.txt"))
    assert [p.message for p in info.value.problems] == [
        "'secret.txt' is not a suite: it is not valid YAML (line 2, column 4); check it with 'sensorcfg validate' "
        "on that file"]


def test_validate_a_folder_nested_deeper_than_the_recursion_limit(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    deep = tmp_path / "top"
    path = deep
    os.mkdir(path)
    for _ in range(1200):  # deeper than Python's recursion limit, shorter than PATH_MAX
        path = path / "d"
        os.mkdir(path)
    (path / "s.yaml").write_text(OK)
    (deep / "a.yaml").write_text(OK)
    (deep / "z.yaml").write_text(OK)
    try:
        code, out, _ = run_main(capsys, "validate", str(deep), "--format", "json")
    finally:  # pytest's own clean-up recurses and cannot remove a tree this deep
        os.remove(path / "s.yaml")
        while path != deep:
            os.rmdir(path)
            path = path.parent
    assert code == 0
    names = [f["path"][len(str(deep)) + 1:] for f in json.loads(out)["files"]]
    assert names == ["a.yaml", "d/" * 1200 + "s.yaml", "z.yaml"]  # path order, as before


# -- which model files a suite may name ----------------------------------------------------------------------

_MODEL_ROOT_FIX = ("where model may reach; allow more with --extends-root DIR on the command line, or "
                   "extends_root=DIR in Python (extends_root='/' allows any file), or name a file of an installed "
                   "package as 'package://<package>/<path>'")


@pytest.mark.parametrize("model", [
    pytest.param("/etc/passwd", id="absolute"),
    pytest.param("../outside.xml", id="dot-dot"),
    pytest.param("link.xml", id="symlink-out"),
    pytest.param("/no/such/file.xml", id="missing-says-no-more"),
])
def test_a_suite_model_stays_in_the_suite_folder_tree_unless_allowed(tmp_path: Path, model: str) -> None:
    """Refused from the path alone, before MuJoCo opens it: its parse error would tell whether a file exists
    and quote element names from it."""
    (tmp_path / "outside.xml").write_text(f"<mujoco><worldbody><body name='{SECRET}'/></worldbody></mujoco>")
    project = tmp_path / "project"
    project.mkdir()
    (project / "link.xml").symlink_to(tmp_path / "outside.xml")
    suite = project / "s.yaml"
    suite.write_text(f"model: {model}\nsensors:\n  q: {{kind: qpos, element: 'joint:*'}}\n")
    with pytest.raises(SuiteError) as info:
        sensorcfg.load(suite)
    assert [p.format() for p in info.value.problems] == [
        f"{suite.resolve()}:1:8: error: model: {model!r} is outside the folder of the suite being loaded "
        f"({project.resolve()}), {_MODEL_ROOT_FIX}"]
    proc = cli("validate", "project/s.yaml", cwd=tmp_path)
    assert proc.returncode == 1 and "hunter2" not in proc.stdout + proc.stderr
    assert proc.stdout.startswith(f"project/s.yaml:1:8: error: model: {model!r} is outside the folder")
    if model != "/no/such/file.xml":  # widened, the file is the model (and a missing one is said missing)
        assert sensorcfg.load(suite, extends_root=tmp_path if model != "/etc/passwd" else "/").model


def test_a_suite_model_inside_its_tree_is_allowed(tmp_path: Path) -> None:
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "r.xml").write_text(sensorcfg.assets.path("robot.xml").read_text())
    (tmp_path / "configs").mkdir()
    (tmp_path / "configs" / "s.yaml").write_text("model: ../models/r.xml\nsensors:\n  q: {kind: qpos, element: 'joint:*'}\n")
    with pytest.raises(SuiteError, match="is outside the folder"):
        sensorcfg.load(tmp_path / "configs" / "s.yaml")
    assert sensorcfg.load(tmp_path / "configs" / "s.yaml", extends_root=tmp_path).model == str(
        (tmp_path / "models" / "r.xml").resolve())
    proc = cli("validate", "configs/s.yaml", "--extends-root", ".", cwd=tmp_path)
    assert proc.returncode == 0 and proc.stdout.strip() == "1 suite valid", proc.stdout + proc.stderr


@pytest.mark.parametrize("inner", ["../../../../../../etc/passwd", "escape.xml", "sub/../../outside.xml"])
def test_a_package_model_stays_in_its_package(tmp_path: Path, inner: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Neither '..' nor a symlink inside the package leads out of it, whatever the suite's root allows."""
    package = tmp_path / "site" / "robots_pkg_xyz"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (tmp_path / "site" / "outside.xml").write_text("<mujoco/>")
    (package / "escape.xml").symlink_to(tmp_path / "site" / "outside.xml")
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    model = f"package://robots_pkg_xyz/{inner}"
    with pytest.raises(SuiteError) as info:
        sensorcfg.loads(f"model: {model}\nsensors: {{}}\n", file="s.yaml", extends_root="/")
    assert [p.format() for p in info.value.problems] == [
        f"s.yaml:1:8: error: model: {model!r} leaves the folder of the package 'robots_pkg_xyz' ({package}); a "
        "package:// model is a file inside it, named without '..' and not through a symlink out of it"]
