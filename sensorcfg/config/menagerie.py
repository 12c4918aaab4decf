"""`model: menagerie://<robot>/<file>`: a MuJoCo Menagerie robot, found through the `mujoco-menagerie` package.

The package (`pip install mujoco-menagerie`, or the `menagerie` extra from a clone: `pip install '.[menagerie]'`)
knows every robot's folder: a checkout named by its `MENAGERIE_ROOT`, or its own download cache. The robot is
the folder's name in Menagerie (`unitree_go2`), the rest a file inside it (`scene.xml`); `files.py` keeps the
file inside that folder. Importing the package does not import MuJoCo, so the config layer stays free of it.
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path
from typing import Any

from ..errors import install_hint

__all__ = ["MENAGERIE_SCHEME", "PACKAGE", "menagerie_file", "menagerie_missing"]

MENAGERIE_SCHEME = "menagerie://"
PACKAGE = "mujoco-menagerie"
_FORM = f"write '{MENAGERIE_SCHEME}<robot folder>/<file>', for example '{MENAGERIE_SCHEME}unitree_go2/scene.xml'"
_OFFLINE = ("; without a network, set MENAGERIE_ROOT to a Menagerie checkout "
            "(git clone https://github.com/google-deepmind/mujoco_menagerie)")


def _package(robot_name: str, inner: str) -> Any:
    try:
        return importlib.import_module("mujoco_menagerie")
    except ImportError:
        raise ValueError(_not_installed(robot_name, inner)) from None


def _not_installed(robot_name: str, inner: str) -> str:
    """Why the package is needed, with what MENAGERIE_ROOT holds of the robot: the package is what reads
    MENAGERIE_ROOT, so setting it is the fix only while it is unset."""
    found = f"a {MENAGERIE_SCHEME} model is found through the {PACKAGE!r} package"
    install = install_hint("menagerie", PACKAGE)
    root = os.environ.get("MENAGERIE_ROOT")
    if not root:
        return (f"{found}, which is not installed: {install}; set MENAGERIE_ROOT to a Menagerie checkout to use "
                "it instead of the package's download cache")
    folder = Path(root) / robot_name
    if not folder.is_dir():
        missing = f"; MENAGERIE_ROOT ({root}) has no folder {robot_name!r} either: point it at a Menagerie checkout"
    elif not (folder / inner).is_file():
        missing = f"; {folder} has no file {inner!r} either"
    else:
        return (f"{found}, which reads MENAGERIE_ROOT ({root}, where {robot_name}/{inner} is) but is not installed: "
                f"{install}")
    return f"{found}, which reads MENAGERIE_ROOT but is not installed: {install}{missing}"


def menagerie_file(value: str) -> tuple[Path, Path]:
    """The robot's folder and the file `value` names in it (not yet checked to stay inside it, or to exist);
    ValueError with the fix when the robot cannot be found."""
    robot_name, _, inner = value[len(MENAGERIE_SCHEME):].partition("/")
    if not robot_name or not inner:
        raise ValueError(f"{value!r} names no file; {_FORM}")
    menagerie = _package(robot_name, inner)
    try:
        folder = Path(menagerie.get(robot_name).path(progress=None))
    except menagerie.DownloadError as e:  # offline, or a download that failed: a checkout works without one
        hint = "" if os.environ.get("MENAGERIE_ROOT") else _OFFLINE
        raise ValueError(f"{PACKAGE} cannot provide {value!r}: {e}{hint}") from None
    except menagerie.MenagerieError as e:  # unknown robot (with its own "did you mean"), ...
        raise ValueError(f"{PACKAGE} cannot provide {value!r}: {e}") from None
    return folder, folder / inner


def menagerie_missing(value: str, folder: Path) -> str:
    """Why `value` names no file of its robot, with the robot's models."""
    robot_name, _, inner = value[len(MENAGERIE_SCHEME):].partition("/")
    files = sorted(e.file for e in _package(robot_name, inner).get(robot_name).entry_points)
    return f"{robot_name!r} has no file {inner!r} (in {folder}); its models are: {', '.join(files)}"
