"""`model: menagerie://<robot>/<file>`: a MuJoCo Menagerie robot, found through the `mujoco-menagerie` package.

The package (an optional extra, `pip install 'sensorcfg[menagerie]'`) knows every robot's folder: a
checkout named by its `MENAGERIE_ROOT`, or its own download cache. The robot is the folder's name in
Menagerie (`unitree_go2`), the rest a file inside it (`scene.xml`). Importing the package does not import
MuJoCo, so the config layer stays free of it.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

__all__ = ["MENAGERIE_SCHEME", "PACKAGE", "resolve_menagerie"]

MENAGERIE_SCHEME = "menagerie://"
PACKAGE = "mujoco-menagerie"
_FORM = f"write '{MENAGERIE_SCHEME}<robot folder>/<file>', for example '{MENAGERIE_SCHEME}unitree_go2/scene.xml'"


def _package() -> Any:
    try:
        return importlib.import_module("mujoco_menagerie")
    except ImportError:
        raise ValueError(f"a {MENAGERIE_SCHEME} model is found through the {PACKAGE!r} package, which is not "
                         f"installed: pip install {PACKAGE} (or 'sensorcfg[menagerie]'); set MENAGERIE_ROOT to a "
                         "Menagerie checkout to use it instead of the package's download cache") from None


def resolve_menagerie(value: str) -> str:
    """The path of the file `value` names; ValueError with the fix when it cannot be found."""
    robot_name, _, inner = value[len(MENAGERIE_SCHEME):].partition("/")
    if not robot_name or not inner:
        raise ValueError(f"{value!r} names no file; {_FORM}")
    menagerie = _package()
    try:
        robot = menagerie.get(robot_name)
        folder = Path(robot.path(progress=None))
    except menagerie.MenagerieError as e:  # unknown robot (with its own "did you mean"), download failed, ...
        raise ValueError(f"{PACKAGE} cannot provide {value!r}: {e}") from None
    path = folder / inner
    if not path.is_file():
        files = sorted(e.file for e in robot.entry_points)
        raise ValueError(f"{robot_name!r} has no file {inner!r} (in {folder}); its models are: {', '.join(files)}")
    return str(path)
