"""Feature values and shapes: exactly those of dm_control's `physics.bind(elements).<kind>`.

Oracle tests (skipped without dm_control, failing with SENSORCFG_REQUIRE_ORACLE=1) compare every kind
our table gives an element type, on every test model, for one element, a list of one, and lists of
several, value for value, shape for shape, dtype for dtype. The oracle-free tests pin the shapes that
matter by hand, on plain MuJoCo: free joint qpos 7, ball 4, hinge 1; one body's xpos (3,), a list of one
(1, 3); sensordata concatenated; index selection; globs in model order; `within`; names with '/'.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pytest
from conftest import MODELS

import sensorcfg
from sensorcfg.kinds import kinds_of

# -- against dm_control ---------------------------------------------------------------------------

ORACLE_MODELS = ("arm", "quadruped", "chain", "composed", "extras")
TYPES = ("joint", "body", "site", "geom", "camera", "sensor", "actuator", "tendon", "light", "material", "texture",
         "mesh", "hfield", "numeric", "equality")


def oracle_physics(oracle: Any, name: str) -> tuple[Any, Any]:
    """A moving dm_control physics of a test model (composed: pendulums attached as 'left/', 'right/')."""
    mjcf = oracle.mjcf
    if name == "composed":
        root = mjcf.from_path(str(MODELS / "chain.xml"))
        for prefix in ("left", "right"):
            child = mjcf.from_path(str(MODELS / "pendulum.xml"))
            child.model = prefix
            root.attach(child)
    else:
        root = mjcf.from_path(str(MODELS / f"{name}.xml"))
    physics = mjcf.Physics.from_mjcf_model(root)
    physics.reset(keyframe_id=0)
    physics.data.ctrl[:] = 0.3
    for _ in range(5):
        physics.step()
    return root, physics


def selector(type_name: str, elements: Any) -> Any:
    if isinstance(elements, list):
        return [f"{type_name}:{e.full_identifier}" for e in elements]
    return f"{type_name}:{elements.full_identifier}"


def named(root: Any, type_name: str) -> list[Any]:
    """Named elements of a type; dm_control binds mocap bodies as another type ('mocap_body')."""
    return [e for e in root.find_all(type_name) if e.full_identifier and not getattr(e, "mocap", False)]


def selections(elements: list[Any]) -> list[Any]:
    """One element (first and last), a list of one, all of them, and all reversed."""
    return [elements[0], elements[-1], [elements[0]], elements, elements[::-1]]


def assert_same(ours: Any, theirs: Any, where: str) -> None:
    theirs = np.asarray(theirs)
    assert np.shape(ours) == theirs.shape, f"{where}: shape {np.shape(ours)} != {theirs.shape}"
    assert np.asarray(ours).dtype == theirs.dtype, f"{where}: dtype"
    assert np.array_equal(ours, theirs), f"{where}: {ours!r} != {theirs!r}"


# The kinds this project promises (issue 2), per element type; each must exist in dm_control too.
PROMISED = [
    ("joint", kind) for kind in ("qpos", "qvel", "qacc", "range", "armature", "damping", "qfrc_actuator")
] + [
    ("body", kind) for kind in ("xpos", "xquat", "xmat", "cvel", "subtree_com", "mass", "inertia", "xipos")
] + [
    (t, kind) for t in ("site", "geom", "camera") for kind in ("xpos", "xmat")
] + [
    ("sensor", "sensordata"),
] + [
    ("actuator", kind) for kind in ("ctrl", "act", "force", "length", "velocity", "gear")
] + [
    ("tendon", kind) for kind in ("length", "velocity")
]


@pytest.fixture(scope="module")
def oracle_models(oracle: Any) -> dict[str, tuple[Any, Any]]:
    return {name: oracle_physics(oracle, name) for name in ORACLE_MODELS}


@pytest.mark.parametrize("type_name,kind", [pytest.param(t, k, id=f"{t}-{k}") for t, k in PROMISED])
def test_promised_kinds_match_bind(oracle_models: dict[str, tuple[Any, Any]], type_name: str, kind: str) -> None:
    checked = 0
    for model_name, (root, physics) in oracle_models.items():
        elements = named(root, type_name)
        if not elements:
            continue
        for elements_or_one in selections(elements):
            where = f"{model_name}: {kind} of {selector(type_name, elements_or_one)}"
            theirs = getattr(physics.bind(elements_or_one), kind)
            ours = sensorcfg.Feature(kind, selector(type_name, elements_or_one))(physics)
            assert_same(ours, theirs, where)
            checked += 1
    assert checked, f"no test model has a {type_name}"


def test_every_kind_matches_bind(oracle_models: dict[str, tuple[Any, Any]]) -> None:
    """Every kind our table lists that dm_control's bind also has (it lacks a few newer fields)."""
    checked, theirs_missing = 0, set()
    for model_name, (root, physics) in oracle_models.items():
        for type_name in TYPES:
            elements = named(root, type_name)
            if not elements:
                continue
            for kind in kinds_of(type_name):
                for elements_or_one in selections(elements):
                    try:
                        theirs = getattr(physics.bind(elements_or_one), kind)
                    except (AttributeError, KeyError, ValueError):
                        theirs_missing.add(f"{type_name}.{kind}")
                        continue
                    ours = sensorcfg.Feature(kind, selector(type_name, elements_or_one))(physics)
                    assert_same(ours, theirs, f"{model_name}: {kind} of {selector(type_name, elements_or_one)}")
                    checked += 1
    assert checked > 4000
    assert not {f"{t}.{k}" for t, k in PROMISED} & theirs_missing


