"""A differential fuzz of the CPU engines: random suites, as users write them, read the same everywhere.

Each seed draws a random suite as YAML text (`sensorcfg.loads`: the loader, validation and binding a user's file
goes through) on the bundled robot: 2-6 sensors of varied kinds (mjData fields, fields MuJoCo computes on demand,
MuJoCo sensor kinds the suite compiles into the model, `index`, `within`), fixed intervals and delays (steps,
durations, rates) and drawn ones (`{uniform: [a, b]}`, `{choice: [...], p: [...]}`), buffers 1-4, every built-in
aggregator, and chains of noise stages from every stage type (parameters drawn per episode where the config
allows, runs of adjacent additive stages, which fuse, misalign on 3-vectors), 1-5 physics steps per control
step, and 2-3 episodes of 40-80 control steps of random actions, some at a noise level (`set_noise_level`).

- (a) the single-simulation Updater with its feature banks (`runtime/bank.py`'s `FeatureBank`,
  `runtime/planned.py`'s `DrawnBank`, their noise `runtime/bank_noise.py`) and the same Updater with both turned
  off (every sensor a per-sample channel, `runtime/channels.py`: the reference), `pad_with_initial_value` both
  ways;
- (b) `BatchEnvironment(nsim=3)` against `Environment(seed=sim_seed(seed, i))` per simulation (draws the batch
  refuses with a SuiteError are skipped; `test_the_draws_reach_every_path` asserts that most run).

Every observation of every control step is compared bit for bit (NaN equal to NaN: a dropout's; signed zeros
told apart). `SENSORCFG_FUZZ_SEEDS=200` (or `a:b`) runs that many seeds instead of the CI-sized set.
"""

from __future__ import annotations

import json
import os
from typing import Any, NamedTuple

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError, assets
from sensorcfg.runtime import updater as updater_module

from fuzz_suites import ADDITIVE, KINDS, STAGES, Draws, suite_text

ROBOT = str(assets.path("robot.xml"))
MODEL = mujoco.MjModel.from_xml_path(ROBOT)
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4


def _seeds() -> list[int]:
    chosen = os.environ.get("SENSORCFG_FUZZ_SEEDS")
    if not chosen:
        return list(range(16))
    if ":" in chosen:
        first, stop = (int(x) for x in chosen.split(":"))
        return list(range(first, stop))
    return list(range(int(chosen)))


SEEDS = _seeds()


class Draw(NamedTuple):
    """A fuzzed run: the suite's sensors and options (`text`, `pad_with_initial_value` as given) and its run."""

    sensors: dict[str, Any]
    substeps: int
    pad: bool
    strip: bool  # strip_singleton_buffer_dim
    episodes: tuple[int, ...]  # control steps per episode
    levels: tuple[float | None, ...]  # the noise level set before each episode's reset (None: left as it is)

    def text(self, pad: bool | None = None) -> str:
        options = {"control_interval": f"{2 * self.substeps}ms",
                   "pad_with_initial_value": self.pad if pad is None else pad, "strip_singleton_buffer_dim": self.strip}
        return suite_text(self.sensors, options)


def draw(seed: int) -> Draw:
    draws = Draws(np.random.default_rng([seed, 2026]))
    rng = draws.rng
    strip = bool(rng.random() < 0.2)
    sensors = draws.sensors(KINDS, strip)
    episodes = tuple(int(rng.integers(40, 81)) for _ in range(int(rng.integers(2, 4))))
    levels = tuple(None if rng.random() < 0.75 else float(rng.choice([0.0, 0.5, 1.0, round(float(rng.random()), 3)]))
                   for _ in episodes)
    return Draw(sensors, int(rng.integers(1, 6)), bool(rng.random() < 0.5), strip, episodes, levels)


def _copy(observation: dict[str, Any]) -> dict[str, np.ndarray]:
    return {k: np.array(v, copy=True) for k, v in observation.items()}


def _actions(seed: int, steps: int, shape: tuple[int, ...]) -> np.ndarray:
    lo, hi = MODEL.actuator_ctrlrange.T
    return np.random.default_rng([seed, 7]).uniform(lo, hi, (steps, *shape, MODEL.nu))


def assert_same(got: np.ndarray, want: np.ndarray, where: str) -> None:
    """Bit for bit but for NaN payloads: shape, dtype, values (NaN equal to NaN) and the sign of every zero."""
    got, want = np.asarray(got), np.asarray(want)
    assert (got.shape, got.dtype) == (want.shape, want.dtype), where
    np.testing.assert_array_equal(got, want, err_msg=where, strict=True)
    numbers = ~np.isnan(want) if want.dtype.kind == "f" else np.ones(want.shape, bool)
    assert (np.signbit(got) == np.signbit(want))[numbers].all(), f"{where}: the signs of zeros differ"


def run_episodes(env: Any, run: Draw, actions: np.ndarray) -> list[dict[str, np.ndarray]]:
    """Every observation (copied) of `env`, an Environment or a BatchEnvironment, over the draw's episodes (resets
    included, each after the episode's noise level), stepping `actions[t]` at the run's control step t."""
    out, t = [], 0
    for steps, level in zip(run.episodes, run.levels):
        if level is not None:
            env.set_noise_level(level)
        out.append(_copy(env.reset().observation))
        for _ in range(steps):
            out.append(_copy(env.step(actions[t]).observation))
            t += 1
    return out


