"""Noise inside the Updater loop: determinism, independence per sensor, simulated time, images, YAML errors."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.noise import build_noise

from conftest import MODELS

N = 5  # physics steps per control step
Z = 5.0


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))


def feature(kind: str, element, shape, stages, timestep=0.002, **kwargs) -> sensorcfg.Feature:
    obs = sensorcfg.Feature(kind, element, **kwargs)
    obs.noise = build_noise(stages, shape, np.float64, timestep)
    obs.enabled = True
    return obs


GYRO = [{"type": "bias", "std": 0.01}, {"type": "gaussian", "std": 0.02},
        {"type": "random_walk", "std": 0.005, "correlation_time": "2s"}, {"type": "quantize", "step": 1e-4}]
ACCEL = [{"type": "gaussian", "std": 0.05}, {"type": "dropout", "p": 0.05}]
JOINTS = [{"type": "outlier", "p": 0.01, "scale": 0.5}, {"type": "lowpass", "cutoff": "30Hz"}]


def suite(*names: str) -> dict[str, sensorcfg.Feature]:
    """A fresh set of noisy observables, in the order given."""
    make = {
        "gyro": lambda: feature("sensordata", "sensor:imu_gyro", (3,), GYRO),
        "accel": lambda: feature("sensordata", "sensor:imu_accel", (3,), ACCEL, update_interval=2),
        "joints": lambda: feature("qpos", ["joint:shoulder", "joint:elbow"], (2,), JOINTS, delay=3,
                                  buffer_size=2),
    }
    return {name: make[name]() for name in names}


def episodes(model, observables, seed: int, count: int = 2, control_steps: int = 40) -> list[dict]:
    """Observations of `count` episodes (one Updater, one RandomState), with a fixed control sequence."""
    data = mujoco.MjData(model)
    physics = sensorcfg.Physics(model, data)
    u = sensorcfg.Updater(observables, physics_steps_per_control_step=N)
    random_state = np.random.RandomState(seed)
    out = []
    for _ in range(count):
        mujoco.mj_resetData(model, data)
        mujoco.mj_forward(model, data)
        u.reset(physics, random_state)
        for c in range(control_steps):
            data.ctrl[:2] = np.sin(0.1 * c), np.cos(0.07 * c)
            u.prepare_for_next_control_step()
            for _ in range(N):
                mujoco.mj_step(model, data)
                u.update()
            out.append({k: np.array(v) for k, v in u.get_observation().items()})
    return out


def stream(obs: list[dict], name: str) -> np.ndarray:
    return np.stack([o[name] for o in obs])


def test_same_seed_bit_identical_streams(model):
    a = episodes(model, suite("gyro", "accel", "joints"), seed=3)
    b = episodes(model, suite("gyro", "accel", "joints"), seed=3)
    for name in ("gyro", "accel", "joints"):
        np.testing.assert_array_equal(stream(a, name), stream(b, name))
    c = episodes(model, suite("gyro", "accel", "joints"), seed=4)
    assert not np.array_equal(stream(a, "gyro"), stream(c, "gyro"))


@pytest.mark.parametrize("others", [
    pytest.param(("gyro",), id="alone"),
    pytest.param(("gyro", "accel"), id="with-accel"),
    pytest.param(("joints", "accel", "gyro"), id="reordered"),
    pytest.param(("accel", "gyro", "joints"), id="all"),
])
def test_a_sensors_noise_does_not_depend_on_the_others(model, others):
    """Adding, removing or reordering other noisy sensors leaves this sensor's noise bit-identical."""
    reference = episodes(model, suite("gyro", "joints"), seed=11)
    got = episodes(model, suite(*others), seed=11)
    np.testing.assert_array_equal(stream(got, "gyro"), stream(reference, "gyro"))
    if "joints" in others:
        np.testing.assert_array_equal(stream(got, "joints"), stream(reference, "joints"))


