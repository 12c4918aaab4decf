"""benchmarks/warp.py runs (for correctness only: `--quick` on Warp's CPU device checks every observation
against the spec and for finite values; no timing is asserted), and its suites are ones the Warp engine runs."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from sensorcfg.warp.support import LINE  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = ROOT / "benchmarks"


def test_quick_run_checks_the_go2_suite_and_prints_the_table() -> None:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    done = subprocess.run([sys.executable, str(BENCHMARKS / "warp.py"), "--quick", "--models", "go2"], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=1800)
    if LINE == "3.11":  # MuJoCo Warp 3.11 itself refuses the Go2 stand-in (MULTICCD with geom margins): said so
        assert done.returncode != 0 and "MuJoCo Warp 3.11.0 cannot run this model: geom pair" in done.stderr
        return
    assert done.returncode == 0, done.stdout + done.stderr
    assert "quick: every observation matched its spec" in done.stdout
    table = done.stdout.splitlines()
    header = next(i for i, line in enumerate(table) if line.startswith("model"))
    row = table[header + 1].split()
    assert row[:2] == ["go2", "2"] and len(row) == 8  # steady and restarting: physics, with suite, overhead
    assert all(float(x) > 0 for x in row[2:4] + row[5:7])
    assert "CUDA graphs: none on the CPU device" in done.stdout  # the table says how it was timed


def _humanoid_offline() -> object | None:
    """dm_control's humanoid as an MjSpec when it can be had without a network, else None."""
    spec = importlib.util.spec_from_file_location("_humanoid", BENCHMARKS / "_humanoid.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    cache = Path(__import__("tempfile").gettempdir()) / "sensorcfg-bench-dmcontrol"
    if importlib.util.find_spec("dm_control") is None and not list(cache.glob("dm_control-*.whl")):
        return None
    import mujoco

    xml, assets = module.humanoid_xml()
    return mujoco.MjSpec.from_string(xml, assets)


def test_the_humanoid_suite_binds_and_the_warp_engine_takes_it() -> None:
    model = _humanoid_offline()
    if model is None:
        pytest.skip("dm_control's humanoid is not available offline (dm_control, or its wheel in the cache)")
    env = WarpEnvironment(model, str(BENCHMARKS / "suites" / "humanoid_sim2real.yaml"), 1, device="cpu",
                          physics_steps_per_control_step=4, seed=0)
    spec = env.observation_spec()
    assert len(spec) == 39 and "last_action" in spec and "last_action_clean" not in spec
