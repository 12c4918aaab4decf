"""Fields MuJoCo computes on demand (cfrc_ext, cfrc_int, cacc; subtree_linvel, subtree_angmom) are computed
when a suite reads them, at the physics steps it samples them, and equal MuJoCo's own functions.

The model has the traits of Menagerie robots: an unnamed free joint, unnamed feet touching a floor, and no
sensors, so MuJoCo itself never fills these fields.
"""

from __future__ import annotations

import copy
from typing import Any

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError

from conftest import MODELS

MODEL = MODELS / "menagerie_like.xml"
CALVES = ["body:fl_calf", "body:fr_calf", "body:hl_calf", "body:hr_calf"]
ON_DEMAND_SUITE = f"""
model: {MODEL}
options: {{control_interval: 10}}
sensors:
  calf_cfrc_ext: {{kind: cfrc_ext, element: {CALVES}}}
  feet_cfrc_ext: {{kind: cfrc_ext, element: "body:*", within: body:base}}
  base_cfrc_int: {{kind: cfrc_int, element: body:base}}
  base_cacc: {{kind: cacc, element: body:base}}
  base_subtree_linvel: {{kind: subtree_linvel, element: body:base}}
  base_subtree_angmom: {{kind: subtree_angmom, element: body:base}}
  base_xpos: {{kind: xpos, element: body:base}}
"""
FIELDS = {"calf_cfrc_ext": "cfrc_ext", "base_cfrc_int": "cfrc_int", "base_cacc": "cacc",
          "base_subtree_linvel": "subtree_linvel", "base_subtree_angmom": "subtree_angmom"}


def _episode(model: mujoco.MjModel, steps: int = 60, overrides: list[str] | None = None):
    suite = sensorcfg.loads(ON_DEMAND_SUITE, overrides)
    env = sensorcfg.Environment(model, suite, seed=0, keyframe="crouch")
    rng = np.random.default_rng(0)
    env.reset()
    for _ in range(steps):
        ts = env.step(rng.uniform(-0.3, 0.3, model.nu) + model.key_ctrl[0])
        yield env, ts.observation


def _crouched_updater() -> tuple[mujoco.MjModel, Any, sensorcfg.Updater]:
    """The on-demand suite's Updater, reset on the model standing in its crouch keyframe."""
    model = mujoco.MjModel.from_xml_path(str(MODEL))
    suite = sensorcfg.loads(ON_DEMAND_SUITE)
    physics = sensorcfg.Physics(model)
    mujoco.mj_resetDataKeyframe(model, physics.data, model.key("crouch").id)
    mujoco.mj_forward(model, physics.data)
    updater = sensorcfg.Updater(suite.build(model), **suite.updater_kwargs(model))
    updater.reset(physics, np.random.RandomState(0))
    return model, physics, updater


def test_on_demand_fields_equal_mujocos_own_functions() -> None:
    """Each value equals MuJoCo's function called on the state the last step computed (its kinematics and
    the velocity it started from), and is not zero: the feet stand on the floor."""
    model, physics, updater = _crouched_updater()
    data = physics.data
    calves = [model.body(n.partition(":")[2]).id for n in CALVES]
    base = model.body("base").id
    rng = np.random.default_rng(0)
    nonzero = dict.fromkeys(FIELDS, 0)
    for _ in range(60):
        data.ctrl[:] = rng.uniform(-0.3, 0.3, model.nu) + model.key("crouch").ctrl
        updater.prepare_for_next_control_step()
        for _ in range(updater.physics_steps_per_control_step):
            start_qvel = data.qvel.copy()
            mujoco.mj_step(model, data)
            updater.update()
        obs = updater.get_observation()
        reference = copy.copy(data)
        reference.qvel[:] = start_qvel  # the velocity the last step started from, as in MuJoCo's own call
        mujoco.mj_rnePostConstraint(model, reference)
        mujoco.mj_subtreeVel(model, reference)
        np.testing.assert_array_equal(obs["calf_cfrc_ext"][0], reference.cfrc_ext[calves])
        for name, field in FIELDS.items():
            if name != "calf_cfrc_ext":
                np.testing.assert_array_equal(obs[name][0], getattr(reference, field)[base], err_msg=name)
        for name in FIELDS:
            nonzero[name] += bool(np.any(obs[name] != 0))
    assert all(count >= 50 for count in nonzero.values()), nonzero


