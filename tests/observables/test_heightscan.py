"""`kind: heightscan` over a heightfield ramp of known shape: the analytic heights, misses, alignments.

The terrain model has a floor over x in [-2, 2] and a heightfield ramp over x in [3, 5] (height
(x - 3) / 4, exact on each triangle), with a gap between them where rays miss.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS, assert_batch_equals_single
from sensorcfg.heightscan import pattern
from sensorcfg.config.models import ScanConfig
from sensorcfg.physics import Physics

TERRAIN = str(MODELS / "terrain.xml")
MUJOCO4 = int(mujoco.__version__.split(".")[0]) >= 4


def _ground(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Terrain height, NaN where there is none."""
    on_floor = (np.abs(x) <= 2) & (np.abs(y) <= 2)
    on_ramp = (x >= 3) & (x <= 5) & (np.abs(y) <= 1)
    return np.where(on_floor, 0.0, np.where(on_ramp, (x - 3) / 4, np.nan))


def _scan(scan: str, qpos: list[float]) -> tuple[np.ndarray, Physics]:
    suite = sensorcfg.loads(f"sensors:\n  h: {{kind: heightscan, element: body:base, scan: {scan}}}\n")
    model = suite.compile(TERRAIN)
    physics = Physics(model)
    physics.data.qpos[:7] = qpos
    mujoco.mj_forward(model, physics.data)
    return suite.build(model)["h"].observation_callable(physics)(), physics


def _pose(x: float, y: float, z: float, yaw: float = 0.0, pitch: float = 0.0) -> list[float]:
    """A pose turned by `yaw` about the world z axis after pitching about its own y axis (heading = yaw)."""
    q = np.zeros(4)
    mujoco.mju_mulQuat(q, np.array([np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]),
                       np.array([np.cos(pitch / 2), 0, np.sin(pitch / 2), 0]))
    return [x, y, z, *q]


def test_grid_counts_both_ends() -> None:
    assert pattern(ScanConfig(size=(1.6, 1.0), resolution=0.1)).shape == (17, 11, 2)


@pytest.mark.parametrize("yaw", [0.0, 0.4, -2.0])
def test_yaw_aligned_grid_over_the_ramp_reads_the_analytic_heights(yaw: float) -> None:
    values, physics = _scan("{size: [1.6, 1.0], resolution: 0.1, miss: -7.5}", _pose(3.6, 0.1, 1.2, yaw, 0.3))
    offsets = pattern(ScanConfig(size=(1.6, 1.0), resolution=0.1))
    c, s = np.cos(yaw), np.sin(yaw)
    x = 3.6 + c * offsets[..., 0] - s * offsets[..., 1]
    y = 0.1 + s * offsets[..., 0] + c * offsets[..., 1]
    base_z = physics.data.xpos[physics.model.body("base").id, 2]
    expected = base_z - _ground(x, y)
    hit = ~np.isnan(expected)
    assert values.shape == (17, 11) and hit.sum() > 50 and (~hit).sum() >= 5  # ramp, floor and the gap
    np.testing.assert_allclose(values[hit], expected[hit], rtol=0, atol=1e-9)
    assert np.all(values[~hit] == -7.5)


def test_full_alignment_follows_the_tilt_and_reads_vertical_heights() -> None:
    pitch = 0.3
    values, physics = _scan("{pattern: ring, radii: [0.2, 0.4], count: 6, alignment: full, above: 0.5}",
                            _pose(4.3, 0.0, 1.0, 0.0, pitch))
    rot = physics.data.xmat[physics.model.body("base").id].reshape(3, 3)
    origin = physics.data.xpos[physics.model.body("base").id]
    offsets = pattern(ScanConfig(pattern="ring", radii=(0.2, 0.4), count=6))
    starts = origin + np.einsum("ij,...j->...i", rot, np.concatenate([offsets, np.full(offsets.shape[:-1] + (1,), 0.5)], -1))
    d = -rot[:, 2]
    t = (starts[..., 0] - 3 - 4 * starts[..., 2]) / (4 * d[2] - d[0])  # ray meets z = (x - 3) / 4
    hit_z = starts[..., 2] + t * d[2]
    np.testing.assert_allclose(values, origin[2] - hit_z, rtol=0, atol=1e-9)


def test_world_alignment_on_the_floor_reads_the_origin_height_and_misses_beyond_reach() -> None:
    values, _ = _scan("{pattern: ring, radii: [0.5], count: 8, alignment: world}", _pose(0.0, 0.0, 0.7, 1.0))
    np.testing.assert_allclose(values, 0.7, rtol=0, atol=1e-12)  # the robot's own legs are seen through
    short, _ = _scan("{pattern: ring, radii: [0.5], count: 8, max_distance: 1.5}", _pose(0.0, 0.0, 0.7))
    assert np.all(short == 1.5 - 1.0)  # default miss: max_distance - above


