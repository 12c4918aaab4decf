"""OpenGL for cameras: render headless without changing the process's environment, survive a backend that
cannot load, and say what to install when a camera needs it.

MuJoCo reads MUJOCO_GL once, at import. On a headless machine (no DISPLAY or WAYLAND_DISPLAY, not macOS
or Windows) GLFW cannot open a context, while Mesa's EGL renders offscreen without a GPU. So where
MUJOCO_GL is unset there, a camera renders with EGL (`backend`: "egl"; the camera points mujoco's Renderer
at EGL's context class when it makes its first renderer), and importing sensorcfg leaves MUJOCO_GL and
PYOPENGL_PLATFORM as they were: another library in the process, or a child process, still sees the user's
environment. A value the user set is what renders.

A backend whose library is missing (MUJOCO_GL=osmesa without libOSMesa, for one) makes `import mujoco`
itself raise, which would take every command down, `validate` included. sensorcfg then imports mujoco
with its GL disabled (restoring MUJOCO_GL for child processes) and remembers why: everything that needs no
camera works, and the first camera raises a SuiteError naming the packages to install (`gl_error`).

A frame leaves the thread's GL state as it found it (`current_restored`): no context of ours stays current,
so a renderer made in one thread can be used, and closed, in another, and a dm_control renderer in the same
thread finds its own context current again.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import Any

__all__ = ["backend", "current_restored", "gl_error", "import_mujoco", "GL_PACKAGES"]

# backend -> what a Debian/Ubuntu machine needs for it (docs/sensors.md, "Cameras")
GL_PACKAGES: dict[str, str] = {
    "egl": "libegl1 libegl-mesa0 libgl1-mesa-dri",
    "osmesa": "libosmesa6",
    "glfw": "libgl1 libglx-mesa0 libglfw3",
}
_ALIASES = {"glx": "glfw", "": "glfw", "enable": "glfw", "enabled": "glfw", "on": "glfw", "true": "glfw",
            "1": "glfw"}

import_failure: str | None = None  # why `import mujoco` failed with the user's MUJOCO_GL, if it did


def import_mujoco() -> None:
    """Import mujoco; if its GL backend breaks the import, import it again with GL disabled."""
    global import_failure
    if "mujoco" in sys.modules:
        return
    try:
        import mujoco  # noqa: F401
    except ImportError:
        raise  # mujoco itself is missing: that error is the right one
    except Exception as e:  # noqa: BLE001 - the GL backend's import failed in its own way (AttributeError, ...)
        import_failure = f"{type(e).__name__}: {e}"
        saved = {key: os.environ.get(key) for key in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
        os.environ["MUJOCO_GL"] = "disable"
        try:
            import mujoco  # noqa: F401
        finally:
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value


def _headless() -> bool:
    return sys.platform not in ("darwin", "win32") and not (os.environ.get("DISPLAY")
                                                            or os.environ.get("WAYLAND_DISPLAY"))


def backend() -> str:
    """The backend a camera renders with: the user's MUJOCO_GL, or EGL where it is unset on a headless machine."""
    if "MUJOCO_GL" not in os.environ and _headless():
        return "egl"
    value = os.environ.get("MUJOCO_GL", "").strip().lower()
    return _ALIASES.get(value, value)


def gl_error(cause: BaseException | None = None) -> str:
    """One line: cameras cannot render here, why, and what to install."""
    name = backend()
    why = import_failure or (f"{type(cause).__name__}: {cause}" if cause is not None else "unknown")
    why = " ".join(why.split())
    if len(why) > 160:
        why = why[:157] + "..."
    packages = GL_PACKAGES.get(name)
    fix = f"set MUJOCO_GL to one of {', '.join(GL_PACKAGES)}"
    if packages:
        fix = f"on Debian/Ubuntu: sudo apt-get install {packages}"
        if name == "glfw":
            fix += ", and run with a display (headless: MUJOCO_GL=egl)"
    return (f"cameras need OpenGL, and MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!s} cannot render here ({why}); "
            f"{fix}; suites without cameras run without it")


def _kind(context_class: type) -> str:
    """'egl', 'osmesa' or 'glfw': which of mujoco's GL context classes `context_class` is (or derives from)."""
    for cls in context_class.__mro__:
        for kind in ("egl", "osmesa", "glfw"):
            if cls.__module__.startswith(f"mujoco.{kind}"):
                return kind
    return ""


@contextlib.contextmanager
def current_restored(context_class: type) -> Iterator[None]:
    """Whatever GL context this thread has current on entry is current again on exit (none: none).

    A frame makes our renderer's context current; other GL users in the thread (dm_control's renderer,
    which remembers its context as current) must find theirs again, and a thread must not keep ours
    current, so that another thread may use or close it.
    """
    kind = _kind(context_class)
    if kind == "egl":
        from mujoco import egl

        gl = egl.EGL
        before = (gl.eglGetCurrentDisplay(), gl.eglGetCurrentSurface(gl.EGL_DRAW), gl.eglGetCurrentSurface(gl.EGL_READ),
                  gl.eglGetCurrentContext())
        try:
            yield
        finally:
            if before[3]:
                gl.eglMakeCurrent(*before)
            elif egl.EGL_DISPLAY is not None:
                gl.eglMakeCurrent(egl.EGL_DISPLAY, gl.EGL_NO_SURFACE, gl.EGL_NO_SURFACE, gl.EGL_NO_CONTEXT)
    elif kind == "glfw":
        import glfw

        window = glfw.get_current_context()
        try:
            yield
        finally:
            glfw.make_context_current(window)
    elif kind == "osmesa":
        from mujoco import osmesa as mj_osmesa
        from OpenGL import GL, osmesa

        local: Any = getattr(mj_osmesa, "_current_context", None)
        ref = getattr(local, "ref", None)
        previous: Any = ref() if ref is not None else None
        had: Any = osmesa.OSMesaGetCurrentContext()
        try:
            yield
        finally:
            if had and previous is not None and previous._context and previous._context.address == had.address:
                previous.make_current()
            else:
                osmesa.OSMesaMakeCurrent(None, None, GL.GL_FLOAT, 0, 0)
                if local is not None:
                    local.ref = None
    else:
        yield
