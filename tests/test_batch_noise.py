"""The batch's table of noise stages: one explicit, read-only table (no stage is registered by an import)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sensorcfg.batch.noise import BATCHED
from sensorcfg.noise.level import Blend, Keep
from sensorcfg.noise.misalign import Misalign
from sensorcfg.noise.redrawn import Redrawn


def test_table_is_read_only():
    with pytest.raises(TypeError):
        BATCHED[object] = object  # type: ignore[index]


def test_table_is_whole_without_importing_the_stage_modules():
    """The table names every batched form itself: importing the noise module alone gives all of them."""
    code = ("import sys, importlib; m = importlib.import_module('sensorcfg.batch.noise'); "
            "from sensorcfg.noise.level import Blend, Keep; from sensorcfg.noise.misalign import Misalign; "
            "from sensorcfg.noise.redrawn import Redrawn; "
            "print(all(t in m.BATCHED for t in (Blend, Keep, Misalign, Redrawn)))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"


@pytest.mark.parametrize("stage", [Keep, Blend, Misalign, Redrawn])
def test_stage_has_a_batched_form(stage):
    assert stage in BATCHED
