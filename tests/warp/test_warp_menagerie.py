"""Held-out suites on MuJoCo Menagerie's robots, on both engines: docs/recipes' Go2 and G1 suites and the Warp
benchmark's Go2 suite, each on the robot it names, with MENAGERIE_ROOT naming a Menagerie checkout. World i of
the Warp sensor layer reads what the Updater reads on the same CPU trajectory (`test_warp_sensors.replay`):
noise-free plain reads bit for bit as float32, the rest to float32 rounding (height scans aside: this
harness feeds mjData fields; test_warp_rays compares scans).

Menagerie is not a test dependency (CI has no copy of it): without a checkout holding the robot, each case
skips and says so. The same suites run on our stand-ins (go2_like, g1_like) everywhere, in test_warp_sensors."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from conftest import ROOT, warp_or_skip  # noqa: E402

warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg.warp.support import refusals  # noqa: E402
from test_warp_sensors import replay  # noqa: E402

# (suite, the Menagerie file it runs on: None for its own `model:` line, how many worlds, control steps)
HELD_OUT = [
    ("docs/recipes/quadruped.yaml", None),
    ("docs/recipes/humanoid.yaml", None),
    ("benchmarks/suites/go2_sim2real.yaml", "unitree_go2/scene_mjx.xml"),
]


def _robot(text: str, named: str | None) -> Path:
    line = next((line for line in text.splitlines() if line.startswith("model: ")), "")
    inner = named or line.removeprefix("model: menagerie://")
    root = os.environ.get("MENAGERIE_ROOT")
    robot = Path(root or ".") / inner
    if not root or not robot.is_file():
        pytest.skip(f"MENAGERIE_ROOT does not name a Menagerie checkout with {inner}")
    return robot


@pytest.mark.parametrize("path, named", HELD_OUT, ids=[Path(p).stem for p, _ in HELD_OUT])
def test_held_out_suites_read_the_same_on_both_engines_on_menagerie_robots(path: str, named: str | None) -> None:
    text = (ROOT / path).read_text()
    robot = _robot(text, named)
    model_line = next((line for line in text.splitlines() if line.startswith("model: ")), None)
    loaded = sensorcfg.loads(text.replace(model_line, "") if model_line else text, file=Path(path).name)
    assert loaded.check(str(robot)) == []
    model = loaded.compile(str(robot), batch=True)
    built = loaded.build(model, batch=True)
    # the Warp engine runs every sensor of these suites (the model: height scans' terrain too)
    assert [(name, refusals(obs, None, model)) for name, obs in built.items() if obs.enabled and
            refusals(obs, None, model)] == []
    # this harness feeds the sensor layer mjData fields: height scans, which cast their own rays, are compared
    # on both engines by tests/warp/test_warp_rays.py
    skipped = {name for name, obs in built.items() if getattr(obs, "per_simulation", False)}

    def make() -> dict[str, Any]:
        fresh = loaded.build(model, batch=True)
        return {name: obs for name, obs in fresh.items() if obs.enabled and name not in skipped}

    substeps = loaded.updater_kwargs(model).get("physics_steps_per_control_step") or 4
    replay(make, model, 2, int(substeps), False, 10, 0)
