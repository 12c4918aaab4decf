"""The batch's noise stages: one explicit, read-only table of them (none registered by an import), their state
kept in the batch's own records, and its noisy samples per history row kept within a budget."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.batch.noise import BATCHED
from sensorcfg.noise.level import Blend, Keep
from sensorcfg.noise.misalign import Misalign
from sensorcfg.noise.redrawn import Redrawn

from conftest import MODELS

needs_batch = pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")


def test_table_is_read_only():
    with pytest.raises(TypeError):
        BATCHED[object] = object  # type: ignore[index]


@pytest.mark.parametrize("stage", [Keep, Blend, Misalign, Redrawn])
def test_stage_has_a_batched_form(stage):
    """The table names the batched forms of stages defined outside `noise.stages` itself."""
    assert stage in BATCHED


TERRAIN = str(MODELS / "terrain.xml")
LEVELED = ("options: {control_interval: 5, strip_singleton_buffer_dim: true}\nsensors:\n"
           "  noisy: {kind: qvel, element: joint:hip_f, noise: [{type: gaussian, std: 0.05}, {type: lowpass, cutoff: 20Hz}]}\n"
           "  added: {kind: qvel, element: joint:hip_f, noise: [{type: gaussian, std: 0.05}]}\n"
           "  clean: {kind: qvel, element: joint:hip_f}\n")


@needs_batch
def test_batches_sharing_observables_keep_their_own_levels() -> None:
    """A batch's noise levels live in its own stages: a second batch built over the same observables (their
    noise stages shared) leaves the first one's level-0 episodes clean."""
    observables = sensorcfg.loads(LEVELED).build(TERRAIN)
    first = sensorcfg.BatchEnvironment(TERRAIN, observables, 2, seed=0)
    first.set_noise_level(0.0)
    first.reset()
    sensorcfg.BatchEnvironment(TERRAIN, observables, 2, seed=1)
    for _ in range(3):
        obs = first.step(np.full(first.action_spec().shape, 0.3)).observation
        np.testing.assert_array_equal(obs["noisy"], obs["clean"])
        np.testing.assert_array_equal(obs["added"], obs["clean"])


HISTORY_NOISE = ("options: {control_interval: 5, strip_singleton_buffer_dim: true}\nsensors:\n"
                 "  a: {kind: qvel, element: joint:hip_f, interval: 3, delay: 2, noise: [{type: lowpass, cutoff: 20Hz}]}\n"
                 "  b: {kind: qpos, element: joint:hip_f, interval: 2, noise: [{type: random_walk, std: 0.1}]}\n")


def _noisy_run(env: sensorcfg.BatchEnvironment) -> list[dict[str, np.ndarray]]:
    out = [env.reset().observation]
    for _ in range(30):
        out.append(env.step(np.full(env.action_spec().shape, 0.3)).observation)
    return out


@needs_batch
def test_noisy_samples_are_kept_within_their_budget() -> None:
    """The batch's noisy samples per history row are a bounded cache: with no budget none is kept, and every value
    stays what it is when they are kept."""
    want = _noisy_run(sensorcfg.BatchEnvironment(TERRAIN, sensorcfg.loads(HISTORY_NOISE), 3, seed=2))
    env = sensorcfg.BatchEnvironment(TERRAIN, sensorcfg.loads(HISTORY_NOISE), 3, seed=2)
    env._updater._noisy_by_row.budget = 0
    got = _noisy_run(env)
    assert len(env._updater._noisy_by_row) == 0
    for g, w in zip(got, want):
        for name in w:
            np.testing.assert_array_equal(g[name], w[name], err_msg=name)
