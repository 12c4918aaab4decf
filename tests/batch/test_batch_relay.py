"""Relays (`sensorcfg.batch.relay`): a batch given the model as a path (or an MjSpec) reads the few values of
a wide field through MuJoCo sensors that copy them, with the same observations to the bit."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.batch import BatchEnvironment, relay, sim_seed
from sensorcfg.batch.layout import Source
from sensorcfg.draws import UniformSteps
from sensorcfg.noise import build_noise
from sensorcfg.physics import Physics

from conftest import ROOT, TESTS

MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4
needs_batch = pytest.mark.skipif(not MUJOCO4, reason=f"mujoco.batch needs MuJoCo 4; this is {mujoco.__version__}")

# Many bodies, sites and geoms (wide fields), each read for one element; one body has no name.
MODEL = """
<mujoco>
  <option integrator="{integrator}" timestep="0.004"/>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 .1"/>
    <body name="base" pos="0 0 1">
      <joint name="j0" type="hinge" axis="0 0 1" damping=".1"/>
      <geom name="g0" type="capsule" fromto="0 0 0 .3 0 0" size=".04" mass="1"/>
      <site name="s0" pos=".3 0 0"/>
      <camera name="eye" pos=".1 0 .1" xyaxes="0 -1 0 0 0 1"/>
      <camera name="left" pos="0 .2 .1"/>
      <camera name="right" pos="0 -.2 .1"/>
      <camera name="top" pos="0 0 .5"/>
      <body name="arm" pos=".3 0 0">
        <joint name="j1" type="hinge" axis="0 1 0" damping=".1"/>
        <geom name="g1" type="capsule" fromto="0 0 0 .3 0 0" size=".03" mass=".5"/>
        <site name="s1" pos=".15 0 0"/>
        <site name="tip" pos=".3 0 0"/>
        <body pos=".3 0 0">
          <joint name="j2" type="hinge" axis="1 0 0" damping=".1"/>
          <geom name="g2" type="box" size=".05 .03 .02" pos=".05 .01 0" mass=".2"/>
          <site name="s2" pos=".1 0 0"/>
          <body name="hand" pos=".1 0 0" quat=".9 .1 .3 .2">
            <joint name="j3" type="hinge" axis="0 0 1" damping=".1"/>
            <geom name="g3" type="sphere" size=".04" pos=".02 .01 0" mass=".1"/>
            <site name="s3" pos=".05 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="m0" joint="j0" ctrlrange="-1 1"/>
    <motor name="m1" joint="j1" ctrlrange="-1 1"/>
    <motor name="m2" joint="j2" ctrlrange="-1 1"/>
  </actuator>
  <sensor>
    <jointpos name="own_j1" joint="j1"/>
    <framepos name="own_tip" objtype="site" objname="tip"/>
  </sensor>
