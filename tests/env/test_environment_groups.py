"""The suite's observation groups in the environments: `group_spec()` (each group's columns, in a pinned order)
and `groups(observation)` (each group's vector) on `Environment` and `BatchEnvironment` (the Warp engine's:
tests/warp/test_warp_groups.py)."""

from __future__ import annotations

import numpy as np

import sensorcfg
from sensorcfg import assets
from test_batch import needs_batch

ROBOT = str(assets.path("robot.xml"))
SUITE = """
sensors:
  q: {kind: qpos, element: ["joint:shoulder", "joint:elbow"], twin: q_clean, noise: [{type: gaussian, std: 0.1}]}
  v: {kind: qvel, element: "joint:elbow"}
  hand: {kind: xpos, element: "site:hand_site", buffer: 2}
  imu: {kind: sensordata, element: ["sensor:imu_gyro", "sensor:imu_accel"]}
groups:
  policy: [v, 'q*', hand]
  critic: ['*']
"""
# (name, start, stop, shape): list order, a glob's matches in the suite's order with each twin after its sensor,
# each observation flattened in C order (buffer axis first: 1 unless `strip_singleton_buffer_dim`)
COLUMNS = {
    "policy": [("v", 0, 1, (1, 1)), ("q", 1, 3, (1, 2)), ("q_clean", 3, 5, (1, 2)), ("hand", 5, 11, (2, 3))],
    "critic": [("q", 0, 2, (1, 2)), ("q_clean", 2, 4, (1, 2)), ("v", 4, 5, (1, 1)), ("hand", 5, 11, (2, 3)),
               ("imu", 11, 17, (1, 6))],
}


def _columns(env: sensorcfg.Environment | sensorcfg.BatchEnvironment) -> dict[str, list[tuple]]:
    return {name: [(c.name, c.start, c.stop, c.shape) for c in group.columns]
            for name, group in env.group_spec().items()}


def _by_hand(observation: dict[str, np.ndarray], group: str, lead: tuple[int, ...]) -> np.ndarray:
    return np.concatenate([np.reshape(observation[name], (*lead, -1)) for name, *_ in COLUMNS[group]], axis=-1)


def test_the_single_environment_concatenates_its_groups_in_the_pinned_order() -> None:
    env = sensorcfg.Environment(ROBOT, sensorcfg.loads(SUITE), seed=3)
    assert _columns(env) == COLUMNS
    assert {name: g.width for name, g in env.group_spec().items()} == {"policy": 11, "critic": 17}
    env.reset()
    step = env.step(np.full(env.action_spec().shape, 0.3))
    vectors = env.groups(step.observation)
    assert list(vectors) == ["policy", "critic"]
    for name, vector in vectors.items():
        assert vector.shape == (env.group_spec()[name].width,) and vector.dtype == np.float64
        np.testing.assert_array_equal(vector, _by_hand(step.observation, name, ()))


@needs_batch
def test_the_batch_concatenates_its_groups_per_simulation() -> None:
    env = sensorcfg.BatchEnvironment(ROBOT, sensorcfg.loads(SUITE), 3, seed=3)
    assert _columns(env) == COLUMNS
    env.reset()
    step = env.step(np.full(env.action_spec().shape, 0.3))
    for name, vector in env.groups(step.observation).items():
        assert vector.shape == (3, env.group_spec()[name].width)
        np.testing.assert_array_equal(vector, _by_hand(step.observation, name, (3,)))
        assert not np.array_equal(vector[0], vector[1])  # each simulation's own noise, in its own row


def test_an_environment_without_groups_has_none() -> None:
    env = sensorcfg.Environment(ROBOT, {"q": sensorcfg.Feature("qpos", "joint:shoulder")})
    assert dict(env.group_spec()) == {} and env.groups(env.reset().observation) == {}
