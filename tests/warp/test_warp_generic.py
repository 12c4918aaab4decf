"""Batched generic sensors (`batched: true`, `sensorcfg.warp.generic`) on Warp's CPU device: a callable of every
world's MuJoCo Warp Model and Data, written with a Warp kernel, reads exactly what the same schedule, delay,
buffer, aggregator and noise read from the mjData field its values come from (through resets of some worlds);
what a callable returns outside its contract is a SuiteError at the sensor's line."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import SuiteError, assets  # noqa: E402
from sensorcfg.observables.generic import BatchedGeneric  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402

ROBOT = str(assets.path("robot.xml"))
HAND = mujoco.MjModel.from_xml_path(ROBOT).site("hand_site").id
NWORLD = 3
HERE = __name__  # the callables below, as a suite names them


@wp.kernel
def _height(site_xpos: wp.array2d[wp.vec3], site: int, out: wp.array[wp.float32]):
    w = wp.tid()
    out[w] = site_xpos[w, site][2]


def height(model, data):
    """The hand's height above the floor (z = 0) in every world: a new (nworld,) array each call."""
    out = wp.empty(data.site_xpos.shape[0], dtype=wp.float32)
    wp.launch(_height, dim=out.shape[0], inputs=[data.site_xpos, HAND], outputs=[out])
    return out


def sites(model, data):
    """Every site's position (an (nworld, nsite) array of vec3: values (nsite, 3)), the same array each call."""
    return data.site_xpos


def hand_slice(model, data):
    """A strided view of the hand's row of `site_xpos`: values (1, 3)."""
    return data.site_xpos[:, HAND:HAND + 1]


def in_float64(model, data):
    return wp.zeros(data.qpos.shape[0], dtype=wp.float64)


def too_few_rows(model, data):
    return wp.zeros(data.qpos.shape[0] - 1, dtype=wp.float32)


def on_the_host(model, data):
    return data.qpos.numpy()


def failing(model, data):
    return 1 / 0


NOT_A_FUNCTION = 3

# the same schedules, delays, buffers, aggregators and noise (keyed by the sensors' names) over a batched generic
# callable and over the mjData field its values come from
SCHEDULES = {
    "h": "interval: 3, delay: 2, buffer: 4, aggregator: mean, noise: [{type: gaussian, std: 0.01}, {type: bias, "
         "std: 0.1}]",
    "hands": "interval: 2, buffer: 2, twin: hands_clean, noise: [{type: dropout, p: 0.3}, {type: quantize, "
             "step: 0.001}, {type: misalign, std: 2deg}]",
    "drawn": "interval: {uniform: [1, 3]}, delay: {choice: [0, 2]}, buffer: 2, noise: [{type: gaussian, std: 0.01}]",
}
GENERIC = {"h": f"kind: generic, callable: '{HERE}:height', batched: true",
           "hands": f"kind: generic, callable: '{HERE}:sites', batched: true",
           "drawn": f"kind: generic, callable: '{HERE}:height', batched: true"}
FIELD = {"h": "kind: xpos, element: site:hand_site, index: 2",
         "hands": "kind: xpos, element: 'site:*'",
         "drawn": "kind: xpos, element: site:hand_site, index: 2"}


def suite(tmp_path, name: str, kinds: dict[str, str]) -> str:
    lines = [f"  {sensor}: {{{kinds[sensor]}, {settings}}}" for sensor, settings in SCHEDULES.items()]
    path = tmp_path / f"{name}.yaml"
    path.write_text("sensors:\n" + "\n".join(lines) + "\n  pos: {kind: qpos, element: joint:elbow, interval: 2}\n")
    return str(path)


def env(source, nworld: int = NWORLD, **kwargs) -> WarpEnvironment:
    return WarpEnvironment(ROBOT, source, nworld, device="cpu", physics_steps_per_control_step=2, **kwargs)


