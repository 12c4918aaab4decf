"""Height scans on the Warp engine (`sensorcfg.warp.rays`, MuJoCo Warp's `rays`) on Warp's CPU device: world w
reads what the single-simulation Updater reads on the same trajectory (heights to float32 rounding, hits and
misses exactly), with intervals, delays, buffers, noise and the reset of some worlds; and a WarpEnvironment
with a height scan end to end."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402
from sensorcfg.draws import episode_entropy  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402
from sensorcfg.plan.bind import bind  # noqa: E402
from sensorcfg.warp import rays  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402
from sensorcfg.warp.layer import episode_keys  # noqa: E402
from sensorcfg.warp.sensors import Sensors  # noqa: E402

# a floor (x, y in [-2, 2]), a heightfield ramp over x in [2.2, 4.2] (a gap between them where rays miss), a
# turned box, a sphere, a mesh, a cylinder, an ellipsoid, a capsule, a box in group 3, and a free body drifting
# and turning above them (no gravity)
TERRAIN = """<mujoco>
  <option timestep="0.002" gravity="0 0 0"/>
  <asset>
    <hfield name="ramp" nrow="3" ncol="5" size="1 1 0.5 0.1"
            elevation="0 0.25 0.5 0.75 1  0 0.25 0.5 0.75 1  0 0.25 0.5 0.75 1"/>
    <mesh name="tet" vertex="0 0 0  .6 0 0  0 .6 0  0 0 .5"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 .1"/>
    <geom name="ramp" type="hfield" hfield="ramp" pos="3.2 0 0"/>
    <geom name="block" type="box" size=".3 .2 .15" pos=".8 .5 .15" euler="0 0 25"/>
    <geom name="ball" type="sphere" size=".3" pos="-.7 -.6 0"/>
    <geom name="spike" type="mesh" mesh="tet" pos="1.2 -1 0" euler="0 0 20"/>
    <geom name="drum" type="cylinder" size=".15 .1" pos="1.3 .15 .1"/>
    <geom name="egg" type="ellipsoid" size=".2 .15 .1" pos=".35 .65 .05" euler="0 0 40"/>
    <geom name="log" type="capsule" size=".08 .25" pos="-.2 -.5 .08" euler="90 0 0"/>
    <geom name="hidden" type="box" size=".4 .4 .3" pos="-.6 .7 .3" group="3"/>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <geom type="box" size=".2 .1 .05"/>
      <site name="imu" pos=".05 .02 .03" euler="10 5 30"/>
    </body>
  </worldbody>
</mujoco>"""

SUITE = """sensors:
  grid:
    kind: heightscan
    element: body:base
    scan: {size: [1.2, 0.8], resolution: 0.2, max_distance: 3.0, geomgroup: [0, 1, 2]}
    interval: 4ms
    delay: 2ms
    buffer: 2
    noise: [{type: gaussian, std: 0.01}, {type: bias, std: 0.05}]
  ring:
    kind: heightscan
    element: site:imu
    scan: {pattern: ring, radii: [0.25, 0.6], count: 7, alignment: full, above: 0.5, miss: -1.0}
    interval: 6ms
    noise: [{type: dropout, p: 0.2, mode: hold}]
  level:
    kind: heightscan
    element: body:base
    scan: {size: [0.6, 0.6], resolution: 0.3, alignment: world}
  pos: {kind: qpos, element: "joint:*", interval: 4ms}