def test_noise_is_actually_applied_and_differs_per_episode(model):
    clean = sensorcfg.Feature("sensordata", "sensor:imu_gyro")
    clean.enabled = True
    noisy = episodes(model, {"gyro": feature("sensordata", "sensor:imu_gyro", (3,), [{"type": "bias", "std": 1}])},
                     seed=1, count=2, control_steps=10)
    truth = episodes(model, {"gyro": clean}, seed=1, count=2, control_steps=10)
    offset = stream(noisy, "gyro") - stream(truth, "gyro")
    np.testing.assert_allclose(offset[:10], offset[0:1].repeat(10, 0), atol=1e-12)  # constant in episode 1
    np.testing.assert_allclose(offset[10:], offset[10:11].repeat(10, 0), atol=1e-12)  # ... and in episode 2
    assert np.all(np.abs(offset[0] - offset[10]) > 1e-6)  # a new draw at the reset


class Zeros:
    """A Generic observable's callable: a constant observation, so the output is the noise alone."""

    def __init__(self, shape, dtype=np.float64):
        self.shape, self.dtype = shape, dtype

    def __call__(self, physics):
        return np.zeros(self.shape, self.dtype)


@pytest.mark.parametrize("interval", [pytest.param(1, id="interval-1"), pytest.param(5, id="interval-5")])
def test_random_walk_follows_simulated_time_in_the_updater(model, interval):
    """Read once per control step (N physics steps), the walk's lag-one autocorrelation is exp(-N dt/tau)
    whatever the sensor's interval, because the Updater passes each sample's physics step."""
    width, tau, dt = 4000, 0.02, model.opt.timestep
    obs = sensorcfg.Generic(Zeros((width,)), update_interval=interval)
    obs.noise = build_noise([{"type": "random_walk", "std": 1.0, "correlation_time": tau}], (width,), np.float64, dt)
    obs.enabled = True
    got = stream(episodes(model, {"walk": obs}, seed=5, count=1, control_steps=3), "walk")
    rho = math.exp(-N * dt / tau)
    for a, b in ((got[0], got[1]), (got[1], got[2])):
        r = np.corrcoef(a, b)[0, 1]
        assert abs(r - rho) <= Z * (1 - rho**2) / math.sqrt(width)
    assert abs(got.std() - 1.0) <= Z * math.sqrt(2 / got.size) * 1.5


def test_uint8_images_through_the_updater(model):
    cam = sensorcfg.Camera("camera:overview", height=24, width=32)
    spec = cam.array_spec
    assert spec.shape == (24, 32, 3) and spec.dtype == np.uint8
    cam.noise = build_noise([{"type": "gaussian", "std": 30}, {"type": "dropout", "p": 0.2, "mode": "hold"}],
                            spec.shape, spec.dtype, model.opt.timestep)
    cam.enabled = True
    depth = sensorcfg.Camera("camera:overview", height=24, width=32, mode="depth")
    spec = depth.array_spec
    assert spec.dtype == np.float32
    depth.noise = build_noise([{"type": "gaussian", "std": 0.01}, {"type": "clip", "min": 0.0}], spec.shape,
                              spec.dtype, model.opt.timestep)
    depth.enabled = True
    obs = episodes(model, {"cam": cam, "depth": depth}, seed=2, count=1, control_steps=5)
    for o in obs:
        assert o["cam"].dtype == np.uint8 and o["cam"].shape == (1, 24, 32, 3)  # (buffer, h, w, rgb)
        assert o["depth"].dtype == np.float32 and o["depth"].min() >= 0
    assert len({o["cam"].tobytes() for o in obs}) > 1


def salt(value, random_state):
    """A dm_control corruptor, usable both as `corruptor=` and as a custom stage."""
    return value + random_state.uniform(-0.1, 0.1, size=value.shape)


def test_custom_stage_in_the_updater_is_seeded_per_sensor(model):
    def make():
        return {"gyro": feature("sensordata", "sensor:imu_gyro", (3,), [{"type": "custom", "callable": salt}])}
    a, b = (stream(episodes(model, make(), seed=8, control_steps=10), "gyro") for _ in range(2))
    np.testing.assert_array_equal(a, b)
    legacy = sensorcfg.Feature("sensordata", "sensor:imu_gyro", corruptor=salt)  # dm_control's way still works
    legacy.enabled = True
    assert stream(episodes(model, {"gyro": legacy}, seed=8, control_steps=10), "gyro").shape == a.shape


# -- YAML: errors at their line and column ---------------------------------------------------------

SUITE_ERRORS = """\
version: 1
sensors:
  gyro:
    kind: sensordata
    element: sensor:imu_gyro
    noise:
      - {type: gausian, std: 0.1}
      - type: uniform
        low: 1
        high: 0
      - {type: quantize, step: 0}
      - {type: dropout, p: 1.5}
      - {type: gaussian, std: -0.1}
"""