def test_a_batched_callable_reads_what_the_same_schedule_reads_from_its_field(tmp_path) -> None:
    """Every read of the batched sensors (intervals above 1, delays, buffers with an aggregator, noise with
    values drawn per episode, misalign, dropout, a clean twin, a drawn schedule) equals, to the bit, the read of
    suite sensors of the same names reading the mjData field the callable's kernel copies, through time-limit
    restarts and the reset of one world."""
    generic = env(suite(tmp_path, "generic", GENERIC), seed=5, time_limit=0.002 * 2 * 5)
    field = env(suite(tmp_path, "field", FIELD), seed=5, time_limit=0.002 * 2 * 5)
    assert generic.observation_spec() == field.observation_spec()
    rng = np.random.default_rng(0)
    seen: set[bytes] = set()
    for t in range(14):
        actions = rng.uniform(-1, 1, (NWORLD, generic._model.nu)).astype(np.float32)
        steps = [e.reset() if t == 0 else e.reset([1]) if t == 6 else e.step(actions) for e in (generic, field)]
        assert steps[0].step_type.numpy().tolist() == steps[1].step_type.numpy().tolist()
        for name, read in steps[1].observation.items():
            got = steps[0].observation[name].numpy()
            assert got.tobytes() == read.numpy().tobytes(), f"{name} at control step {t}"
            seen.add(got.tobytes())
    assert len(seen) > 40  # the reads move: not a constant that would agree trivially
    z = generic.data.site_xpos.numpy()[:, HAND, 2]
    assert 0.05 < np.abs(z).min() and np.all(np.isfinite(z))