"""


# where each world starts, drifting from there: over the mesh, the ramp, the box; restarted over the ball, the gap
PLACES = [(1.3, -0.9), (3.2, 0.1), (0.8, 0.4), (-0.7, -0.5), (2.1, 0.0)]


def _state(model: mujoco.MjModel, rng: np.random.Generator, place: tuple[float, float]) -> mujoco.MjData:
    """A pose over `place` drifting and turning (no gravity: it keeps flying)."""
    data = mujoco.MjData(model)
    data.qpos[:3] = [*place, rng.uniform(0.7, 1.3)]
    quat = rng.normal(size=4) * [4, 0.3, 0.3, 1]  # mostly upright, any heading
    data.qpos[3:7] = quat / np.linalg.norm(quat)
    data.qvel[:] = rng.uniform(-1.5, 1.5, 6)
    mujoco.mj_forward(model, data)
    return data


def _fields(datas: list[mujoco.MjData], names: list[str]) -> dict[str, wp.array]:
    return {f: wp.array(np.stack([np.ravel(getattr(d, f)) for d in datas]).astype(np.float32), dtype=wp.float32,
                        device="cpu") for f in names}


def test_world_w_scans_what_the_updater_scans_on_the_same_trajectory() -> None:
    """Three worlds, 39 physics steps, worlds 0 and 2 restarted after the 13th (from new states, with new keys):
    each read of each world equals its Updater's to float32 rounding, misses included (a miss reads the same),
    and a scan is cast only at steps some world's schedule takes a sample at."""
    model = mujoco.MjModel.from_xml_string(TERRAIN)
    loaded = sensorcfg.loads(SUITE)
    make = lambda: {n: o for n, o in loaded.build(model).items() if o.enabled}  # noqa: E731
    nworld, substeps = 3, 1
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    bound, plan = rays.plan(bind(make(), physics, substeps, False), physics, nworld, substeps, False)
    assert [s.name for s in plan.sensors] == ["pos", "grid", "ring", "level"]
    device = wp.get_device("cpu")
    sensors = Sensors(plan, device, 2)
    scans = rays.Scans(model, plan, bound, device)
    names = sorted({f for f, _ in plan.fields if f not in scans.heights} | set(scans.pose_fields))
    table = np.zeros(sensors.episodes.key_table.shape, np.uint64)
    values = np.zeros(sensors.episodes.value_table.shape)
    for w in range(nworld):  # episode 0 seeded 100 + w, episode 1 (the restarted worlds') 200 + w
        for e, seed in enumerate((100 + w, 200 + w)):
            table[w, e], values[w, e] = episode_keys(sensors, episode_entropy(np.random.RandomState(seed)))
    sensors.episodes.key_table.assign(table)
    sensors.episodes.value_table.assign(values)

    rng = np.random.default_rng(0)
    datas = [_state(model, rng, PLACES[w]) for w in range(nworld)]
    updaters = [sensorcfg.Updater(make(), substeps) for _ in range(nworld)]
    for w, u in enumerate(updaters):
        u.reset(Physics(model, datas[w]), np.random.RandomState(100 + w))
    steps = np.zeros(nworld, np.int64)
    warp_steps = wp.zeros(nworld, dtype=wp.int64, device="cpu")
    everyone = wp.ones(nworld, dtype=wp.int32, device="cpu")
    fields = {**_fields(datas, names), **scans.heights}
    scans.cast(fields, warp_steps, every=True)
    sensors.reset(everyone, fields, warp_steps)
    seen = {"hit": 0, "miss": 0}
    cast = {"grid": 0, "ring": 0, "level": 0}
    for t in range(41):
        if t == 14:  # worlds 0 and 2 restart
            restarted = [0, 2]
            for w, place in zip(restarted, PLACES[3:]):
                datas[w] = _state(model, rng, place)
                updaters[w].reset(Physics(model, datas[w]), np.random.RandomState(200 + w))
                steps[w] = 0
            warp_steps.assign(steps)
            fields = {**_fields(datas, names), **scans.heights}
            mask = wp.array(np.isin(np.arange(nworld), restarted).astype(np.int32), dtype=wp.int32, device="cpu")
            scans.cast(fields, warp_steps, every=True)
            sensors.reset(mask, fields, warp_steps)
        elif t:
            for w, u in enumerate(updaters):
                u.control_step(lambda w=w: mujoco.mj_step(model, datas[w]))
            steps += 1
            warp_steps.assign(steps)
            fields = {**_fields(datas, names), **scans.heights}
            for heights in scans.heights.values():
                heights.fill_(np.nan)  # a row no read shows may hold anything: a read of one would fail
            scans.cast(fields, warp_steps)
            for record in plan.sensors[1:]:  # cast only at steps some world's schedule takes a sample at
                due = record.timing.taken[steps % record.timing.period].any()
                assert np.isnan(scans.heights[record.source.field].numpy()).all() == (not due), (t, record.name)
                cast[record.name] += int(due)
            sensors.record(fields, warp_steps)
        got = {name: array.numpy() for name, array in sensors.read(warp_steps).items()}
        for w, u in enumerate(updaters):
            for name, value in u.get_observation().items():
                assert got[name][w].shape == value.shape, name
                np.testing.assert_allclose(got[name][w], value, rtol=0, atol=2e-5, err_msg=f"world {w} t {t} {name}")
                if name == "level":
                    seen["miss"] += int(np.sum(value == 4.0))  # max_distance - above
                    seen["hit"] += int(np.sum(value != 4.0))
    assert seen["miss"] > 10 and seen["hit"] > 100  # both hits and misses were compared
    # of 39 steps: the first 13 every other, every third, each; then worlds 0 and 2 run 13 steps behind world 1,
    # so a scan is due where either phase takes a sample
    assert cast == {"grid": 6 + 26, "ring": 4 + 17, "level": 39}


