"""Pick an OpenGL backend before mujoco is imported: EGL when there is no display.

MuJoCo reads MUJOCO_GL once, at import. On a headless machine (no DISPLAY or WAYLAND_DISPLAY, not macOS
or Windows) GLFW cannot open a context, while Mesa's EGL renders offscreen without a GPU. A value the
user set is never overridden.
"""

import os
import sys


def choose_gl_backend() -> None:
    if "MUJOCO_GL" in os.environ or sys.platform in ("darwin", "win32"):
        return
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return
    os.environ["MUJOCO_GL"] = "egl"
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
