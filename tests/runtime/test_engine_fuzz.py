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

ROBOT = str(assets.path("robot.xml"))
MODEL = mujoco.MjModel.from_xml_path(ROBOT)
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4

# (kind, element, extra keys, whether its values are 3-vectors: misalign turns them)
KINDS: list[tuple[str, Any, dict[str, Any], bool]] = [
    ("qpos", ["joint:shoulder", "joint:elbow"], {}, False),
    ("qpos", "joint:wrist", {}, False),
    ("qvel", "joint:elbow", {}, False),
    ("qvel", "joint:wrist", {}, True),
    ("qacc", ["joint:shoulder", "joint:finger_slide"], {}, False),
    ("qfrc_actuator", ["joint:shoulder", "joint:elbow"], {}, False),
    ("xpos", "site:hand_site", {}, True),
    ("xpos", ["site:hand_site", "site:imu"], {}, True),
    ("xpos", "body:hand", {}, True),
    ("xquat", "body:hand", {}, False),
    ("xmat", "body:forearm", {}, False),  # (9,): no 3-vector axis
    ("cvel", "body:forearm", {}, False),  # (6,): no 3-vector axis
    ("cacc", "body:hand", {}, False),  # computed on demand
    ("cfrc_int", "body:forearm", {}, False),  # computed on demand
    ("sensordata", "sensor:imu_gyro", {}, True),
    ("sensordata", "sensor:imu_accel", {}, True),
    ("sensordata", ["sensor:shoulder_pos", "sensor:elbow_pos"], {}, False),
    ("force", "actuator:*", {}, True),
    ("ctrl", ["actuator:shoulder_motor", "actuator:elbow_motor"], {}, False),
    ("gyro", "site:imu", {}, True),
    ("accelerometer", "site:hand_site", {}, True),
    ("velocimeter", "site:imu", {}, True),
    ("framepos", "site:fingertip", {"frame": "body:base"}, True),
    ("framequat", "body:hand", {}, False),
    ("jointpos", "joint:elbow", {}, False),
    ("gravity", "site:imu", {}, True),
    ("subtreecom", "body:upper_arm", {}, True),
    ("subtreelinvel", "body:upper_arm", {}, True),
    ("xpos", "body:hand", {"index": 2}, False),
    ("xpos", ["site:hand_site", "site:imu", "site:fingertip"], {"index": "0:2"}, True),
    ("qvel", "joint:*", {"within": "body:upper_arm", "index": [0, 2]}, False),
]
AGGREGATORS = [None, None, "mean", "sum", "max", "min", "median"]
ADDITIVE = ("gaussian", "uniform", "outlier", "random_walk", "bias")  # adjacent additive stages fuse into one sum
STAGES = ("gaussian", "uniform", "outlier", "bias", "scale", "random_walk", "quantize", "clip", "lowpass",
          "dropout")


def _seeds() -> list[int]:
    chosen = os.environ.get("SENSORCFG_FUZZ_SEEDS")
    if not chosen:
        return list(range(16))
    if ":" in chosen:
        first, stop = (int(x) for x in chosen.split(":"))
        return list(range(first, stop))
    return list(range(int(chosen)))


SEEDS = _seeds()


def _number(rng: np.random.Generator, low: float, high: float, drawn: float = 0.25) -> Any:
    """A parameter in [low, high], drawn per episode (`{uniform: [a, b]}`) with probability `drawn`."""
    if rng.random() < drawn:
        a, b = sorted(rng.uniform(low, high, 2).round(4).tolist())
        return {"uniform": [a, b]}
    return round(float(rng.uniform(low, high)), 4)


def _stage(rng: np.random.Generator, kind: str, fixed: bool) -> dict[str, Any]:
    """One noise stage of type `kind` with random parameters (some drawn per episode); `fixed`: the sensor's
    interval is constant (a noise density needs one)."""
    n = lambda low, high: _number(rng, low, high)  # noqa: E731
    if kind == "gaussian":
        out: dict[str, Any] = ({"std": n(0.001, 0.05)} if not fixed or rng.random() < 0.8
                               else {"density": n(0.0005, 0.002)})
        if rng.random() < 0.3:
            out["mean"] = n(-0.01, 0.01)
    elif kind == "uniform":  # the two ends' ranges never cross
        out = {"low": n(-0.05, -0.01), "high": n(0.01, 0.05)}
    elif kind == "bias":
        out = {"std": n(0.01, 0.2)} if rng.random() < 0.6 else {"low": n(-0.2, -0.1), "high": n(0.1, 0.2)}
        if "std" in out and rng.random() < 0.3:
            out["mean"] = n(-0.05, 0.05)
    elif kind == "scale":
        out = {"low": n(0.8, 0.95), "high": n(1.05, 1.2)} if rng.random() < 0.5 else \
            {"mean": n(0.95, 1.05), "std": n(0.0, 0.05)}
    elif kind == "random_walk":
        out = {"std": n(0.001, 0.05)}
        if rng.random() < 0.6:
            out["correlation_time"] = f"{int(rng.integers(5, 200))}ms" if rng.random() < 0.5 else n(0.005, 0.2)
    elif kind == "quantize":
        out = {"step": n(0.0005, 0.01)}
    elif kind == "clip":
        out = {"min": n(-1.0, -0.2), "max": n(0.2, 1.0)}
        if rng.random() < 0.3:
            out.pop(str(rng.choice(["min", "max"])))
    elif kind == "dropout":
        out = {"p": n(0.05, 0.6), "mode": str(rng.choice(["hold", "zero", "nan"]))}
        if rng.random() < 0.4:
            out["per"] = "value"
    elif kind == "outlier":
        out = {"p": n(0.02, 0.3), "scale": n(0.1, 2.0)}
    elif kind == "lowpass":
        out = {"cutoff": f"{int(rng.integers(2, 80))}Hz" if rng.random() < 0.5 else n(2.0, 80.0)}
    else:
        raise AssertionError(kind)
    return {"type": kind, **out}