def test_a_warp_environment_scans_each_worlds_own_pose() -> None:
    """The bundled robot's base scans the floor and the static target sphere: after each control step and
    reset (world 1's alone at the fourth), a world's scan is the CPU rule (`HeightScan`'s own sampler) applied
    to its float32 pose in MuJoCo Warp's Data, to float32 rounding; the observation spec has the world axis."""
    path = str(assets.path("robot.xml"))
    loaded = sensorcfg.loads("sensors:\n  scan: {kind: heightscan, element: body:base, scan: {size: [1.4, 0.6], "
                             "resolution: 0.1, above: 0.5}}\n")
    env = WarpEnvironment(path, loaded, 2, device="cpu", physics_steps_per_control_step=2, seed=0)
    assert env.observation_spec()["scan"].shape == (2, 1, 15, 7)  # (world, buffer, x, y)
    model = mujoco.MjModel.from_xml_path(path)
    physics = Physics(model)
    cpu = loaded.build(model)["scan"].observation_callable(physics)
    base = model.body("base").id
    actions = np.random.default_rng(0).uniform(-1, 1, (8, 2, model.nu)).astype(np.float32)
    step = env.reset()
    for t in range(8):
        if t == 4:  # world 1 restarts (every world's forward runs: world 0's pose is no longer the one it scanned)
            step = env.reset([1])
        elif t:
            step = env.step(actions[t])
        xpos, xmat = env.data.xpos.numpy(), env.data.xmat.numpy()
        for w in ([1] if t == 4 else [0, 1]):
            physics.data.xpos[base], physics.data.xmat[base] = xpos[w, base], xmat[w, base].ravel()
            np.testing.assert_allclose(step.observation["scan"].numpy()[w, 0], cpu(), rtol=0, atol=1e-5,
                                       err_msg=f"control step {t}, world {w}")
    assert np.ptp(step.observation["scan"].numpy()) > 0.01  # the target sphere, off the floor, is seen


# TERRAIN with an SDF geom (a mesh's, group 4) on the floor: MuJoCo Warp's ray caster reads an SDF as a miss
SDF = TERRAIN.replace('<geom name="hidden"',
                      '<geom name="blob" type="sdf" mesh="tet" pos="-1 1 0" group="4"/>\n    <geom name="hidden"')
SEEING = """sensors:
  sees: {kind: heightscan, element: body:base}
  blind: {kind: heightscan, element: body:base, scan: {geomgroup: [0, 1, 2, 3]}}
"""


def test_a_scan_whose_rays_would_meet_a_geom_mujoco_warp_does_not_cast_is_refused_at_its_line() -> None:
    model = mujoco.MjModel.from_xml_string(SDF)
    assert model.geom("blob").type[0] == mujoco.mjtGeom.mjGEOM_SDF
    suite = sensorcfg.loads(SEEING, file="s.yaml")
    message = ("its rays would meet geom 'blob' (type sdf), which MuJoCo Warp's ray caster does not cast (it would "
               "read as a miss); leave it out of this scan's geomgroup, or run this suite on the CPU engines")
    reported = suite.check(model, warp=True)
    assert [(p.line, p.loc, p.message) for p in reported] == [(2, "sensors.sees.kind", message)]
    assert suite.check(model, batch=True) == []
    with pytest.raises(sensorcfg.SuiteError) as refused:
        WarpEnvironment(model, suite, 1, device="cpu")
    assert [(p.loc, p.message) for p in refused.value.problems] == [("sensors.sees.kind", message)]