def test_index_matches_mjcf_feature(oracle: Any, oracle_models: dict[str, tuple[Any, Any]]) -> None:
    root, physics = oracle_models["arm"]
    cases = [("qpos", "joint", "root", slice(3, 7)), ("xmat", "body", ["base", "hand"], (slice(None), 0)),
             ("sensordata", "sensor", ["accel", "gyro"], [5, 0, 2]), ("xpos", "site", "tip", -1)]
    for kind, type_name, names, index in cases:
        elements = [root.find(type_name, n) for n in names] if isinstance(names, list) else root.find(type_name, names)
        theirs = oracle.observable.MJCFFeature(kind, elements, index=index)(physics)
        ours = sensorcfg.Feature(kind, selector(type_name, elements), index=index)(physics)
        assert_same(ours, theirs, f"{kind}[{index!r}]")


def test_dirty_physics_is_brought_up_to_date(oracle: Any) -> None:
    """After a write through a binding, dm_control's bind runs mj_forward before reading derived values."""
    root = oracle.mjcf.from_path(str(MODELS / "arm.xml"))
    physics = oracle.mjcf.Physics.from_mjcf_model(root)
    physics.bind(root.find("joint", "root")).qpos[:3] = [1.0, 2.0, 3.0]
    assert physics.is_dirty
    qpos = sensorcfg.Feature("qpos", "joint:root")(physics)  # an input: read as is, no forward
    assert physics.is_dirty and qpos[:3].tolist() == [1.0, 2.0, 3.0]
    ours = sensorcfg.Feature("xpos", "body:base")(physics)  # derived: forward first, as bind would
    assert not physics.is_dirty
    np.testing.assert_array_equal(ours, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(ours, physics.bind(root.find("body", "base")).xpos)


# -- oracle-free: shapes by hand on plain MuJoCo ---------------------------------------------------


@pytest.fixture(scope="module")
def arm() -> sensorcfg.Physics:
    physics = sensorcfg.Physics.from_xml_path(str(MODELS / "arm.xml"))
    mujoco.mj_resetDataKeyframe(physics.model, physics.data, 0)
    physics.step(3)
    physics.forward()
    return physics


def jid(physics: sensorcfg.Physics, name: str) -> int:
    return mujoco.mj_name2id(physics.model, mujoco.mjtObj.mjOBJ_JOINT, name)


@pytest.mark.parametrize("kind,element,shape", [
    pytest.param("qpos", "joint:root", (7,), id="free-qpos"),
    pytest.param("qvel", "joint:root", (6,), id="free-qvel"),
    pytest.param("qpos", "joint:wrist", (4,), id="ball-qpos"),
    pytest.param("qvel", "joint:wrist", (3,), id="ball-qvel"),
    pytest.param("qpos", "joint:shoulder", (1,), id="hinge-qpos"),
    pytest.param("qpos", "joint:extend", (1,), id="slide-qpos"),
    pytest.param("qpos", ["joint:root", "joint:wrist", "joint:shoulder"], (12,), id="qpos-concatenated"),
    pytest.param("range", "joint:shoulder", (2,), id="range-one"),
    pytest.param("range", ["joint:shoulder", "joint:elbow"], (2, 2), id="range-list"),
    pytest.param("xpos", "body:base", (3,), id="xpos-one"),
    pytest.param("xpos", ["body:base"], (1, 3), id="xpos-list-of-one"),
    pytest.param("xmat", ["body:base", "body:hand"], (2, 9), id="xmat-list"),
    pytest.param("mass", "body:base", (), id="mass-scalar"),
    pytest.param("mass", ["body:base"], (1,), id="mass-list-of-one"),
    pytest.param("inertia", "body:hand", (3,), id="inertia"),
    pytest.param("xpos", "site:tip", (3,), id="site-xpos"),
    pytest.param("xpos", "geom:hand_geom", (3,), id="geom-xpos"),
    pytest.param("xmat", "camera:hand_cam", (9,), id="camera-xmat"),
    pytest.param("sensordata", "sensor:accel", (3,), id="sensor-3"),
    pytest.param("sensordata", "sensor:base_quat", (4,), id="sensor-4"),
    pytest.param("sensordata", "sensor:shoulder_pos", (1,), id="sensor-1"),
    pytest.param("sensordata", ["sensor:accel", "sensor:base_quat", "sensor:shoulder_pos"], (8,), id="sensor-list"),
    pytest.param("ctrl", "actuator:shoulder_motor", (), id="ctrl-scalar"),
    pytest.param("ctrl", ["actuator:shoulder_motor"], (1,), id="ctrl-list-of-one"),
    pytest.param("act", "actuator:extend_int", (), id="act-scalar"),
    pytest.param("act", "actuator:shoulder_motor", (0,), id="act-none"),
    pytest.param("gear", "actuator:shoulder_motor", (6,), id="gear"),
    pytest.param("length", "tendon:coupling", (), id="tendon-length"),
])
def test_shape(arm: sensorcfg.Physics, kind: str, element: Any, shape: tuple[int, ...]) -> None:
    feature = sensorcfg.Feature(kind, element)
    value = feature(arm)
    assert np.shape(value) == shape
    assert feature.array_spec.shape == shape


def test_values_are_the_model_arrays(arm: sensorcfg.Physics) -> None:
    m, d = arm.model, arm.data
    root, wrist = jid(arm, "root"), jid(arm, "wrist")
    qpos = sensorcfg.Feature("qpos", ["joint:wrist", "joint:root"])(arm)
    a, b = m.jnt_qposadr[wrist], m.jnt_qposadr[root]
    np.testing.assert_array_equal(qpos, np.concatenate([d.qpos[a:a + 4], d.qpos[b:b + 7]]))
    sensors = sensorcfg.Feature("sensordata", ["sensor:gyro", "sensor:accel"])(arm)
    gyro, accel = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, n) for n in ("gyro", "accel"))
    np.testing.assert_array_equal(sensors, np.concatenate([d.sensordata[m.sensor_adr[gyro]:m.sensor_adr[gyro] + 3],
                                                           d.sensordata[m.sensor_adr[accel]:m.sensor_adr[accel] + 3]]))
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "hand")
    assert sensorcfg.Feature("mass", "body:hand")(arm) == m.body_mass[body]
    np.testing.assert_array_equal(sensorcfg.Feature("xmat", ["body:hand"])(arm), d.xmat[[body]])


