"""Drawn intervals and delays on the Warp engine (`sensorcfg.warp.drawn`), on Warp's CPU device: the draws are
numpy's (`UniformSteps.of_uniform`, `ChoiceSteps.of_uniform` of the schedule key's uniforms) bit for bit, and
world w reads what the Updater reads on world w's trajectory (`test_warp_sensors.replay`), resets of some
worlds included; `WarpEnvironment` with drawn sensors reads what `BatchEnvironment` reads."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pytest

from cpu_batch import cpu_batch  # noqa: E402
from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg.draws import ChoiceSteps, UniformSteps  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.noise import streams  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.plan import DrawnTiming, SensorRecord, Source, SuitePlan  # noqa: E402
from sensorcfg.plan.compile import _steps  # noqa: E402
from sensorcfg.plan.drawn import Drawn, Planner  # noqa: E402
from sensorcfg.plan.schedule import history_rows  # noqa: E402
from sensorcfg.warp.drawn import DrawnSchedules, DrawnSetting, DrawnTimings, _setting, draw  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from sensorcfg.warp.philox import MODULE_OPTIONS  # noqa: E402
from test_warp_sensors import FEATURES, NOISE, ROBOT, replay  # noqa: E402

wp.set_module_options(MODULE_OPTIONS)

SETTINGS = [UniformSteps(1, 7), UniformSteps(3, 3), UniformSteps(0, 1000), ChoiceSteps((1, 4, 9)),
            ChoiceSteps((2, 5, 7), (0.2, 0.5, 0.3)), ChoiceSteps((1, 2, 3), (0.0, 1.0, 0.0)),
            ChoiceSteps((0, 6), (0.1, 0.9))]
DEGENERATE = [UniformSteps(3, 3), ChoiceSteps((1, 2, 3), (0.0, 1.0, 0.0))]  # one value only


@wp.kernel
def _draws(setting: DrawnSetting, timings: DrawnTimings, keys: wp.array2d[wp.uint64], samples: wp.array[wp.int64],
           lane: wp.uint32, out: wp.array[wp.int64]):
    i = wp.tid()
    out[i] = draw(setting, timings, keys[i, 0], keys[i, 1], samples[i], lane)


@pytest.mark.parametrize("setting", SETTINGS, ids=repr)
@pytest.mark.parametrize("lane", [0, 1])
def test_a_draw_is_numpys_bit_for_bit(setting: UniformSteps | ChoiceSteps, lane: int) -> None:
    rng = np.random.default_rng(lane)
    m = 4000
    keys = rng.integers(0, 2**64, (m, 2), dtype=np.uint64)
    samples = rng.integers(0, 2**40, m).astype(np.int64)
    samples[:50] = np.arange(50)
    schedule = keys ^ np.array([0, 1 << 63], np.uint64)
    expected = np.asarray(setting.of_uniform(streams.uniform_runs(schedule, samples, np.ones(m, np.int64), lane)))
    values: list[int] = []
    cumulative: list[float] = []
    drawn = _setting(_steps(setting, 0), values, cumulative)
    timings = DrawnTimings()  # (only the shared values and cumulative weights `draw` reads)
    timings.values = wp.array(np.asarray(values, np.int64), dtype=wp.int64, device="cpu")
    timings.cumulative = wp.array(np.asarray(cumulative), dtype=wp.float64, device="cpu")
    out = wp.zeros(m, dtype=wp.int64, device="cpu")
    wp.launch(_draws, dim=m, inputs=[drawn, timings, wp.array(keys, dtype=wp.uint64), wp.array(samples, dtype=wp.int64),
                                     lane], outputs=[out], device="cpu")
    assert out.numpy().tolist() == expected.astype(np.int64).tolist()
    assert len(set(expected.tolist())) > 1 or setting in DEGENERATE


def _plan(timings: list[DrawnTiming], nworld: int, substeps: int) -> SuitePlan:
    """A plan of one-value drawn sensors (only what `DrawnSchedules` reads of it)."""
    source = Source("qpos", np.zeros(1, np.intp))
    sensors = tuple(SensorRecord(f"s{i}", (1,), (i, i + 1), (t.buffer, 1), None, t, None, source)
                    for i, t in enumerate(timings))
    rows = history_rows([], substeps, reach=max(t.span for t in timings))
    return SuitePlan(nworld, substeps, 0.002, False, sensors, 0, len(timings), rows,
                     None, None, None, ())  # type: ignore[arg-type]


SCHEDULES = [  # (interval, delay, buffer): delays long against intervals, large buffers, one-step intervals
    (UniformSteps(1, 3), UniformSteps(0, 20), 5),
    (ChoiceSteps((1, 9), (0.8, 0.2)), ChoiceSteps((0, 1, 30)), 4),
    (1, UniformSteps(0, 6), 3),
    (UniformSteps(2, 5), 7, 2),
    (ChoiceSteps((3,)), ChoiceSteps((0, 40), (0.9, 0.1)), 6),
]


@pytest.mark.parametrize("substeps", [1, 3])
def test_windows_are_the_planners_for_every_read(substeps: int) -> None:
    """Each read's window (the sample steps shown, -1 padding) of 48 worlds of random keys over 400 steps, for
    each schedule of `SCHEDULES`, against `plan.drawn.Planner`'s rounds (the CPU engines' rule)."""
    nworld, length = 48, 400
    drawns = [Drawn(interval, delay, buffer, substeps) for interval, delay, buffer in SCHEDULES]
    timings = [DrawnTiming(_steps(d.interval, 1), _steps(d.delay, 0), d.buffer, d.span) for d in drawns]
    plan = _plan(timings, nworld, substeps)
    keys = np.random.default_rng(substeps).integers(0, 2**64, (nworld, len(drawns), 2), dtype=np.uint64)
    schedules = DrawnSchedules(plan, wp.get_device("cpu"), {f"s{i}": i for i in range(len(drawns))}, {})
    device_keys = wp.array(keys, dtype=wp.uint64, device="cpu")
    due = wp.zeros((nworld, 1), dtype=wp.int32, device="cpu")
    history = wp.zeros((nworld, plan.rows, plan.width), dtype=wp.float32, device="cpu")
    everyone = wp.ones(nworld, dtype=wp.int32, device="cpu")
    steps = wp.zeros(nworld, dtype=wp.int64, device="cpu")
    sims = np.arange(nworld)
    planners = [Planner(d, nworld) for d in drawns]
    expected = [[p.start(sims, keys[:, i]).windows[:, 0]] for i, p in enumerate(planners)]
    for i, p in enumerate(planners):
        expected[i] += list(p.round(sims, length).windows.transpose(1, 0, 2))
    shown = set()
    for s in range(length + 1):
        steps.assign(np.full(nworld, s, np.int64))
        schedules.record(steps, everyone, device_keys, due)
        if s % substeps == 0:
            schedules.read(steps, history)
            windows = schedules.windows.numpy()
            for i, d in enumerate(drawns):
                want = expected[i][s // substeps]
                assert windows[:, i, :d.buffer].tolist() == want.tolist(), (s, i)
                shown |= set(want.ravel().tolist())
    assert -1 in shown and len(shown) > length // 2


DRAWS = {
    "interval": (lambda rng: UniformSteps(1, int(rng.integers(2, 5))), lambda rng: int(rng.integers(0, 4))),
    "delay": (lambda rng: int(rng.integers(1, 4)), lambda rng: UniformSteps(0, int(rng.integers(1, 7)))),
    "both": (lambda rng: ChoiceSteps((1, 2, 4), (0.5, 0.25, 0.25)), lambda rng: ChoiceSteps((0, 3, 6))),
}
STATEFUL = [8, 5, 11, 12]  # lowpass, dropout holding, random walks (NOISE's rows)


def drawn_suite(seed: int, which: str, noise: bool) -> dict[str, sensorcfg.Observable]:
    """A fixed-schedule sensor and two to four drawn ones (`which` is drawn), buffers up to 3, aggregators,
    noise (stateless and stateful) on most when `noise`."""
    rng = np.random.default_rng(seed)
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
    interval, delay = DRAWS[which]
    out = {"fixed": sensorcfg.Feature("qpos", "joint:elbow", update_interval=2, delay=1, buffer_size=2)}
    for j in range(int(rng.integers(2, 5))):
        kind, element = FEATURES[int(rng.integers(len(FEATURES)))]
        out[f"d{j}_{kind}"] = sensorcfg.Feature(kind, element, update_interval=interval(rng), delay=delay(rng),
                                                buffer_size=int(rng.integers(1, 4)),
                                                aggregator=[None, None, "mean", "max", "median"][int(rng.integers(5))])
    for j, obs in enumerate(out.values()):
        obs.reader(physics)
        if noise and j and rng.random() < 0.8:
            picks = [*rng.choice(len(NOISE), size=int(rng.integers(1, 3)), replace=False)]
            if j == 1:
                picks.append(STATEFUL[seed % len(STATEFUL)])  # one stateful stage at least
            obs.noise = build_noise([NOISE[int(p)] for p in dict.fromkeys(picks)], obs.array_spec.shape,
                                    obs.array_spec.dtype, physics.timestep)
        obs.enabled = True
    return out


CASES = [(seed, which) for which in DRAWS for seed in range(4)]


@pytest.mark.parametrize("seed, which", CASES)
def test_world_i_reads_what_the_updater_reads_with_drawn_schedules(seed: int, which: str) -> None:
    """Drawn intervals, delays or both; substeps 1 to 3; padding on and off; noise on three cases in four;
    worlds 1, then 0 and 2, start a second episode mid-run."""
    replay(lambda: drawn_suite(seed, which, seed % 4 != 0), mujoco.MjModel.from_xml_path(ROBOT), 3, 1 + seed % 3,
           bool(seed % 2), 24, seed, resets={7: [1], 15: [0, 2]})


def test_warp_environment_reads_what_the_batch_reads_with_drawn_schedules() -> None:
    """A drawn sensor of the controls (the same values on both engines, whatever the physics): its samples,
    windows, noise (at a noise level too) and restarts (after a time limit, and by `reset(ids)`) are
    `BatchEnvironment`'s."""
    def suite() -> dict[str, Any]:
        ctrl = {"ctrl": sensorcfg.Feature("ctrl", "actuator:shoulder_motor", update_interval=UniformSteps(1, 3),
                                          delay=ChoiceSteps((0, 2, 5)), buffer_size=3),
                "noisy": sensorcfg.Feature("ctrl", ["actuator:shoulder_motor", "actuator:elbow_motor"],
                                           update_interval=ChoiceSteps((1, 2)), delay=UniformSteps(0, 3),
                                           buffer_size=2, aggregator="max")}
        ctrl["noisy"].noise = build_noise([{"type": "gaussian", "std": 0.5}, {"type": "dropout", "p": 0.3},
                                           {"type": "clip", "min": -0.8, "max": 0.8}], (2,), np.float64, timestep)
        for obs in ctrl.values():
            obs.enabled = True
        return ctrl

    timestep = float(mujoco.MjModel.from_xml_path(ROBOT).opt.timestep)
    options = dict(physics_steps_per_control_step=1, seed=4, time_limit=9 * timestep)
    warp = WarpEnvironment(ROBOT, suite(), 2, device="cpu", **options)
    batch = cpu_batch(ROBOT, suite, 2, **options)
    ours, theirs = warp.reset(), batch.reset()
    rng = np.random.default_rng(0)
    for t in range(24):
        for name in ("ctrl", "noisy"):
            np.testing.assert_allclose(ours.observation[name].numpy(), theirs.observation[name], rtol=1e-6,
                                       atol=1e-6, err_msg=f"step {t} {name}")
        assert ours.step_type.numpy().tolist() == [int(s) for s in theirs.step_type]
        actions = rng.uniform(-1, 1, (2, warp._model.nu)).astype(np.float32)
        actions[:, 2] = 0.02
        if t == 5:  # from each world's next episode: noise blended with the raw value, clipped to its bounds
            warp.set_noise_level(0.5)
            batch.set_noise_level(0.5)
        if t == 13:  # world 1 restarted by hand, mid-episode
            ours, theirs = warp.reset([1]), batch.reset([1])
        else:
            ours, theirs = warp.step(actions), batch.step(actions.astype(np.float64))