</mujoco>
"""

# kind, element: each read after every substep (buffers of 3), from a wide field
RELAYED = [
    ("xquat", "body:hand"), ("xmat", "body:arm"), ("xpos", "body:hand"), ("xipos", "body:arm"),
    ("ximat", "body:hand"), ("subtree_com", "body:arm"), ("xpos", "geom:g2"), ("xmat", "geom:g3"),
    ("xpos", "site:s2"), ("xmat", "site:tip"), ("xpos", "camera:eye"), ("xmat", "camera:eye"),
]
FIELDS = {"xquat", "xmat", "xpos", "xipos", "ximat", "subtree_com", "geom_xpos", "geom_xmat", "site_xpos",
          "site_xmat", "cam_xpos", "cam_xmat"}


def model_file(tmp_path, integrator: str = "Euler") -> str:
    path = tmp_path / f"arm_{integrator}.xml"
    path.write_text(MODEL.format(integrator=integrator))
    return str(path)


def suite(path: str, extra: tuple = ()) -> dict[str, sensorcfg.Observable]:
    """The relayed reads, one with noise added as the batch reads, one with a drawn delay, and the model's
    own sensors (whose sensordata positions relays must not move)."""
    physics = Physics(mujoco.MjModel.from_xml_path(path))
    out = {}
    for j, (kind, element) in enumerate([*RELAYED, *extra, ("sensordata", ["sensor:own_j1", "sensor:own_tip"])]):
        obs = sensorcfg.Feature(kind, element, buffer_size=3, aggregator="mean" if j % 3 == 1 else None,
                                delay=UniformSteps(0, 3) if j == 4 else j % 2)
        obs.reader(physics)
        if j in (0, 5):
            spec = obs.array_spec
            obs.noise = build_noise([{"type": "gaussian", "std": 0.01}], spec.shape, spec.dtype, physics.timestep)
        obs.enabled = True
        out[f"o{j}_{kind}"] = obs
    return out


def relay_sensors(model: mujoco.MjModel) -> list[str]:
    return [model.sensor(i).name for i in range(model.nsensor) if model.sensor(i).name.startswith("sensorcfg:relay:")]


def run(env: BatchEnvironment, steps: int = 24) -> list[dict[str, np.ndarray]]:
    spec = env.action_spec()
    actions = np.random.default_rng(3).uniform(spec.minimum, spec.maximum, (steps, *spec.shape))
    out = [env.reset().observation]
    for s, a in enumerate(actions):
        if s == 11:
            out.append(env.reset([1]).observation)
        out.append(env.step(a).observation)
    return out


def same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(a[k].dtype == b[k].dtype and a[k].tobytes() == b[k].tobytes() for k in a)


@needs_batch
@pytest.mark.parametrize("integrator", ["Euler", "implicit", "implicitfast"])
def test_relayed_reads_are_the_fields_values_bit_for_bit(tmp_path, integrator):
    path = model_file(tmp_path, integrator)
    relayed = BatchEnvironment(path, suite(path), 3, physics_steps_per_control_step=3, seed=5)
    as_written = BatchEnvironment(mujoco.MjModel.from_xml_path(path), suite(path), 3,
                                  physics_steps_per_control_step=3, seed=5)
    recorded = relayed.updater.layout.recorded()
    assert not FIELDS & recorded.keys() and "sensordata" in recorded  # every wide field is read through relays
    assert FIELDS <= as_written.updater.layout.recorded().keys()  # an MjModel cannot take sensors: recorded
    names = relay_sensors(relayed._model)
    assert {n.split(":")[2] for n in names} == FIELDS
    plain = mujoco.MjModel.from_xml_path(path)
    assert relayed._model.nsensordata > plain.nsensordata
    assert list(relayed._model.sensor_adr[:plain.nsensor]) == list(plain.sensor_adr)  # the model's own stay put
    for s, (a, b) in enumerate(zip(run(relayed), run(as_written))):
        assert same(a, b), f"step {s}"


@needs_batch
def test_each_relayed_simulation_is_the_single_environment(tmp_path):
    path = model_file(tmp_path)
    env = BatchEnvironment(path, suite(path), 2, physics_steps_per_control_step=2, seed=9)
    assert relay_sensors(env._model)
    singles = [sensorcfg.Environment(path, suite(path), physics_steps_per_control_step=2, seed=sim_seed(9, i))
               for i in range(2)]
    spec = env.action_spec()
    actions = np.random.default_rng(1).uniform(spec.minimum, spec.maximum, (20, *spec.shape))
    batch = [env.reset()] + [env.step(a) for a in actions]
    for i, single in enumerate(singles):
        steps = [single.reset()] + [single.step(a[i]) for a in actions]
        for s, (b, one) in enumerate(zip(batch, steps)):
            for k, v in one.observation.items():
                assert b.observation[k][i].tobytes() == v.tobytes(), f"sim {i} step {s} {k}"


@needs_batch
def test_rk4_keeps_recording_the_fields(tmp_path):
    """With RK4 the fields hold the last of four evaluations and sensors the first: relays would be wrong."""
    path = model_file(tmp_path, "RK4")
    env = BatchEnvironment(path, suite(path), 2, physics_steps_per_control_step=3, seed=5)
    assert not relay_sensors(env._model) and FIELDS <= env.updater.layout.recorded().keys()
    plain = mujoco.MjModel.from_xml_path(path)
    layout = env.updater.layout
    assert relay.choose(plain, layout.sources, layout.recorded(), 3) is None


@needs_batch
def test_a_field_read_at_an_unnamed_element_is_recorded(tmp_path):
    """Relay sensors name their element: the third link (body 3) has no name, so its xquat stays recorded."""
    model = mujoco.MjModel.from_xml_path(model_file(tmp_path))
    assert mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, 3) is None
    sources = [Source("xquat", np.arange(12, 16)), Source("xmat", np.arange(18, 27))]
    chosen = relay.choose(model, sources, {"xquat": 3, "xmat": 3}, 3)
    assert chosen is not None and set(chosen.copies) == {"xmat"}
    named = relay.choose(model, [Source("xquat", np.arange(16, 20))], {"xquat": 3}, 3)
    assert named is not None and set(named.copies) == {"xquat"}


@needs_batch
def test_relays_that_do_not_copy_are_not_used(tmp_path, monkeypatch):
    path = model_file(tmp_path)
    model = mujoco.MjModel.from_xml_path(path)
    sources = [Source("site_xmat", np.arange(27, 36)), Source("xquat", np.arange(4, 8))]
    chosen = relay.choose(model, sources, {"site_xmat": 3, "xquat": 3}, 3)
    assert chosen is not None
    compiled = sensorcfg.native.compile_model(path, {}, False, chosen.records)[0]
    where = relay.positions(compiled, chosen)
    assert relay.exact(compiled, where)
    swapped = {f: dict(zip(m, reversed(list(m.values())))) for f, m in where.items()}  # a transposed copy
    assert not relay.exact(compiled, swapped)
    # an environment whose relays fail the check runs on the model as written
    monkeypatch.setattr(relay, "exact", lambda model, where: False)
    env = BatchEnvironment(path, suite(path), 2, physics_steps_per_control_step=3, seed=5)
    assert not relay_sensors(env._model) and FIELDS <= env.updater.layout.recorded().keys()


@needs_batch
def test_a_suite_file_and_a_spec_take_relays(tmp_path):
    path = model_file(tmp_path)
    text = "sensors:\n" + "".join(
        f"  r{j}:\n    kind: {kind}\n    element: '{element}'\n    buffer: 3\n" for j, (kind, element) in enumerate(RELAYED))
    suite_path = tmp_path / "suite.yaml"
    suite_path.write_text(text)
    loaded = sensorcfg.load(suite_path)
    from_path = BatchEnvironment(path, loaded, 2, physics_steps_per_control_step=3, seed=2)
    from_spec = BatchEnvironment(mujoco.MjSpec.from_file(path), sensorcfg.load(suite_path), 2,
                                 physics_steps_per_control_step=3, seed=2)
    as_written = BatchEnvironment(mujoco.MjModel.from_xml_path(path), sensorcfg.load(suite_path), 2,
                                  physics_steps_per_control_step=3, seed=2)
    assert relay_sensors(from_path._model) and relay_sensors(from_spec._model)
    for a, b, c in zip(run(from_path, 12), run(from_spec, 12), run(as_written, 12)):
        assert same(a, c) and same(b, c)


@needs_batch
def test_relays_next_to_a_camera_read_the_persistent_batchs_sensordata(tmp_path):
    """A camera makes the batch keep one MjData per simulation: reset samples come from there, relays too."""
    path = model_file(tmp_path)

    def with_camera() -> dict[str, sensorcfg.Observable]:
        out = suite(path)
        camera = sensorcfg.Camera("eye", width=32, height=24, update_interval=3)
        camera.enabled = True
        out["eye"] = camera
        return out

    relayed = BatchEnvironment(path, with_camera(), 2, physics_steps_per_control_step=3, seed=5)
    as_written = BatchEnvironment(mujoco.MjModel.from_xml_path(path), with_camera(), 2,
                                  physics_steps_per_control_step=3, seed=5)
    assert relayed.batch.persistent and relay_sensors(relayed._model)
    for s, (a, b) in enumerate(zip(run(relayed, 10), run(as_written, 10))):
        assert same(a, b), f"step {s}"


ORDER_SCRIPT = """
import json, pathlib, sys, tempfile
sys.path[:0] = sys.argv[1:]  # this test's folder, tests/ (its conftest) and the repository
import sensorcfg
from sensorcfg.batch import BatchEnvironment
from test_batch_relay import RELAYED, model_file