def _noise(rng: np.random.Generator, vector: bool, fixed: bool) -> list[dict[str, Any]]:
    """1-4 stages, now and then a run of 2-3 adjacent additive ones (fused into one sum), and on 3-vectors a
    misalign or two (an angle, or a cross-axis matrix too) somewhere in the chain."""
    if rng.random() < 0.25:
        kinds = [str(k) for k in rng.choice(ADDITIVE, int(rng.integers(2, 4)))]
        kinds.insert(int(rng.integers(len(kinds) + 1)), str(rng.choice(STAGES)))
    else:
        kinds = [str(k) for k in rng.choice(STAGES, int(rng.integers(1, 5)))]
    stages = [_stage(rng, k, fixed) for k in kinds]
    for _ in range(int(rng.integers(1, 3)) if vector and rng.random() < 0.5 else 0):
        turn: dict[str, Any] = {"type": "misalign"}
        if rng.random() < 0.8:
            turn["std"] = f"{round(float(rng.uniform(0.5, 5.0)), 2)}deg" if rng.random() < 0.5 else \
                round(float(rng.uniform(0.01, 0.1)), 3)
        if rng.random() < 0.4:
            turn["matrix"] = (np.eye(3) + rng.normal(0, 0.02, (3, 3))).round(3).tolist()
        if len(turn) == 1:
            turn["std"] = 0.05
        stages.insert(int(rng.integers(len(stages) + 1)), turn)
    return stages


def _steps(rng: np.random.Generator, low: int, high: int, rate: bool = False) -> Any:
    """A constant number of physics steps in [low, high] (as steps, a duration or a rate), or drawn per sample."""
    r = rng.random()
    if r < 0.4:
        return int(rng.integers(low, high + 1))
    if r < 0.55:  # the robot's timestep is 2 ms
        steps = int(rng.integers(low, high + 1))
        return f"{500 // steps}Hz" if rate and steps and 500 % steps == 0 and rng.random() < 0.4 else f"{2 * steps}ms"
    if r < 0.8:
        a = int(rng.integers(low, high + 1))
        return {"uniform": [a, int(rng.integers(a, high + 2))]}
    values = sorted({int(v) for v in rng.integers(low, high + 2, int(rng.integers(1, 4)))})
    out: dict[str, Any] = {"choice": values}
    if len(values) > 1 and rng.random() < 0.5:
        p = rng.dirichlet(np.ones(len(values))).round(3)
        p[-1] = round(1.0 - float(p[:-1].sum()), 3)
        if (p > 0).all():
            out["p"] = p.tolist()
    return out


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
        return json.dumps({"version": 1, "options": options, "sensors": self.sensors}, indent=1)


def draw(seed: int) -> Draw:
    rng = np.random.default_rng([seed, 2026])
    strip = bool(rng.random() < 0.2)
    sensors: dict[str, Any] = {}
    for j in range(int(rng.integers(2, 7))):
        kind, element, extra, vector = KINDS[int(rng.integers(len(KINDS)))]
        entry: dict[str, Any] = {"kind": kind, "element": element, **extra}
        if rng.random() < 0.85:
            entry["interval"] = _steps(rng, 1, 4, rate=True)
        if rng.random() < 0.8:
            entry["delay"] = _steps(rng, 0, 5)
        buffer = int(rng.integers(1, 5))
        if buffer > 1 or rng.random() < 0.2:
            entry["buffer"] = buffer
        aggregator = AGGREGATORS[int(rng.integers(len(AGGREGATORS)))]
        if aggregator and not (strip and buffer == 1):  # (no buffer axis to reduce: refused)
            entry["aggregator"] = aggregator
        if rng.random() < 0.75:
            entry["noise"] = _noise(rng, vector, not isinstance(entry.get("interval"), dict))
        sensors[f"s{j}"] = entry
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


def run_single(run: Draw, pad: bool, seed: int) -> tuple[list[dict[str, np.ndarray]], sensorcfg.Environment]:
    """Every observation of an Environment over the draw's episodes (resets included)."""
    env = sensorcfg.Environment(ROBOT, sensorcfg.loads(run.text(pad)), seed=seed)
    assert env.updater.physics_steps_per_control_step == run.substeps
    actions = _actions(seed, sum(run.episodes), ())
    out, t = [], 0
    for steps, level in zip(run.episodes, run.levels):
        if level is not None:
            env.set_noise_level(level)
        out.append(_copy(env.reset().observation))
        for _ in range(steps):
            out.append(_copy(env.step(actions[t]).observation))
            t += 1
    return out, env


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
    got, t = [], 0
    for steps, level in zip(run.episodes, run.levels):
        if level is not None:
            batch.set_noise_level(level)
        got.append(_copy(batch.reset().observation))
        for _ in range(steps):
            got.append(_copy(batch.step(actions[t]).observation))
            t += 1
    for i in range(nsim):
        env = sensorcfg.Environment(ROBOT, sensorcfg.loads(run.text()), seed=sim_seed(seed, i))
        t, k = 0, 0
        for steps, level in zip(run.episodes, run.levels):
            if level is not None:
                env.set_noise_level(level)
            want = [env.reset().observation]
            for _ in range(steps):
                want.append(env.step(actions[t, i]).observation)
                t += 1
            for obs in want:
                assert obs.keys() == got[k].keys()
                for name, value in obs.items():
                    assert_same(got[k][name][i], value, f"seed {seed} sim {i} read {k} {name}: {run.sensors[name]}")
                k += 1


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