def test_reads_follow_the_simulation() -> None:
    physics = sensorcfg.Physics.from_xml_path(str(MODELS / "arm.xml"))
    mujoco.mj_resetDataKeyframe(physics.model, physics.data, 0)
    read = sensorcfg.Feature("qpos", "joint:root").observation_callable(physics)
    before = read()
    physics.step()
    after = read()
    assert not np.array_equal(before, after)
    np.testing.assert_array_equal(after, physics.data.qpos[:7])
    assert not np.shares_memory(after, physics.data.qpos)  # a sample is a copy, not a view


@pytest.mark.parametrize("index,expected", [
    pytest.param(slice(3, 7), lambda q: q[3:7], id="slice"),
    pytest.param(2, lambda q: q[2], id="int"),
    pytest.param([6, 0], lambda q: q[[6, 0]], id="list"),
])
def test_index(arm: sensorcfg.Physics, index: Any, expected: Any) -> None:
    value = sensorcfg.Feature("qpos", "joint:root", index=index)(arm)
    np.testing.assert_array_equal(value, expected(arm.data.qpos[:7]))
    assert np.shape(value) == np.shape(expected(arm.data.qpos[:7]))


def test_index_out_of_range(arm: sensorcfg.Physics) -> None:
    with pytest.raises(sensorcfg.SuiteError, match=r"index 7 does not fit qpos of 'joint:root' with shape \(7,\)"):
        sensorcfg.Feature("qpos", "joint:root", index=7)(arm)