@pytest.mark.skipif(not MUJOCO4, reason="mujoco.batch needs MuJoCo 4")
def test_batched_scans_equal_single_ones() -> None:
    suite = sensorcfg.loads("options: {control_interval: 10}\nsensors:\n"
                            "  h: {kind: heightscan, element: site:imu, interval: 5, buffer: 2}\n"
                            "  r: {kind: heightscan, element: body:base, scan: {pattern: ring, alignment: full}}\n"
                            "  v: {kind: velocimeter, element: body:base}\n")
    assert_batch_equals_single(TERRAIN, suite, nsim=2, seed=3, steps=15)


@pytest.mark.skipif(not MUJOCO4, reason="mujoco.batch needs MuJoCo 4")
def test_noisy_batched_scans_equal_single_ones() -> None:
    """Noise on a height scan runs per simulation, stateful stages included, keyed as the single simulation."""
    suite = sensorcfg.loads("options: {control_interval: 10}\nsensors:\n"
                            "  h: {kind: heightscan, element: site:imu, interval: 5, buffer: 2,\n"
                            "      noise: [{type: gaussian, std: 0.01}, {type: lowpass, cutoff: 20Hz}]}\n"
                            "  r: {kind: heightscan, element: body:base, scan: {pattern: ring},\n"
                            "      noise: [{type: bias, std: 0.05}, {type: dropout, p: 0.2, mode: hold}]}\n"
                            "  v: {kind: velocimeter, element: body:base, noise: [{type: gaussian, std: 0.1}]}\n")
    assert_batch_equals_single(TERRAIN, suite, nsim=3, seed=5, steps=12)


@pytest.mark.parametrize("scan, expected", [
    pytest.param("{size: [1.0, 1.0], resolution: 0.3}", "f.yaml:2:51: error: sensors.h.scan: size along x (1 m) "
                 "is not a whole number of 0.3 m steps (3.33); use 0.9 or 1.2, or another resolution", id="grid"),
    pytest.param("{geomgroup: [7]}", "f.yaml:2:64: error: sensors.h.scan.geomgroup.0: expected a value <= 5; got 7",
                 id="group"),
])
def test_scan_mistakes_are_positioned(scan: str, expected: str) -> None:
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(f"sensors:\n  h: {{kind: heightscan, element: body:base, scan: {scan}}}\n", file="f.yaml")
    assert str(info.value) == expected


def test_a_scan_reads_one_frame() -> None:
    problems = sensorcfg.loads("sensors:\n  h: {kind: heightscan, element: geom:FL}\n", file="f.yaml").check(TERRAIN)
    assert [p.format() for p in problems] == ["f.yaml:2:34: error: sensors.h.element: a height scan is cast from "
                                              "one frame, 'body:<name>' or 'site:<name>'; got 'geom:FL'"]


@pytest.mark.parametrize("scan, expected", [
    pytest.param("{resolution: 5e-324}", "1.6 x 1 m every 4.94066e-324 m makes inf rays", id="subnormal-resolution"),
    pytest.param("{size: [100, 100], resolution: 0.01}", "100 x 100 m every 0.01 m makes 1e+08 rays", id="huge-grid"),
    pytest.param("{pattern: ring, radii: [1], count: 100000000000}", "1 ring of 100000000000 rays makes 1e+11 rays",
                 id="huge-ring"),
])
def test_a_scan_has_at_most_100000_rays(scan: str, expected: str) -> None:
    """Found by the fuzz test: a subnormal resolution raised OverflowError; a huge scan would fill memory."""
    with pytest.raises(sensorcfg.SuiteError) as e:
        sensorcfg.loads(f"sensors:\n  h: {{kind: heightscan, element: body:base, scan: {scan}}}\n", file="f.yaml")
    assert [(p.loc, p.message) for p in e.value.problems] == [
        ("sensors.h.scan", f"{expected}; a scan casts at most 100,000: use a coarser resolution, a smaller size or "
                           "fewer rays")]


_MATERIALS = """<mujoco><asset><material name="clear" rgba="1 1 1 0"/><material name="solid" rgba="1 1 1 1"/></asset>
<worldbody><geom type="plane" size="5 5 .1"/>
<geom name="glass" type="box" pos="0 0 .5" size=".4 .4 .1" material="clear" rgba="1 0 0 1"/>
<geom name="painted" type="box" pos="1 0 .3" size=".4 .4 .1" material="solid" rgba="1 0 0 0"/>
<geom name="hidden" type="box" pos="0 1 .4" size=".4 .4 .1" rgba="1 0 0 0"/>
<geom name="plain" type="box" pos="1 1 .2" size=".4 .4 .1"/>
<body name="base" pos=".5 .5 2"><freejoint/><geom size=".1"/></body></worldbody></mujoco>"""


