"""Cameras and OpenGL: any thread, several threads at once, a clean exit, and machines without a GL backend.

Renderers are per (model, size, thread) and leave no context current after a frame, so a camera environment
made in one thread steps in another and closes at exit from the main thread. Without a usable backend,
everything that needs no camera works and a camera fails with one line naming the packages to install.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np

import sensorcfg
from sensorcfg import assets

from conftest import ROOT

ROBOT = str(assets.path("robot.xml"))
CONFIGS = ROOT / "configs"
VISION = str(CONFIGS / "vision.yaml")


def _run(env: sensorcfg.Environment, steps: int) -> list[dict[str, np.ndarray]]:
    out = [env.reset().observation]
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, env.action_spec().shape[0]))
    out += [env.step(a).observation for a in actions]
    return out


def _same(a: list[dict[str, np.ndarray]], b: list[dict[str, np.ndarray]]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        for k in x:
            assert x[k].tobytes() == y[k].tobytes(), k


def test_a_camera_environment_rendered_in_one_thread_steps_in_another() -> None:
    reference = _run(sensorcfg.make_env(VISION, seed=0), 6)
    env = sensorcfg.make_env(VISION, seed=0)
    first: list = []
    rendered, done = threading.Event(), threading.Event()

    def other_thread() -> None:  # renders first, and stays alive holding its renderer
        first.append(env.reset().observation)
        rendered.set()
        done.wait(60)

    thread = threading.Thread(target=other_thread)
    thread.start()
    try:
        assert rendered.wait(60)
        actions = np.random.default_rng(1).uniform(-1, 1, (6, env.action_spec().shape[0]))
        rest = [env.step(a).observation for a in actions]
    finally:
        done.set()
        thread.join()
    _same(first + rest, reference)


def test_camera_environments_in_several_threads_at_once() -> None:
    reference = _run(sensorcfg.make_env(VISION, seed=0), 8)
    results: dict[int, list] = {}
    errors: list[BaseException] = []
    start = threading.Barrier(3)

    def worker(i: int) -> None:
        try:
            env = sensorcfg.make_env(VISION, seed=0)
            start.wait(60)
            results[i] = _run(env, 8)
        except BaseException as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for i in range(3):
        _same(results[i], reference)


def _python(code: str, env: dict[str, str] | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    full = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(sensorcfg.__file__).parent.parent),
                                                         *filter(None, [os.environ.get("PYTHONPATH")])])}
    full.update(env or {})
    for key in [k for k, v in full.items() if v is None]:
        del full[key]
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=full, cwd=cwd, capture_output=True,
                          text=True, timeout=300)


def test_threads_then_exit_print_nothing() -> None:
    proc = _python(f"""
        import threading, numpy as np, sensorcfg
        env = sensorcfg.make_env({VISION!r}, seed=0)
        def go():
            env.reset()
            for _ in range(4):
                env.step(np.zeros(env.action_spec().shape))
        t = threading.Thread(target=go); t.start(); t.join()
        for _ in range(4):
            env.step(np.zeros(env.action_spec().shape))
        print("done")
    """, env={"MUJOCO_GL": "egl"})
    assert proc.returncode == 0 and proc.stdout.strip() == "done", proc.stderr
    assert proc.stderr == ""  # no EGLError, no "Exception ignored" at exit


# -- machines without a working GL backend -------------------------------------------------------------

# Make the named shared libraries unloadable, as on a machine that lacks them.
BLOCKER = """
import ctypes, os
_blocked = [n for n in os.environ.get("TEST_BLOCK_LIBS", "").split(",") if n]
_init = ctypes.CDLL.__init__
def _refuse(self, name, *args, **kwargs):
    if name and any(("lib" + b + ".") in os.path.basename(str(name)) for b in _blocked):
        raise OSError(f"{name}: cannot open shared object file: No such file or directory")
    _init(self, name, *args, **kwargs)