def test_a_noise_free_read_is_what_the_callable_returned_at_the_step(tmp_path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(f"sensors:\n  z: {{kind: generic, callable: '{HERE}:height', batched: true}}\n")
    e = env(str(path), 2)
    for t in range(3):
        step = e.reset() if t == 0 else e.step(np.zeros((2, e._model.nu), np.float32))
        np.testing.assert_array_equal(step.observation["z"].numpy()[:, 0], e.data.site_xpos.numpy()[:, HAND, 2])
    assert e.observation_spec()["z"].shape == (2, 1)


DEVICES = ["cpu", *(["cuda:0"] if wp.is_cuda_available() else [])]


@pytest.mark.parametrize("device", DEVICES)
def test_in_one_environment_a_callable_reads_what_its_field_reads(tmp_path, device: str) -> None:
    """On a CUDA device the control step is replayed as a CUDA graph (from the second step): the callables'
    launches (and a new array each call) are replayed with it, and read what the field they copy reads; a
    strided view is copied as its values."""
    settings = "interval: 2, delay: 1, buffer: 3"
    path = tmp_path / "s.yaml"
    path.write_text(f"sensors:\n  h: {{{GENERIC['h']}, {settings}, aggregator: mean}}\n"
                    f"  h_field: {{{FIELD['h']}, {settings}, aggregator: mean}}\n"
                    f"  hands: {{{GENERIC['hands']}, {settings}}}\n  hands_field: {{{FIELD['hands']}, {settings}}}\n"
                    f"  hand: {{kind: generic, callable: '{HERE}:hand_slice', batched: true, {settings}}}\n"
                    f"  hand_field: {{kind: xpos, element: site:hand_site, {settings}}}\n")
    e = WarpEnvironment(ROBOT, str(path), NWORLD, device=device, physics_steps_per_control_step=2, seed=1,
                        time_limit=0.002 * 2 * 4)
    rng = np.random.default_rng(1)
    for t in range(10):
        actions = wp.array(rng.uniform(-1, 1, (NWORLD, e._model.nu)).astype(np.float32), device=device)
        step = e.reset() if t == 0 else e.reset([2]) if t == 5 else e.step(actions)
        for name in ("h", "hands", "hand"):
            assert step.observation[name].numpy().tobytes() == step.observation[f"{name}_field"].numpy().tobytes(), \
                f"{name} at control step {t}"
    assert e._graph is not None or device == "cpu"


@pytest.mark.parametrize(("callable_", "message"), [
    ("in_float64", "returned a Warp array of float64 values; a batched callable returns an (2, ...) float32 Warp "
                   "array on the engine's device (cpu), filled by Warp kernels (convert in its kernel)"),
    ("too_few_rows", "returned a Warp array of shape (1,), whose first axis is not the 2 worlds"),
    ("on_the_host", "returned a numpy array (2, "),
    ("failing", "calling it with MuJoCo Warp's Model and Data raised ZeroDivisionError: division by zero"),
])
def test_what_a_callable_returns_outside_its_contract_is_an_error_at_its_line(tmp_path, callable_, message) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(f"sensors:\n  pos: {{kind: qpos, element: joint:elbow}}\n  bad:\n    kind: generic\n"
                    f"    callable: '{HERE}:{callable_}'\n    batched: true\n")
    with pytest.raises(SuiteError) as raised:
        env(str(path), 2)
    text = str(raised.value)
    assert text.startswith(f"{path}:5:15: error: sensors.bad.callable: generic sensor 'bad': "), text
    assert message in text and "Traceback" not in text


def test_a_callable_that_is_no_function_and_noise_that_does_not_fit_are_errors_at_their_lines(tmp_path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(f"sensors:\n  thing: {{kind: generic, callable: '{HERE}:NOT_A_FUNCTION', batched: true}}\n"
                    f"  z:\n    kind: generic\n    callable: '{HERE}:height'\n    batched: true\n"
                    "    noise: [{type: gaussian, std: [0.1, 0.2]}]\n")
    with pytest.raises(SuiteError) as raised:
        env(str(path), 2)
    assert str(raised.value).startswith(f"{path}:2:"), str(raised.value)
    assert f"sensors.thing.callable: '{HERE}:NOT_A_FUNCTION' is a int, not a function" in str(raised.value)
    path.write_text(path.read_text().replace(f"  thing: {{kind: generic, callable: '{HERE}:NOT_A_FUNCTION', "
                                             "batched: true}\n", ""))
    with pytest.raises(SuiteError) as raised:
        env(str(path), 2)
    assert str(raised.value).startswith(f"{path}:6:"), str(raised.value)
    assert "sensors.z.noise.0.std: 2 entries do not fit the observation's shape ()" in str(raised.value)


def test_a_per_simulation_generic_is_refused_with_batched_as_the_fix(tmp_path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(f"sensors:\n  z: {{kind: generic, callable: '{HERE}:height'}}\n")
    with pytest.raises(SuiteError, match=r"s.yaml:2:\d+: error: sensors.z.kind: a generic callable runs Python per "
                                         r"sample .*'batched: true' with a callable that takes every world at once"):
        env(str(path), 2)


def test_python_observables_name_the_sensor() -> None:
    obs = {"pos": sensorcfg.Feature("qpos", "joint:elbow"), "bad": BatchedGeneric(in_float64)}
    for o in obs.values():
        o.enabled = True
    with pytest.raises(SuiteError, match=r"generic sensor 'bad': returned a Warp array of float64 values"):
        env(obs, 2)
    with pytest.raises(TypeError, match="BatchedGeneric needs a callable"):
        BatchedGeneric(NOT_A_FUNCTION)  # type: ignore[arg-type]
    obs["bad"] = BatchedGeneric(height, noise_stages=[{"type": "misalign", "std": 0.01}])
    obs["bad"].enabled = True
    with pytest.raises(SuiteError, match=r"sensors.bad.noise.0.type: misalign turns 3-vectors"):
        env(obs, 2)


def test_a_callable_whose_value_changes_shape_is_an_error_naming_the_sensor() -> None:
    calls = []

    def growing(model, data):
        calls.append(1)
        return wp.zeros((data.qpos.shape[0], 1 if len(calls) == 1 else 2), dtype=wp.float32)

    obs = {"z": BatchedGeneric(growing)}
    obs["z"].enabled = True
    e = env(obs, 2)
    with pytest.raises(SuiteError, match=r"generic sensor 'z': returned a Warp array of shape \(2, 2\) float32, but "
                                         r"its first had shape \(2, 1\) float32; a sensor's value keeps one shape"):
        e.reset()