def _mj_ray_heights(model: mujoco.MjModel, data: mujoco.MjData, size: tuple[float, float]) -> np.ndarray:
    """The heights of body 'base' above what `mj_ray` on the whole model meets, straight down from 0.5 above
    it on a grid of `size` at 0.1 (axes as the world's: the base upright, heading along x), the base excluded."""
    base = model.body("base").id
    origin = data.xpos[base]
    offsets = pattern(ScanConfig(size=size, resolution=0.1))
    expected = np.empty(offsets.shape[:-1])
    for index in np.ndindex(expected.shape):
        start = np.array([origin[0] + offsets[index][0], origin[1] + offsets[index][1], origin[2] + 0.5])
        dist = mujoco.mj_ray(model, data, start, np.array([0.0, 0.0, -1.0]), None, 1, base, None)
        expected[index] = origin[2] - (start[2] - dist)
    return expected


@pytest.mark.parametrize("batched", [pytest.param(False, id="single"),
                                     pytest.param(True, id="batch", marks=pytest.mark.skipif(
                                         not MUJOCO4, reason="mujoco.batch needs MuJoCo 4"))])
def test_a_scan_sees_what_mj_ray_sees_through_materials(batched: bool) -> None:
    """mj_ray skips a geom by its material's alpha where it has a material, else by its own rgba's: a box
    with a transparent material is seen through, one with alpha 0 and an opaque material is hit."""
    model = mujoco.MjModel.from_xml_string(_MATERIALS)
    suite = sensorcfg.loads("sensors:\n  h: {kind: heightscan, element: body:base,\n"
                            "      scan: {size: [2.0, 2.0], resolution: 0.1, alignment: world, above: 0.5}}\n")
    observable = suite.build(model)["h"]
    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    if batched:
        from mujoco import batch

        sims = batch.Batch(model, 1)
        reader = observable.batch_reader(model, sims)  # binds the frame's fields, which forward then fills
        sims.forward()
        values = reader(np.array([0]))[0]
    else:
        values = observable.observation_callable(physics)()
    expected = _mj_ray_heights(model, physics.data, (2.0, 2.0))
    heights = {round(float(v), 9) for v in expected.ravel()}
    assert heights == {2.0, 2.0 - 0.4, 2.0 - 0.3}  # the floor, 'painted' and 'plain'; 'glass' and 'hidden' unseen
    np.testing.assert_allclose(values, expected, rtol=0, atol=1e-9)


_SDF = """<mujoco><extension><plugin plugin="mujoco.sdf.torus"><instance name="torus">
<config key="radius1" value="0.35"/><config key="radius2" value="0.15"/></instance></plugin></extension>
<asset><mesh name="tet" vertex="0 0 0  1 0 0  0 1 0  0 0 1" scale=".5 .5 .5"/>
<mesh name="torus"><plugin instance="torus"/></mesh></asset>
<worldbody><geom type="plane" size="5 5 .1"/>
<geom name="blob" type="sdf" mesh="tet" pos="0 0 .1"/>{ring}
<body name="base" pos=".2 .2 2"><freejoint/><geom size=".1"/></body></worldbody></mujoco>"""
_RING = '\n<geom name="ring" type="sdf" mesh="torus" pos="2 2 .2"><plugin instance="torus"/></geom>'
_SCAN = "sensors:\n  h: {kind: heightscan, element: body:base, scan: {size: [1.0, 1.0], resolution: 0.1}}\n"


def test_a_scan_sees_an_sdf_of_a_mesh_as_mj_ray_does_and_refuses_one_a_plugin_computes() -> None:
    """An SDF geom of a mesh on the terrain is seen as mj_ray on the whole model sees it (the terrain model
    copies its mesh); one a plugin computes cannot be copied, which is said, not a MuJoCo compile error."""
    model = mujoco.MjModel.from_xml_string(_SDF.format(ring=""))
    env = sensorcfg.Environment(model, sensorcfg.loads(_SCAN))
    values = env.reset().observation["h"]
    physics = env.physics
    expected = _mj_ray_heights(model, physics.data, (1.0, 1.0))
    assert np.ptp(expected) > 0.1  # the blob is seen above the floor
    # mj_ray marches an SDF to its own tolerance from where the ray starts in each model's frame: 1e-6
    np.testing.assert_allclose(values.reshape(expected.shape), expected, rtol=0, atol=1e-6)
    with pytest.raises(sensorcfg.UnsupportedError, match="geom 'ring' is an SDF computed by a plugin"):
        sensorcfg.Environment(mujoco.MjModel.from_xml_string(_SDF.format(ring=_RING)), sensorcfg.loads(_SCAN))