def names_of(physics: sensorcfg.Physics, obj: mujoco.mjtObj, ids: Any) -> list[str]:
    return [mujoco.mj_id2name(physics.model, obj, int(i)) for i in ids]


def test_globs_in_model_order_and_body_star_excludes_world(arm: sensorcfg.Physics) -> None:
    xpos = sensorcfg.Feature("xpos", "body:*")(arm)
    np.testing.assert_array_equal(xpos, arm.data.xpos[1:])  # bodies 1.., never the world body
    np.testing.assert_array_equal(sensorcfg.Feature("xpos", "site:*")(arm), arm.data.site_xpos)
    np.testing.assert_array_equal(sensorcfg.Feature("xpos", ["body:hand", "body:base"])(arm),
                                  arm.data.xpos[[4, 1]])  # an explicit list keeps its order
    one_match = sensorcfg.Feature("xpos", "body:ha*")(arm)
    assert one_match.shape == (1, 3)  # a glob is batched even when it matches one element


def test_within_restricts_to_a_subtree(arm: sensorcfg.Physics) -> None:
    m = arm.model
    joints = sensorcfg.Feature("qpos", "joint:*", within="body:upper")(arm)
    adr = [m.jnt_qposadr[jid(arm, n)] for n in ("shoulder", "elbow", "extend", "wrist")]
    expected = np.concatenate([arm.data.qpos[adr[0]:adr[0] + 3], arm.data.qpos[adr[3]:adr[3] + 4]])
    np.testing.assert_array_equal(joints, expected)
    sites = sensorcfg.Feature("xpos", "site:*", within="body:lower")(arm)
    tip = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tip")
    np.testing.assert_array_equal(sites, arm.data.site_xpos[[tip]])
    with pytest.raises(sensorcfg.SuiteError, match=r"'site:imu' is not in the subtree of 'body:upper'"):
        sensorcfg.Feature("xpos", "site:imu", within="body:upper")(arm)
    with pytest.raises(sensorcfg.SuiteError, match=r"'joint:sh\*' matches no joint under body 'lower'"):
        sensorcfg.Feature("qpos", "joint:sh*", within="body:lower")(arm)


def test_names_with_slashes() -> None:
    physics = sensorcfg.Physics.from_xml_path(str(MODELS / "prefixed.xml"))
    physics.data.qpos[:] = [0.3, -0.2]
    physics.forward()
    m, d = physics.model, physics.data
    assert sensorcfg.Feature("qpos", "joint:left/swing")(physics).tolist() == [0.3]
    left = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "left/base")
    np.testing.assert_array_equal(sensorcfg.Feature("xpos", "body:left/*")(physics), d.xpos[[left]])
    right = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, "right/tip_pos")
    np.testing.assert_array_equal(sensorcfg.Feature("sensordata", "sensor:right/tip_pos")(physics),
                                  d.sensordata[m.sensor_adr[right]:m.sensor_adr[right] + 3])
    np.testing.assert_array_equal(sensorcfg.Feature("xpos", "site:*/tip")(physics), d.site_xpos)
    with pytest.raises(sensorcfg.SuiteError,
                       match=r"no joint named 'left/swng' \(did you mean 'left/swing' or 'right/swing'\?\)"):
        sensorcfg.Feature("qpos", "joint:left/swng")(physics)