EPISODE_NOISE = [  # stages drawing values per episode (a rotation, parameters), on drawn schedules
    [{"type": "misalign", "std": 0.1}, {"type": "gaussian", "std": {"uniform": [0.01, 0.05]}}],
    [{"type": "random_walk", "std": {"uniform": [0.01, 0.02]}, "correlation_time": 0.05},
     {"type": "misalign", "std": 0.2}],
    [{"type": "dropout", "p": {"uniform": [0.1, 0.4]}, "mode": "hold"}, {"type": "bias", "std": 0.1},
     {"type": "lowpass", "cutoff": 20.0}],
]


@pytest.mark.parametrize("seed, which", [(seed, which) for which in DRAWS for seed in range(2)])
def test_drawn_schedules_with_misalign_and_parameters_drawn_per_episode(seed: int, which: str) -> None:
    """Drawn intervals and delays under noise whose values are drawn at each reset (misalign's rotation,
    parameters drawn per episode, a bias): world i reads what the Updater reads, resets included."""
    def make() -> dict[str, sensorcfg.Observable]:
        rng = np.random.default_rng(seed)
        physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
        interval, delay = DRAWS[which]
        out = {}
        for j, stages in enumerate(EPISODE_NOISE):
            obs = sensorcfg.Feature("xpos", "site:hand_site", update_interval=interval(rng), delay=delay(rng),
                                    buffer_size=int(rng.integers(1, 3)), aggregator=[None, "mean"][j % 2])
            obs.reader(physics)
            obs.noise = build_noise(stages, obs.array_spec.shape, obs.array_spec.dtype, physics.timestep)
            obs.enabled = True
            out[f"d{j}"] = obs
        return out

    replay(make, mujoco.MjModel.from_xml_path(ROBOT), 3, 1 + seed % 3, bool(seed % 2), 24, seed,
           resets={7: [1], 15: [0, 2]})


def test_a_lowpass_whose_cutoff_is_drawn_per_episode_on_a_drawn_delay() -> None:
    """A constant interval with a drawn delay is a drawn schedule, whose low-pass coefficients per gap are
    computed for a fixed cutoff: a cutoff drawn per episode filters with the episode's (the gap is always the
    interval), as on the CPU, over several episodes."""
    def make() -> dict[str, sensorcfg.Observable]:
        physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
        obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], update_interval=3,
                                delay=ChoiceSteps((1, 4)))
        obs.reader(physics)
        obs.noise = build_noise([{"type": "lowpass", "cutoff": {"uniform": [5.0, 40.0]}}], (2,), np.float64,
                                physics.timestep)
        obs.enabled = True
        return {"filtered": obs}

    replay(make, mujoco.MjModel.from_xml_path(ROBOT), 2, 3, False, 8, 0, resets={4: [1]})
