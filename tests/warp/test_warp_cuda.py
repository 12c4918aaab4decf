"""The Warp engine on a CUDA device against Warp's CPU device (skipped where no CUDA device is present; the
GPU check benchmarks/warp_gpu.sh runs it): the same keys give the same Philox words and uniforms bit for
bit, normals to one float64 ulp (the ziggurat fallback's exp and log are each device's), and the sensor
layer fed the same samples with the same key and episode tables reads the same values on both devices;
cameras recorded in the control step's CUDA graph render each step's state."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from conftest import MODELS, warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.draws import ChoiceSteps, UniformSteps, episode_entropy  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.plan.bind import bind, plan_suite  # noqa: E402
from sensorcfg.warp import philox  # noqa: E402
from sensorcfg.warp.layer import episode_keys  # noqa: E402
from sensorcfg.warp.sensors import Sensors  # noqa: E402

if not wp.is_cuda_available():
    pytest.skip("no CUDA device: the CUDA-against-CPU checks run on a GPU machine (benchmarks/warp_gpu.sh)",
                allow_module_level=True)

CUDA = "cuda:0"
ROBOT = str(assets.path("robot.xml"))
# every stage the engine runs, two to a sensor, with delays (constant and drawn), drawn intervals, buffers and
# aggregators
SENSORS = [
    ("qpos", ["joint:shoulder", "joint:elbow"], 1, 2, 1, None,
     [{"type": "gaussian", "std": 0.01}, {"type": "quantize", "step": 0.001}]),
    ("qvel", "joint:elbow", 1, 1, 3, "mean",
     [{"type": "uniform", "low": -0.01, "high": 0.02}, {"type": "lowpass", "cutoff": 20.0}]),
    ("sensordata", "sensor:imu_accel", 2, 0, 2, "max",
     [{"type": "outlier", "p": 0.2, "scale": 1.0}, {"type": "clip", "min": -0.5, "max": 0.5}]),
    ("xpos", "site:hand_site", 1, 3, 1, None,
     [{"type": "gaussian", "std": 0.02}, {"type": "dropout", "p": 0.3, "mode": "hold"}]),
    ("xquat", "body:hand", 3, 0, 2, "median",
     [{"type": "dropout", "p": 0.3, "mode": "zero", "per": "value"}, {"type": "gaussian", "std": 0.01}]),
    ("xpos", ["site:hand_site", "site:imu"], 1, 1, 2, None,  # drawn per episode: parameters, a rotation
     [{"type": "gaussian", "std": {"uniform": [0.01, 0.05]}}, {"type": "misalign", "std": 0.1},
      {"type": "random_walk", "std": 0.01, "correlation_time": {"uniform": [0.01, 0.1]}}]),
    ("qpos", "joint:elbow", UniformSteps(1, 3), ChoiceSteps((0, 2, 5)), 2, None,
     [{"type": "gaussian", "std": 0.01}, {"type": "lowpass", "cutoff": 20.0}]),
    ("xpos", "site:hand_site", 2, UniformSteps(0, 4), 3, "mean",
     [{"type": "random_walk", "std": 0.01}, {"type": "dropout", "p": 0.3, "mode": "hold"}]),
]


def _keys(rng: np.random.Generator, m: int) -> np.ndarray:
    return rng.integers(0, 2**32, size=(m, 4), dtype=np.uint64).reshape(m, 2, 2) @ np.array([1 << 32, 1], np.uint64)


@pytest.mark.parametrize("stage, lane, size", [(0, 0, 1), (3, 1, 7), (63, 0, 12)])
def test_the_same_keys_give_the_same_numbers_on_cuda_and_cpu(stage: int, lane: int, size: int) -> None:
    rng = np.random.default_rng(stage + 100 * lane + size)
    m = 4096
    keys = _keys(rng, m)
    samples = np.concatenate([np.arange(m // 2), rng.integers(2**32 - 4, 2**45, size=m - m // 2)]).astype(np.int64)
    uniform = [philox.numbers(keys, samples, stage, lane, size, False, device=d).numpy() for d in ("cpu", CUDA)]
    assert uniform[0].tobytes() == uniform[1].tobytes()
    normal = [philox.numbers(keys, samples, stage, lane, size, True, device=d).numpy() for d in ("cpu", CUDA)]
    np.testing.assert_array_max_ulp(normal[0], normal[1], maxulp=1)


def _observables() -> dict[str, sensorcfg.Observable]:
    physics = Physics(mujoco.MjModel.from_xml_path(ROBOT))
    out = {}
    for j, (kind, element, interval, delay, buffer, aggregator, noise) in enumerate(SENSORS):
        obs = sensorcfg.Feature(kind, element, update_interval=interval, delay=delay, buffer_size=buffer,
                                aggregator=aggregator)
        obs.reader(physics)
        obs.noise = build_noise(noise, obs.array_spec.shape, obs.array_spec.dtype, physics.timestep)
        obs.enabled = True
        out[f"s{j}_{kind}"] = obs
    return out


def _sensors(device: str, nworld: int, substeps: int) -> Sensors:
    """The sensor layer on `device`."""
    model = mujoco.MjModel.from_xml_path(ROBOT)
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    bound = bind(_observables(), physics, substeps, False)
    return Sensors(plan_suite(bound, physics, bound.sources(), nworld, substeps, False), wp.get_device(device), 2)


def _run(device: str, nworld: int, substeps: int, trajectory: list[dict[str, np.ndarray]],
         table: np.ndarray, values: np.ndarray) -> list[dict[str, np.ndarray]]:
    """The sensor layer on `device` with key table `table` and episode table `values`, fed `trajectory` (per
    physics step, each field (nworld, size) float32): the reads at the reset and after each control step."""
    sensors = _sensors(device, nworld, substeps)
    sensors.episodes.key_table.assign(table)
    sensors.episodes.value_table.assign(values)

    def fields(k: int) -> dict[str, wp.array]:
        return {f: wp.array(v, dtype=wp.float32, device=device) for f, v in trajectory[k].items()}

    steps = wp.zeros(nworld, dtype=wp.int64, device=device)
    sensors.reset(wp.ones(nworld, dtype=wp.int32, device=device), fields(0), steps)
    reads = [{n: a.numpy().copy() for n, a in sensors.read(steps).items()}]
    for k in range(1, len(trajectory)):
        steps.assign(np.full(nworld, k, np.int64))
        sensors.record(fields(k), steps)
        if k % substeps == 0:
            reads.append({n: a.numpy().copy() for n, a in sensors.read(steps).items()})
    return reads


def test_the_sensor_layer_reads_the_same_values_on_cuda_and_cpu() -> None:
    nworld, substeps, nsteps = 64, 2, 41
    model = mujoco.MjModel.from_xml_path(ROBOT)
    data = mujoco.MjData(model)
    layout = _sensors("cpu", nworld, substeps)
    rng = np.random.default_rng(0)
    sizes = {f: np.ravel(getattr(data, f)).size for f, _ in layout.plan.fields}
    trajectory = [{f: rng.uniform(-1, 1, (nworld, n)).astype(np.float32) for f, n in sizes.items()}
                  for _ in range(nsteps)]
    table = np.zeros(layout.episodes.key_table.shape, np.uint64)
    values = np.zeros(layout.episodes.value_table.shape)
    for w in range(nworld):
        table[w, 0], values[w, 0] = episode_keys(layout, episode_entropy(np.random.RandomState(100 + w)))
    cpu, cuda = (_run(d, nworld, substeps, trajectory, table, values) for d in ("cpu", CUDA))
    assert len(cpu) == len(cuda) == 1 + (nsteps - 1) // substeps
    for t, (a, b) in enumerate(zip(cpu, cuda)):
        assert a.keys() == b.keys()
        for name in a:
            # float64 noise arithmetic rounded to float32 on both devices: equal to float32 rounding (a
            # normal's fallback takes each device's exp and log)
            np.testing.assert_allclose(b[name], a[name], rtol=1e-6, atol=1e-7, err_msg=f"read {t} {name}")


def test_cameras_in_the_captured_control_step_render_each_steps_state() -> None:
    """Replayed graphs (from the second step), restarts in the graph's conditional node (a 0.05 s episode):
    each step's depth frame is a render of the worlds' state after it, as a render context of its own gives."""
    import mujoco_warp as mjw

    from sensorcfg.observables.camera import Camera
    from sensorcfg.warp.cameras import background_depth
    from sensorcfg.warp.environment import WarpEnvironment

    scene, nworld, width, height = str(MODELS / "camera_scene.xml"), 4, 32, 24
    obs = {"depth": Camera("eye", height=height, width=width, mode="depth")}
    obs["depth"].enabled = True
    env = WarpEnvironment(scene, obs, nworld, device=CUDA, physics_steps_per_control_step=1, time_limit=0.05)
    model = mujoco.MjModel.from_xml_path(scene)
    with wp.ScopedDevice(CUDA):
        rc = mjw.create_render_context(model, nworld=nworld, cam_res=[(width, height)], render_rgb=[False],
                                       render_depth=[True], render_seg=[False], cam_active=[0])
    far = background_depth(model, 0)
    actions = wp.array(np.linspace(-1, 1, nworld, dtype=np.float32).reshape(nworld, 1), device=CUDA)
    env.reset()
    frames = []
    for _ in range(12):
        depth = env.step(actions).observation["depth"].numpy().reshape(nworld, height * width).copy()
        with wp.ScopedDevice(CUDA):
            mjw.refit_bvh(env.worlds.model, env.data, rc)
            mjw.render(env.worlds.model, env.data, rc)
        own = rc.depth_data.numpy()
        np.testing.assert_array_equal(depth, np.where(own > 0, own, np.float32(far)))
        frames.append(depth)
    assert env._graph is not None  # the steps above replayed the recorded graph
    assert len({f.tobytes() for f in frames}) >= 5  # steps 1..5 of an episode differ (then they repeat)