path = model_file(pathlib.Path(tempfile.mkdtemp()))
sensors = [f"  r{j}: {{kind: {kind}, element: '{element}', buffer: 3}}" for j, (kind, element) in enumerate(RELAYED)]
sensors += ["  ext: {kind: cfrc_ext, element: body:arm}", "  momentum: {kind: subtree_angmom, element: body:arm}",
            "  acc: {kind: cacc, element: body:hand}", "  linvel: {kind: subtree_linvel, element: body:base}",
            "  vel: {kind: velocimeter, element: body:hand}", "  gyro: {kind: gyro, element: 'body:*'}"]
suite = sensorcfg.loads("options: {control_interval: 3}\\nsensors:\\n" + "\\n".join(sensors) + "\\n")
model = BatchEnvironment(path, suite, 2, seed=0).batch.get_model(0)
print(json.dumps([[model.sensor(i).name for i in range(model.nsensor)], [model.site(i).name for i in range(model.nsite)]]))
"""


@needs_batch
def test_what_a_batch_adds_is_added_in_one_order_in_every_process() -> None:
    """Enablers, relays, native sensors and their sites: the same compiled model whatever the hash seed."""
    import json
    import os
    import subprocess
    import sys

    runs = []
    for seed in ("1", "2", "3", "4"):
        done = subprocess.run([sys.executable, "-c", ORDER_SCRIPT, str(TESTS / "batch"), str(TESTS), str(ROOT)],
                              capture_output=True, text=True, check=True, env={**os.environ, "PYTHONHASHSEED": seed})
        runs.append(json.loads(done.stdout))
    sensors = runs[0][0]
    assert sum(n.startswith("sensorcfg:relay:") for n in sensors) > 4
    assert sum(n.startswith("sensorcfg:on-demand:") for n in sensors) == 2
    assert all(run == runs[0] for run in runs[1:])