def test_yaml_config_errors_have_line_and_column():
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(SUITE_ERRORS, file="arm.yaml")
    assert str(info.value).splitlines() == [
        "arm.yaml:7:16: error: sensors.gyro.noise.0.type: unknown noise stage type 'gausian' (did you mean "
        "'gaussian'?); stage types are gaussian, uniform, bias, scale, random_walk, quantize, clip, dropout, "
        "outlier, lowpass, misalign, custom",
        "arm.yaml:9:14: error: sensors.gyro.noise.1.low: low must not exceed high: low is 1 and high is 0; swap them",
        "arm.yaml:11:32: error: sensors.gyro.noise.2.step: a quantisation step must be > 0, got 0",
        "arm.yaml:12:28: error: sensors.gyro.noise.3.p: a probability must be <= 1, got 1.5",
        "arm.yaml:13:31: error: sensors.gyro.noise.4.std: a standard deviation must be >= 0, got -0.1",
    ]


SUITE_BINDING = """\
version: 1
sensors:
  gyro:
    kind: sensordata
    element: sensor:imu_gyro
    noise:
      - {type: gaussian, std: [0.1, 0.2]}
  cam:
    kind: rgb
    element: camera:wrist
    noise:
      - {type: random_walk, std: 1}
"""


def test_yaml_binding_errors_have_line_and_column(model):
    suite_ = sensorcfg.loads(SUITE_BINDING, file="arm.yaml")
    with pytest.raises(sensorcfg.SuiteError) as info:
        suite_.build(model)
    assert str(info.value).splitlines() == [
        "arm.yaml:7:31: error: sensors.gyro.noise.0.std: 2 entries do not fit the observation's shape (3,): give a "
        "number or 3 (one per value)",
        "arm.yaml:12:16: error: sensors.cam.noise.0.type: random_walk cannot apply to a uint8 image: images take "
        "gaussian, uniform, quantize, clip, dropout, outlier, custom (results are rounded and clipped to 0..255)",
    ]


def test_yaml_suite_with_noise_runs_reproducibly(model):
    text = """\
version: 1
sensors:
  imu:
    kind: sensordata
    element: ["sensor:imu_gyro", "sensor:imu_accel"]
    noise:
      - {type: bias, std: [0.01, 0.01, 0.01, 0.1, 0.1, 0.1]}
      - {type: random_walk, std: 0.002, correlation_time: 500ms}
      - {type: gaussian, std: 0.02}
      - {type: lowpass, cutoff: 40Hz}
  joints:
    kind: qpos
    element: ["joint:shoulder", "joint:elbow"]
    noise:
      - {type: quantize, step: 0.001}
"""
    runs = [stream(episodes(model, sensorcfg.loads(text).build(model), seed=6, control_steps=10), "imu")
            for _ in range(2)]
    np.testing.assert_array_equal(runs[0], runs[1])
    assert runs[0].shape == (20, 1, 6)  # buffer axis kept (no strip_singleton_buffer_dim)


class TimeAndZeros:
    """Generic callable: [simulated time, 0, 0, ...], so a sample carries the time it was taken."""

    def __init__(self, width):
        self.width = width

    def __call__(self, physics):
        out = np.zeros(self.width)
        out[0] = physics.data.time
        return out


def test_random_walk_with_random_intervals_uses_each_samples_time(model):
    """With intervals drawn per sample, the correlation between two reads is exp(-(t2 - t1)/tau) for the
    times t1, t2 at which their samples were taken (std 0 on entry 0 keeps the time readable)."""
    width, tau = 4001, 0.01
    draws = np.random.RandomState(0)
    obs = sensorcfg.Generic(TimeAndZeros(width), update_interval=lambda: int(draws.randint(1, 5)))
    obs.noise = build_noise([{"type": "random_walk", "std": [0.0] + [1.0] * (width - 1), "correlation_time": tau}],
                            (width,), np.float64, model.opt.timestep)
    obs.enabled = True
    got = stream(episodes(model, {"walk": obs}, seed=9, count=1, control_steps=8), "walk")[:, 0]
    times = got[:, 0]
    assert len(set(np.round(np.diff(times) / model.opt.timestep).astype(int))) > 1  # irregular gaps
    for (t1, a), (t2, b) in zip(zip(times, got[:, 1:]), zip(times[1:], got[1:, 1:])):
        rho = math.exp(-(t2 - t1) / tau)
        r = np.corrcoef(a, b)[0, 1]
        assert abs(r - rho) <= Z * (1 - rho**2) / math.sqrt(width - 1) + 1e-9, (t1, t2, r, rho)


