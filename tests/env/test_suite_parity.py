"""A suite runs exactly as the same sensors written by hand with dm_control's observables and Updater.

The suite's units (durations, rates), selectors (globs in model order, `within`, lists) and aggregators
are translated by sensorcfg; dm_control gets the same settings in steps and explicit elements. Both
updaters run on one dm_control Physics, so any difference is a translation mistake.
"""

from __future__ import annotations

import numpy as np

import sensorcfg
from sensorcfg.assets import path as asset_path

SUITE = """
options: {control_interval: 10ms}
sensors:
  arm: {kind: qpos, element: "joint:*", within: body:upper_arm, interval: 4ms, delay: 6ms, buffer: 3}
  imu: {kind: sensordata, element: [sensor:imu_gyro, sensor:imu_accel], interval: 250Hz, buffer: 4,
        aggregator: mean}
  hand: {kind: xpos, element: site:hand_site, interval: 10, delay: 2}
  motors: {kind: force, element: "actuator:*", buffer: 2}
"""


def test_suite_matches_dm_control_written_by_hand(oracle) -> None:
    root = oracle.mjcf.from_path(str(asset_path("robot.xml")))
    physics = oracle.mjcf.Physics.from_mjcf_model(root)
    find = root.find
    feature = oracle.observable.MJCFFeature
    by_hand = {
        "arm": feature("qpos", [find("joint", n) for n in ("shoulder", "elbow", "wrist", "finger_slide")],
                       update_interval=2, delay=3, buffer_size=3),
        "imu": feature("sensordata", [find("sensor", "imu_gyro"), find("sensor", "imu_accel")],
                       update_interval=2, buffer_size=4, aggregator="mean"),
        "hand": feature("xpos", find("site", "hand_site"), update_interval=10, delay=2),
        "motors": feature("force", root.find_all("actuator"), buffer_size=2),
    }
    for obs in by_hand.values():
        obs.enabled = True
    suite = sensorcfg.loads(SUITE)
    ours = sensorcfg.Updater(suite.build(physics.model.ptr), **suite.updater_kwargs(physics.model.ptr))
    theirs = oracle.updater.Updater(by_hand, physics_steps_per_control_step=5)
    assert ours.physics_steps_per_control_step == 5
    ours.reset(physics, np.random.RandomState(0))
    theirs.reset(physics, np.random.RandomState(0))
    for k in range(60):
        physics.data.ctrl[:] = np.sin(0.2 * k + np.arange(physics.model.nu))
        ours.prepare_for_next_control_step()
        theirs.prepare_for_next_control_step()
        for _ in range(5):
            physics.step()
            ours.update()
            theirs.update()
        mine, expected = ours.get_observation(), theirs.get_observation()
        assert list(mine) == list(expected)
        for name in expected:
            np.testing.assert_array_equal(mine[name], expected[name], err_msg=f"{name} at control step {k}")