ctypes.CDLL.__init__ = _refuse
"""


def _cli(tmp: Path, *args: str, gl: dict[str, str | None]) -> subprocess.CompletedProcess:
    (tmp / "sitecustomize.py").write_text(BLOCKER)
    env = {**os.environ, **gl}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp), str(Path(sensorcfg.__file__).parent.parent)])
    env = {k: v for k, v in env.items() if v is not None}
    return subprocess.run([sys.executable, "-m", "sensorcfg", *args], env=env, capture_output=True, text=True,
                          timeout=300, cwd=tmp)


NO_GL = {
    "osmesa without libOSMesa": ({"MUJOCO_GL": "osmesa", "TEST_BLOCK_LIBS": "OSMesa", "PYOPENGL_PLATFORM": None},
                                 "sudo apt-get install libosmesa6"),
    "headless without libEGL": ({"MUJOCO_GL": None, "DISPLAY": None, "WAYLAND_DISPLAY": None,
                                 "PYOPENGL_PLATFORM": None, "TEST_BLOCK_LIBS": "EGL"},
                                "sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri"),
    "glx without a display": ({"MUJOCO_GL": "glx", "DISPLAY": None, "WAYLAND_DISPLAY": None,
                               "PYOPENGL_PLATFORM": None}, "sudo apt-get install libgl1 libglx-mesa0 libglfw3"),
    "a backend MuJoCo does not know": ({"MUJOCO_GL": "foo", "PYOPENGL_PLATFORM": None},
                                       "set MUJOCO_GL to one of egl, osmesa, glfw"),
}


def test_without_gl_everything_but_cameras_works(tmp_path: Path) -> None:
    for label, (gl, install) in NO_GL.items():
        for args in (("validate", str(CONFIGS)), ("spec", VISION), ("run", str(CONFIGS / "imu.yaml"), "--steps", "5")):
            proc = _cli(tmp_path, *args, gl=gl)
            assert proc.returncode == 0, (label, args, proc.stderr)
            assert "Traceback" not in proc.stderr, (label, proc.stderr)
        proc = _cli(tmp_path, "run", VISION, "--steps", "5", gl=gl)
        assert proc.returncode == 2, (label, proc.stderr)  # the machine lacks something, not the suite
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1, (label, proc.stderr)
        assert "cameras need OpenGL" in lines[0] and install in lines[0], (label, lines[0])


def test_without_gl_the_python_api_runs_camera_free_environments(tmp_path: Path) -> None:
    (tmp_path / "sitecustomize.py").write_text(BLOCKER)
    proc = _python(f"""
        import numpy as np, sensorcfg
        env = sensorcfg.make_env({str(CONFIGS / 'proprioception.yaml')!r}, seed=0)
        env.reset()
        for _ in range(5):
            env.step(np.zeros(env.action_spec().shape))
        try:
            sensorcfg.make_env({VISION!r}, seed=0)
        except sensorcfg.UnsupportedError as e:  # not a mistake in the suite: the machine lacks a library
            print("camera:", e)
        import os
        print("MUJOCO_GL", os.environ["MUJOCO_GL"])
    """, env={"MUJOCO_GL": "osmesa", "TEST_BLOCK_LIBS": "OSMesa",
              "PYTHONPATH": os.pathsep.join([str(tmp_path), str(Path(sensorcfg.__file__).parent.parent)])})
    assert proc.returncode == 0, proc.stderr
    assert "camera: " in proc.stdout and "sudo apt-get install libosmesa6" in proc.stdout
    assert "MUJOCO_GL osmesa" in proc.stdout  # the user's setting is kept for child processes


def test_renderers_of_ended_threads_are_closed() -> None:
    from sensorcfg.observables import camera

    env = sensorcfg.make_env(VISION, seed=0)
    reference = _run(sensorcfg.make_env(VISION, seed=0), 3)
    for _ in range(4):  # each short-lived thread renders with a renderer of its own
        out: list = []
        thread = threading.Thread(target=lambda: out.append(_run(env, 3)))
        thread.start()
        thread.join()
        _same(out[0], reference)
    pool = camera._RENDERERS[env.physics.model]
    threads = {key[2] for key in pool}
    assert len([t for t in threads if not t.is_alive()]) <= 1  # only the last thread's, closed by the next one