@pytest.mark.parametrize("overrides", [
    pytest.param([], id="once-per-control-step"),
    pytest.param(["defaults.buffer=10", "defaults.aggregator=max"], id="every-step-max-per-control-step"),
    pytest.param(["defaults.interval=3", "defaults.buffer=4", "defaults.delay=2"], id="interval-3-buffer-4-delay-2"),
    pytest.param(["defaults.interval={uniform: [1, 4]}", "defaults.buffer=3"], id="drawn-interval"),
])
def test_on_demand_fields_equal_those_mujoco_fills_for_its_own_sensors(overrides: list[str]) -> None:
    """The same trajectory on the model with sensors that make every step compute these fields, bit for bit:
    cacc and cfrc_int too, which MuJoCo computes from the velocity the step started from."""
    spec = mujoco.MjSpec.from_file(str(MODEL))
    spec.add_sensor(type=mujoco.mjtSensor.mjSENS_SUBTREELINVEL, objtype=mujoco.mjtObj.mjOBJ_BODY, objname="base")
    site = spec.body("base").add_site(name="imu")
    spec.add_sensor(type=mujoco.mjtSensor.mjSENS_ACCELEROMETER, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
    with_sensors = spec.compile()
    ours = [obs for _, obs in _episode(mujoco.MjModel.from_xml_path(str(MODEL)), 30, overrides)]
    theirs = [obs for _, obs in _episode(with_sensors, 30, overrides)]
    for a, b in zip(ours, theirs):
        for name in [*FIELDS, "feet_cfrc_ext"]:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def _with_sensors() -> mujoco.MjModel:
    """The model with sensors that make MuJoCo fill both families of on-demand fields at every step."""
    spec = mujoco.MjSpec.from_file(str(MODEL))
    spec.add_sensor(type=mujoco.mjtSensor.mjSENS_SUBTREELINVEL, objtype=mujoco.mjtObj.mjOBJ_BODY, objname="base")
    spec.body("base").add_site(name="imu")
    spec.add_sensor(type=mujoco.mjtSensor.mjSENS_ACCELEROMETER, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu")
    return spec.compile()


@pytest.mark.skipif(not hasattr(mujoco.MjData, "flg_rnepost"), reason="MuJoCo 3.17 has no flags to tell")
def test_a_field_the_models_sensors_fill_is_read_as_it_is() -> None:
    """No computation and no remembered velocity where MuJoCo's own step fills the field (the reads join the
    feature bank like any other field); the values are the same either way (the test above)."""
    for model, computed in ((mujoco.MjModel.from_xml_path(str(MODEL)), True), (_with_sensors(), False)):
        physics = sensorcfg.Physics(model)
        for kind in ("cfrc_ext", "subtree_linvel"):
            reader = sensorcfg.Feature(kind, "body:base").reader(physics)
            assert (reader.compute is not None) == computed, (kind, computed)


def test_computed_only_at_sampled_steps() -> None:
    """Interval 3 with 10 steps per control step: the last step of a control step samples nothing."""
    model = mujoco.MjModel.from_xml_path(str(MODEL))
    suite = sensorcfg.loads(f"""
model: {MODEL}
options: {{control_interval: 10}}
sensors:
  ext: {{kind: cfrc_ext, element: body:fl_calf, interval: 3}}
  com: {{kind: subtree_linvel, element: body:base, interval: 5}}
""")
    env = sensorcfg.Environment(model, suite, seed=0)
    env.reset()
    data = env.physics.data
    assert data.flg_rnepost and data.flg_subtreevel  # the reset sample computed both
    env.step(np.zeros(model.nu))  # step 10: `com` samples (10 = 2 * 5), `ext` does not (9 did)
    assert not data.flg_rnepost and data.flg_subtreevel


def test_batch_from_the_file_adds_the_sensors_that_fill_them() -> None:
    """A BatchEnvironment given the model's file compiles it with one sensor per on-demand family the suite
    reads (MuJoCo then fills the fields at every step): each simulation equals its Environment to the bit,
    and `validate --batch` (Suite.check) finds nothing to report."""
    pytest.importorskip("mujoco.batch")
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("BatchEnvironment needs MuJoCo 4")
    from conftest import assert_batch_equals_single

    suite = sensorcfg.loads(ON_DEMAND_SUITE, ["options.keyframe=crouch"])
    assert suite.check(str(MODEL), batch=True) == []
    compiled = suite.compile(str(MODEL), batch=True)
    assert [compiled.sensor(i).name for i in range(compiled.nsensor)] == ["sensorcfg:on-demand:flg_rnepost",
                                                                        "sensorcfg:on-demand:flg_subtreevel"]
    assert suite.compile(str(MODEL)).nsensor == 0  # the single simulation computes them on demand instead
    assert_batch_equals_single(str(MODEL), suite, nsim=2, seed=0, steps=20)


def test_batch_refuses_them_on_a_compiled_model_that_cannot_fill_them() -> None:
    pytest.importorskip("mujoco.batch")
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("BatchEnvironment needs MuJoCo 4")
    model = mujoco.MjModel.from_xml_path(str(MODEL))
    suite = sensorcfg.loads(ON_DEMAND_SUITE)
    with pytest.raises(SuiteError) as e:  # a suite: each sensor at its `kind`
        sensorcfg.BatchEnvironment(model, suite, 2)
    assert [p.loc for p in e.value.problems] == [f"sensors.{name}.kind" for name in (
        "calf_cfrc_ext", "feet_cfrc_ext", "base_cfrc_int", "base_cacc", "base_subtree_linvel", "base_subtree_angmom")]
    assert e.value.problems[0].message.startswith("cfrc_ext is filled by mj_rnePostConstraint only when something "
                                                  "asks for it, and a BatchEnvironment's rollout cannot call it")
    assert "give BatchEnvironment the model's file" in e.value.problems[0].message
    feature = sensorcfg.Feature("cfrc_ext", "body:fl_calf")
    feature.enabled = True  # (observables start disabled, as dm_control's do)
    with pytest.raises(SuiteError, match=r"sensor 'ext': cfrc_ext is filled by mj_rnePostConstraint"):  # Python
        sensorcfg.BatchEnvironment(model, {"ext": feature}, 2)


def test_batch_records_them_truly_when_the_models_sensors_compute_them() -> None:
    if int(mujoco.__version__.split(".")[0]) < 4:
        pytest.skip("BatchEnvironment needs MuJoCo 4")
    model = _with_sensors()
    suite = sensorcfg.loads(ON_DEMAND_SUITE, ["options.keyframe=crouch"])
    batch = sensorcfg.BatchEnvironment(model, suite, 2, seed=0)
    singles = [sensorcfg.Environment(model, suite, seed=sensorcfg.batch.sim_seed(0, i)) for i in range(2)]
    first = batch.reset().observation
    for i, env in enumerate(singles):
        for name, value in env.reset().observation.items():
            np.testing.assert_array_equal(first[name][i], value, err_msg=name)
    rng = np.random.default_rng(1)
    for _ in range(20):
        actions = rng.uniform(-0.3, 0.3, (2, model.nu)) + model.key("crouch").ctrl
        obs = batch.step(actions).observation
        for i, env in enumerate(singles):
            for name, value in env.step(actions[i]).observation.items():
                np.testing.assert_array_equal(obs[name][i], value, err_msg=name)
    assert np.any(obs["calf_cfrc_ext"] != 0)


def test_a_forward_pass_after_the_step_is_read_as_it_left_the_data() -> None:
    """After mj_forward the kinematics match the velocity the step ended with: no remembered velocity."""
    model, physics, updater = _crouched_updater()
    data = physics.data
    base = model.body("base").id
    for _ in range(5):
        updater.prepare_for_next_control_step()
        for k in range(updater.physics_steps_per_control_step):
            mujoco.mj_step(model, data)
            if k == updater.physics_steps_per_control_step - 1:
                mujoco.mj_forward(model, data)  # e.g. dm_control bringing a dirty physics up to date
            updater.update()
        reference = copy.copy(data)
        mujoco.mj_rnePostConstraint(model, reference)
        np.testing.assert_array_equal(updater.get_observation()["base_cacc"][0], reference.cacc[base])