def test_unknown_element_and_kind(arm: sensorcfg.Physics) -> None:
    with pytest.raises(sensorcfg.SuiteError, match=r"the model has no body named 'bse' \(did you mean 'base'\?\)"):
        sensorcfg.Feature("xpos", "body:bse")(arm)
    with pytest.raises(sensorcfg.SuiteError, match=r"Feature\('qpos', 'body:base'\): a body has no kind 'qpos' "
                                                   r"\(did you mean 'xpos' or 'xipos'\?\)"):  # state kinds first
        sensorcfg.Feature("qpos", "body:base")
    with pytest.raises(sensorcfg.SuiteError, match=r"unknown element type 'bdy' \(did you mean 'body'\?\)"):
        sensorcfg.Feature("xpos", "bdy:base")
    with pytest.raises(sensorcfg.SuiteError, match=r"one sensor reads one element type; this list mixes body, site"):
        sensorcfg.Feature("xpos", ["body:base", "site:tip"])(arm)


def test_getitem_selects_part_of_the_value_like_mjcffeature() -> None:
    from sensorcfg import assets

    model = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
    physics = sensorcfg.Physics(model)
    mujoco.mj_forward(model, physics.data)
    whole = sensorcfg.Feature("xpos", "body:hand", buffer_size=2)
    z = whole[2]
    assert z.buffer_size == 2 and whole.buffer_size == 2
    np.testing.assert_array_equal(z(physics), whole(physics)[2])
    with pytest.raises(sensorcfg.SuiteError, match="already has index"):
        z[0]


# -- mocap bodies -------------------------------------------------------------------------------------

MOCAP_XML = """<mujoco><worldbody>
  <body name="free"><freejoint/><geom size=".1"/></body>
  <body name="hand_target" mocap="true" pos="1 2 3"><geom size=".05" contype="0" conaffinity="0"/></body>
  <body name="foot_target" mocap="true" pos="4 5 6" quat="0 1 0 0"><geom size=".05" contype="0" conaffinity="0"/></body>
</worldbody></mujoco>"""


def test_mocap_kinds_read_the_mocap_rows_of_mocap_bodies() -> None:
    physics = sensorcfg.Physics(mujoco.MjModel.from_xml_string(MOCAP_XML))
    physics.data.mocap_pos[1] = [7.0, 8.0, 9.0]  # foot_target's row, written as a controller would
    np.testing.assert_array_equal(sensorcfg.Feature("mocap_pos", "body:foot_target")(physics), [7.0, 8.0, 9.0])
    both = sensorcfg.Feature("mocap_pos", "body:*_target")(physics)
    np.testing.assert_array_equal(both, [[1.0, 2.0, 3.0], [7.0, 8.0, 9.0]])
    assert sensorcfg.Feature("mocap_quat", ["body:foot_target"])(physics).shape == (1, 4)
    np.testing.assert_array_equal(sensorcfg.Feature("mocap_quat", "body:foot_target")(physics), [0, 1, 0, 0])


def test_mocap_kinds_of_other_bodies_say_so() -> None:
    physics = sensorcfg.Physics(mujoco.MjModel.from_xml_string(MOCAP_XML))
    with pytest.raises(sensorcfg.SuiteError, match=r"mocap_pos exists only for mocap bodies .*'free' is not"):
        sensorcfg.Feature("mocap_pos", ["body:hand_target", "body:free"])(physics)


def test_mocap_kinds_match_bind(oracle_models: dict[str, tuple[Any, Any]]) -> None:
    root, physics = oracle_models["extras"]
    target = root.find("body", "target")
    physics.bind(target).mocap_pos = [0.1, 0.2, 0.3]
    for kind in ("mocap_pos", "mocap_quat"):
        for one in (target, [target]):
            assert_same(sensorcfg.Feature(kind, selector("body", one))(physics), getattr(physics.bind(one), kind),
                        f"{kind} of {one}")
