"""Shared fixtures: the dm_control oracle and the test models.

dm_control 1.0.50 only runs with MuJoCo 3.17.0, so differential tests skip where it is missing. The
environment that is meant to have it sets SENSORCFG_REQUIRE_ORACLE=1, and there a missing oracle is a
failure: a parity suite that silently skips proves nothing.
"""

from __future__ import annotations

import importlib
import os
import sys
import types
from pathlib import Path

import pytest

import sensorcfg  # noqa: F401  first: it picks the GL backend (EGL when headless) before mujoco is imported

# Paths every test computes from: tests sit in folders by layer (tests/config/, tests/runtime/, ...), so a test
# names the shared models and the repository through these, never through its own `__file__`.
TESTS = Path(__file__).resolve().parent
MODELS = TESTS / "models"
ROOT = TESTS.parent
# a test may import another layer's test module by name (`from test_batch import NOISE`): every layer's folder
# is importable, whichever file pytest collects first (or alone)
sys.path[len(sys.path):] = [str(p) for p in sorted(TESTS.iterdir()) if p.is_dir() and p.name.isidentifier()
                            and str(p) not in sys.path]

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


def assert_batch_equals_single(model: str, suite: object, nsim: int, seed: int, steps: int) -> None:
    """Simulation i of a BatchEnvironment equals Environment(seed=sim_seed(seed, i)) to the bit, every step
    (random actions in [-1, 1])."""
    import numpy as np

    from sensorcfg import Environment
    from sensorcfg.batch import BatchEnvironment, sim_seed

    batch = BatchEnvironment(model, suite, nsim, seed=seed)
    singles = [Environment(model, suite, seed=sim_seed(seed, i)) for i in range(nsim)]
    batch.reset()
    for env in singles:
        env.reset()
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (nsim, batch.action_spec().shape[-1]))
        out = batch.step(actions)
        for i, env in enumerate(singles):
            for name, value in env.step(actions[i]).observation.items():
                np.testing.assert_array_equal(out.observation[name][i], value, err_msg=name)


def _extra_or_skip(extra: str, modules: tuple[str, ...]) -> types.ModuleType:
    """The last of `modules` (all imported), or skip the test module; where SENSORCFG_REQUIRE_<EXTRA>=1 (the nox
    session that installs `sensorcfg[<extra>]`) a missing one fails instead."""
    try:
        return [importlib.import_module(name) for name in modules][-1]
    except ImportError as e:
        message, variable = f"sensorcfg[{extra}] is not installed: {e}", f"SENSORCFG_REQUIRE_{extra.upper()}"
        if os.environ.get(variable, "") not in ("", "0"):
            pytest.fail(f"{message} ({variable}=1 forbids skipping)", pytrace=False)
        pytest.skip(message, allow_module_level=True)


def warp_or_skip() -> types.ModuleType:
    """Warp (with MuJoCo Warp importable), or skip the module; where SENSORCFG_REQUIRE_WARP=1 (the `tests-warp`
    and `tests-mjlab` nox sessions) a missing one fails instead."""
    return _extra_or_skip("warp", ("mujoco_warp", "warp"))


def mjlab_or_skip() -> types.ModuleType:
    """mjlab, or skip the module; where SENSORCFG_REQUIRE_MJLAB=1 (the `tests-mjlab` nox session, which installs
    `sensorcfg[mjlab]`) a missing one fails instead."""
    return _extra_or_skip("mjlab", ("mjlab",))
