"""examples/several_gpus.py under torchrun: two processes on Warp's CPU device (gloo) together produce exactly
the worlds of one environment of all of them: every observation group, done and time-out, bit for bit, over
episodes that end and restart in the same step."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, warp_or_skip  # noqa: E402

wp = warp_or_skip()
pytest.importorskip("torch")
pytest.importorskip("rsl_rl")

EXAMPLE = ROOT / "examples" / "several_gpus.py"
SUITE = str(ROOT / "configs" / "training.yaml")
WORLDS, STEPS, SEED, TIME_LIMIT = 2, 10, 3, 0.1  # 5 control steps of 20 ms per episode


def test_two_processes_make_the_worlds_of_one_environment(tmp_path) -> None:
    out = tmp_path / "rollout.npz"
    command = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc-per-node", "2", str(EXAMPLE),
               SUITE, "--device", "cpu", "--worlds", str(WORLDS), "--seed", str(SEED), "--time-limit",
               str(TIME_LIMIT), "--rollout", str(STEPS), "--out", str(out)]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    spec = importlib.util.spec_from_file_location("several_gpus", EXAMPLE)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    whole = example.rollout(example.make_env(SUITE, 2 * WORLDS, 0, "cpu", SEED, TIME_LIMIT), STEPS)
    parts = dict(np.load(out))
    assert sorted(parts) == sorted(whole) == ["critic", "dones", "policy", "time_outs"]
    for name, array in whole.items():
        assert parts[name].shape == array.shape and parts[name].tobytes() == array.tobytes(), name
    assert whole["dones"].sum() >= 2 * 2 * WORLDS and whole["time_outs"].sum() == whole["dones"].sum()
    assert not np.array_equal(whole["policy"][:, 0], whole["policy"][:, WORLDS])  # each world its own noise