TERRAIN = str(MODELS / "terrain.xml")


@pytest.mark.parametrize("pad", [False, True])
@pytest.mark.parametrize("schedule, shows_zeros", [
    pytest.param("delay: 5", True, id="delay"),
    pytest.param("buffer: 3", True, id="buffer"),
    pytest.param("delay: {uniform: [0, 3]}", True, id="drawn-delay"),
    pytest.param("interval: 3, buffer: 2", True, id="interval-buffer"),
    pytest.param("buffer: 3, aggregator: mean", True, id="mean"),
    pytest.param("delay: 2, buffer: 3, aggregator: min", True, id="min"),
    pytest.param("interval: {uniform: [1, 3]}", False, id="nothing-padded"),
])
def test_spec_bounds_hold_the_zeros_a_read_pads_with(schedule: str, shows_zeros: bool, pad: bool) -> None:
    """dm_control pads a window with zeros before its first samples are delivered: a spec whose bounds exclude
    0 includes it wherever a read can show the padding (pad_with_initial_value repeats the first sample
    instead, which keeps the bounds), and every read, single or batched, lies within the spec."""
    suite = sensorcfg.loads(f"options: {{pad_with_initial_value: {str(pad).lower()}}}\nsensors:\n"
                            f"  q: {{kind: qpos, element: joint:hip_f, {schedule},\n"
                            "      noise: [{type: gaussian, std: 0.1}, {type: clip, min: 1, max: 2}]}\n")
    env = sensorcfg.Environment(TERRAIN, suite, seed=0)
    spec = env.observation_spec()["q"]
    lowest = 0.0 if shows_zeros and not pad else 1.0
    assert lowest - 1e-12 < float(np.min(spec.minimum)) <= lowest and float(np.max(spec.maximum)) >= 2
    reads = [env.reset().observation["q"]] + [env.step(np.zeros(2)).observation["q"] for _ in range(8)]
    for value in reads:
        spec.validate(value)
    assert any(np.any(value == 0) for value in reads) == (shows_zeros and not pad and "mean" not in schedule)
    if int(mujoco.__version__.split(".")[0]) < 4:
        return
    batch = sensorcfg.BatchEnvironment(TERRAIN, suite, 2, seed=0)
    batch_spec = batch.observation_spec()["q"]
    np.testing.assert_array_equal(np.broadcast_to(batch_spec.minimum, batch_spec.shape)[0],
                                  np.broadcast_to(spec.minimum, spec.shape))
    for obs in [batch.reset().observation] + [batch.step(np.zeros((2, 2))).observation for _ in range(8)]:
        batch_spec.validate(obs["q"])


@pytest.mark.parametrize("target, found", [
    pytest.param("builtins:max", "has no signature Python can read", id="no-signature"),
    pytest.param("math:floor", "must accept (value, random_state), as a dm_control corruptor does; it takes (x, /)",
                 id="one-argument"),
])
def test_a_custom_callable_that_cannot_take_the_corruptor_arguments_is_a_problem_at_its_line(model, target, found):
    """What `validate --import` reports is what running the suite raises, at the callable's line, before any
    step (a builtin without a signature used to pass and then fail in the first step with a TypeError)."""
    text = f"sensors:\n  q: {{kind: qpos, element: 'joint:*', noise: [{{type: custom, callable: '{target}'}}]}}\n"
    problems = sensorcfg.loads(text, file="arm.yaml").check(model, import_callables=True)
    assert [(p.file, p.line, p.col, p.loc) for p in problems] == [("arm.yaml", 2, 72, "sensors.q.noise.0.callable")]
    assert found in problems[0].message
    with pytest.raises(sensorcfg.SuiteError, match=r"arm\.yaml:2:72: error: sensors\.q\.noise\.0\.callable: "):
        sensorcfg.Environment(model, sensorcfg.loads(text, file="arm.yaml"))
