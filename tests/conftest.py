"""Shared fixtures: the dm_control oracle and the test models.

dm_control 1.0.50 only runs with MuJoCo 3.17.0, so differential tests skip where it is missing. The
environment that is meant to have it sets SENSORCFG_REQUIRE_ORACLE=1, and there a missing oracle is a
failure: a parity suite that silently skips proves nothing.
"""

from __future__ import annotations

import importlib
import os
import types
from pathlib import Path

import pytest

import sensorcfg  # noqa: F401  first: it picks the GL backend (EGL when headless) before mujoco is imported

MODELS = Path(__file__).parent / "models"

_ORACLE_MODULES = {
    "mjcf": "dm_control.mjcf",
    "updater": "dm_control.composer.observation.updater",
    "observable": "dm_control.composer.observation.observable",
    "variation": "dm_control.composer.variation",
    "distributions": "dm_control.composer.variation.distributions",
}


def oracle_required() -> bool:
    return os.environ.get("SENSORCFG_REQUIRE_ORACLE", "") not in ("", "0")


def import_oracle() -> types.SimpleNamespace:
    """dm_control's modules, or skip (fail when SENSORCFG_REQUIRE_ORACLE=1) if dm_control is missing."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        modules = {key: importlib.import_module(name) for key, name in _ORACLE_MODULES.items()}
    except Exception as e:  # ImportError, or dm_control failing against an unsupported MuJoCo
        message = f"dm_control oracle unavailable: {type(e).__name__}: {e}"
        if oracle_required():
            pytest.fail(f"{message} (SENSORCFG_REQUIRE_ORACLE=1 forbids skipping)", pytrace=False)
        pytest.skip(message)
    return types.SimpleNamespace(**modules)


@pytest.fixture(scope="session")
def oracle() -> types.SimpleNamespace:
    return import_oracle()
