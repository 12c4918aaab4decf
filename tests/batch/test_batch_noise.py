"""The batch's noise stages: one explicit, read-only table of them (none registered by an import), their state
kept in the batch's own records, and its noisy samples per history row kept within a budget."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.batch.noise import BATCHED
from sensorcfg.config.noise import STAGES

from conftest import MODELS

needs_batch = pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")


def test_table_is_read_only():
    with pytest.raises(TypeError):
        BATCHED[object] = object  # type: ignore[index]


@pytest.mark.parametrize("stage", sorted(STAGES))
def test_stage_has_a_batched_form(stage):
    """The table is keyed by the plan's stage names (`NoiseStep.stage`): every stage but a custom callable has a
    batched form."""
    assert (stage in BATCHED) == (stage != "custom")


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


SHARED = ("options: {control_interval: 2}\nsensors:\n"
          "  q: {kind: qvel, element: joint:hip_f, noise: [{type: bias, std: 0.1}, {type: gaussian, std: 0.01},\n"
          "      {type: random_walk, std: 0.05, correlation_time: 0.1}, {type: lowpass, cutoff: 20Hz}]}\n"
          "  v: {kind: xpos, element: body:base, noise: [{type: scale, low: 0.9, high: 1.1},\n"
          "      {type: misalign, std: 2deg}, {type: dropout, p: 0.2, mode: hold}]}\n"
          "  w: {kind: qpos, element: joint:hip_r, interval: 2,\n"
          "      noise: [{type: gaussian, std: {uniform: [0.01, 0.05]}}]}\n")


def _steps(env: sensorcfg.Environment, actions: np.ndarray, between=lambda: None) -> list[dict[str, np.ndarray]]:
    out = [env.reset().observation]
    for a in actions:
        between()
        out.append(env.step(a).observation)
    return out


@needs_batch
def test_a_batch_never_resets_the_pipelines_of_its_observables(monkeypatch) -> None:
    """A batch's episodes start from its plan (`plan.noise.episode`), not from the observables' own pipelines: an
    Environment sharing the observables with a batch that resets and steps reads what an Environment of its own
    reads, and the batch's resets and steps reset no pipeline."""
    observables = sensorcfg.loads(SHARED).build(TERRAIN)
    shared = sensorcfg.Environment(TERRAIN, observables, seed=3)
    batch = sensorcfg.BatchEnvironment(TERRAIN, observables, 3, seed=5)
    actions = np.random.default_rng(0).uniform(-1, 1, (8, *shared.action_spec().shape))
    batch_actions = np.zeros(batch.action_spec().shape)
    batch.reset()
    got = _steps(shared, actions, lambda: (batch.reset(np.array([0, 2])), batch.step(batch_actions)))
    want = _steps(sensorcfg.Environment(TERRAIN, sensorcfg.loads(SHARED).build(TERRAIN), seed=3), actions)
    for g, w in zip(got, want):
        for name in w:
            np.testing.assert_array_equal(g[name], w[name], err_msg=name)

    from sensorcfg.noise.pipeline import NoisePipeline

    resets: list[NoisePipeline] = []
    monkeypatch.setattr(NoisePipeline, "reset", lambda self, *args, **kwargs: resets.append(self))
    batch.reset()
    batch.step(batch_actions)
    batch.reset(np.array([1]))
    assert not resets


REDRAWN = """
options: {control_interval: 3}
sensors:
  a: {kind: qpos, element: "joint:*", noise: [{type: gaussian, mean: {uniform: [-0.01, 0.01]},
      std: {uniform: [0.01, 0.05]}},
      {type: uniform, low: -0.01, high: {uniform: [0.0, 0.02]}}, {type: bias, std: {uniform: [0.0, 0.1]}},
      {type: quantize, step: {uniform: [0.001, 0.002]}}, {type: clip, min: {uniform: [-0.4, -0.2]}}]}
  b: {kind: qvel, element: "joint:*", interval: 2, noise: [{type: random_walk, std: {uniform: [0.01, 0.05]},
      correlation_time: {uniform: [0.02, 0.1]}}, {type: outlier, p: {uniform: [0.1, 0.3]}, scale: 1.0},
      {type: dropout, p: {uniform: [0.1, 0.4]}, mode: hold}]}
  c: {kind: qvel, element: "joint:elbow", interval: {uniform: [1, 3]}, noise: [{type: random_walk,
      std: {uniform: [0.01, 0.05]}}, {type: lowpass, cutoff: {uniform: [10, 40]}},
      {type: dropout, p: {uniform: [0.1, 0.4]}, mode: zero, per: value}]}
  d: {kind: xpos, element: "site:hand_site", noise: [{type: scale, low: {uniform: [0.8, 0.9]}, high: 1.1},
      {type: misalign, std: 2deg}, {type: lowpass, cutoff: {uniform: [10, 40]}}]}
"""


@needs_batch
def test_every_stage_with_parameters_drawn_per_episode_is_the_single_environments() -> None:
    """Parameters drawn per episode: each simulation's steps compute with its episode's kernel numbers
    (`plan.noise.episode`), as the single Environment's stages rebuilt at its reset, at noise levels 1 and 0.5."""
    from conftest import ROOT, assert_batch_equals_single

    robot = str(ROOT / "sensorcfg" / "assets" / "robot.xml")
    assert_batch_equals_single(robot, sensorcfg.loads(REDRAWN), nsim=3, seed=6, steps=25)
    batch = sensorcfg.BatchEnvironment(robot, sensorcfg.loads(REDRAWN), 3, seed=9)
    singles = [sensorcfg.Environment(robot, sensorcfg.loads(REDRAWN), seed=sensorcfg.batch.sim_seed(9, i))
               for i in range(3)]
    for env in (batch, *singles):
        env.set_noise_level(0.5)
    got = _steps(batch, np.zeros((12, 3, *batch.action_spec().shape[1:])))
    for i, env in enumerate(singles):
        for g, w in zip(got, _steps(env, np.zeros((12, *env.action_spec().shape)))):
            for name in w:
                np.testing.assert_array_equal(g[name][i], w[name], err_msg=name)