def run_single(run: Draw, pad: bool, seed: int) -> tuple[list[dict[str, np.ndarray]], sensorcfg.Environment]:
    """Every observation of an Environment over the draw's episodes (resets included)."""
    env = sensorcfg.Environment(ROBOT, sensorcfg.loads(run.text(pad)), seed=seed)
    assert env.updater.physics_steps_per_control_step == run.substeps
    return run_episodes(env, run, _actions(seed, sum(run.episodes), ())), env


class Banks(NamedTuple):
    """Which of an Updater's banks ran at its last reset, and whether the fixed one ran noise."""

    fixed: bool
    drawn: bool
    noise: bool


def banks(env: sensorcfg.Environment) -> Banks:
    updater = env.updater
    fixed, drawn = updater._bank, updater._drawn
    return Banks(fixed is not None, drawn is not None, fixed is not None and fixed.noise is not None)


def run_per_sample(run: Draw, pad: bool, seed: int,
                   monkeypatch: pytest.MonkeyPatch) -> tuple[list[dict[str, np.ndarray]], sensorcfg.Environment]:
    """`run_single` with the Updater's banks turned off: every sensor a per-sample channel."""
    with monkeypatch.context() as patch:
        patch.setattr(updater_module.Updater, "_make_bank", lambda self, physics: None)
        patch.setattr(updater_module.Updater, "_make_drawn_bank", lambda self, physics: None)
        out, env = run_single(run, pad, seed)
    assert banks(env) == Banks(False, False, False)
    return out, env


# -- (a) the banks against the per-sample channels ---------------------------------------------------


@pytest.mark.parametrize("pad", [False, True], ids=["zeros", "initial"])
@pytest.mark.parametrize("seed", SEEDS)
def test_the_banks_read_what_the_per_sample_channels_read(seed: int, pad: bool,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    run = draw(seed)
    banked, _ = run_single(run, pad, seed)
    reference, _ = run_per_sample(run, pad, seed, monkeypatch)
    assert len(banked) == len(reference) == sum(run.episodes) + len(run.episodes)
    for t, (a, b) in enumerate(zip(banked, reference)):
        assert a.keys() == b.keys()
        for name in a:
            assert_same(a[name], b[name], f"seed {seed} read {t} {name}: {run.sensors[name]}")


# -- (b) each simulation of a batch against its single Environment -----------------------------------


def _batch(run: Draw, seed: int) -> Any:
    """The draw's BatchEnvironment of 3 simulations, or None where the batch refuses the suite."""
    try:
        return sensorcfg.BatchEnvironment(ROBOT, sensorcfg.loads(run.text()), 3, seed=seed)
    except SuiteError as e:
        if "vectorise" not in str(e) and "cannot" not in str(e):  # only what a batch cannot run is skipped
            raise
        return None


@pytest.mark.skipif(not MUJOCO4, reason=f"mujoco.batch needs MuJoCo 4; this is {mujoco.__version__}")
@pytest.mark.parametrize("seed", SEEDS)
def test_each_simulation_of_a_batch_reads_what_its_environment_reads(seed: int) -> None:
    from sensorcfg.batch import sim_seed

    run = draw(seed)
    batch = _batch(run, seed)
    if batch is None:
        pytest.skip("the batch refuses this draw")
    nsim = batch.nsim
    actions = _actions(seed, sum(run.episodes), (nsim,))
    got = run_episodes(batch, run, actions)
    for i in range(nsim):
        env = sensorcfg.Environment(ROBOT, sensorcfg.loads(run.text()), seed=sim_seed(seed, i))
        for k, obs in enumerate(run_episodes(env, run, actions[:, i])):
            assert obs.keys() == got[k].keys()
            for name, value in obs.items():
                assert_same(got[k][name][i], value, f"seed {seed} sim {i} read {k} {name}: {run.sensors[name]}")


# -- the draws reach what they are meant to ----------------------------------------------------------


def test_the_draws_reach_every_path() -> None:
    """Over the seeds: the banks run (fixed, drawn, with noise), noise levels are set, and most draws run in a
    batch; the draws cover every stage type, drawn parameters, fused runs, misalign and drawn schedules."""
    reached: dict[str, int] = {}

    def count(key: str, hit: bool = True) -> None:
        reached[key] = reached.get(key, 0) + int(bool(hit))

    for seed in SEEDS:
        run = draw(seed)
        env = sensorcfg.Environment(ROBOT, sensorcfg.loads(run.text()), seed=seed)
        env.reset()
        for key, hit in banks(env)._asdict().items():
            count(f"bank {key}", hit)
        count("level", any(level is not None for level in run.levels))
        text = run.text()
        for word in (*STAGES, "misalign", "density", '"choice"', "correlation_time", '"per"', '"p"'):
            count(word, word in text)
        for sensor in run.sensors.values():
            stages = [s["type"] for s in sensor.get("noise", ())]
            count("fused", any(a in ADDITIVE and b in ADDITIVE for a, b in zip(stages, stages[1:])))
            count("drawn parameter", any("uniform" in json.dumps(v) for s in sensor.get("noise", ())
                                         for k, v in s.items() if k != "type"))
            count("drawn schedule", isinstance(sensor.get("interval"), dict) or isinstance(sensor.get("delay"), dict))
        if MUJOCO4:
            batch = _batch(run, seed)
            count("batch", batch is not None)
            if batch is not None:
                batch.close()
    few = max(1, len(SEEDS) // 8)
    assert all(reached.get(k, 0) >= few for k in ("bank fixed", "bank drawn", "bank noise", "level", "fused",
                                                  "drawn parameter", "drawn schedule")), reached
    assert all(reached.get(k, 0) >= 1 for k in (*STAGES, "misalign", "density", '"choice"')), reached
    if MUJOCO4:
        assert reached["batch"] >= 0.7 * len(SEEDS), reached
