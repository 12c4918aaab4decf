"""`sensorcfg.mjlab` on mjlab's Unitree Go1 velocity task, on Warp's CPU device with 2 worlds: each world's
observations are an Updater's replaying that world's physics states (as tests/warp replays them), the groups'
columns are the suite's, mjlab's RSL-RL runner trains on the example, and what the adapter cannot honour is
refused."""

from __future__ import annotations

import importlib.util
from typing import Any

import numpy as np
import pytest

from conftest import ROOT, mjlab_or_skip, warp_or_skip  # noqa: E402

wp = warp_or_skip()
mjlab_or_skip()

# mjlab.rl at collection: its tensordict imports triton where a CUDA build of torch brings it, and triton's LLVM
# crashes the process when it loads after OpenGL's (Mesa's llvmpipe, which tests/warp's CPU cameras load)
import mjlab.rl  # noqa: E402,F401
import torch  # noqa: E402

import sensorcfg  # noqa: E402
from sensorcfg.draws import root_seed, sim_seed  # noqa: E402
from sensorcfg.loop.control import random_state_from  # noqa: E402
from sensorcfg.errors import ArgumentError, SuiteError  # noqa: E402
from sensorcfg.noise.level import leveled  # noqa: E402
from sensorcfg.physics import Physics  # noqa: E402

_spec = importlib.util.spec_from_file_location("mjlab_train_example", ROOT / "examples" / "mjlab" / "train.py")
assert _spec is not None and _spec.loader is not None
example = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(example)

SEED, OFFSET, NWORLD = 5, 3, 2
POLICY = ["base_lin_vel", "base_ang_vel", "projected_gravity", "joint_pos", "joint_vel"]


@pytest.fixture(scope="module")
def env() -> Any:
    env = example.make_env(NWORLD, "cpu", SEED, world_offset=OFFSET)
    env.cfg.episode_length_s = 5 * env.step_dt  # time-outs within the run
    return env


class Replay:
    """One Updater per world over the suite's observables, each reading its world's states: MuJoCo Warp's
    fields after every physics step (recorded as mjlab steps), or after mjlab's reset and forward."""

    def __init__(self, env: Any):
        self.env, self.sensor = env, env.scene["sensorcfg"]
        self.model = env.sim.mj_model
        self.names = [f for f, _ in self.sensor.layer.sensors.plan.fields]
        suite = self.sensor.suite
        options = {**suite.updater_kwargs(self.model), "physics_steps_per_control_step": env.cfg.decimation}
        root = root_seed(SEED)
        self.worlds = []
        for w in range(NWORLD):
            built = {k: o for k, o in suite.build(self.model, batch=True, warp=True).items() if o.enabled}
            leveled(built)
            self.worlds.append((sensorcfg.Updater(built, **options), Physics(self.model),
                                random_state_from(sim_seed(root, OFFSET + w))))
        self.snapshots: list[dict[str, np.ndarray]] = []
        physics_step = env.sim.step

        def step() -> None:
            physics_step()
            self.snapshots.append(self.state())
        env.sim.step = step

    def state(self) -> dict[str, np.ndarray]:
        return {f: getattr(self.env.sim.wp_data, f).numpy().reshape(NWORLD, -1).copy() for f in self.names}

    def _copy(self, w: int, state: dict[str, np.ndarray]) -> None:
        data = self.worlds[w][1].data
        for f, values in state.items():
            getattr(data, f).flat[:] = values[w]

    def restart(self, w: int) -> None:
        self._copy(w, self.state())
        updater, physics, random_state = self.worlds[w]
        updater.reset(physics, random_state)

    def control_step(self, w: int) -> None:
        states = iter(self.snapshots)
        self.worlds[w][0].control_step(lambda: self._copy(w, next(states)))

    def check(self, t: int) -> list[dict[str, np.ndarray]]:
        """Every observation of every world against its Updater's (returned): noise-free plain reads bit for bit
        (float32 copies of MuJoCo Warp's fields), the others to float32 rounding."""
        plan = self.sensor.layer.sensors.plan
        plain = {s.name for s in plan.sensors if s.noise is None and s.aggregator is None}
        got = {name: value.numpy() for name, value in self.sensor.data.items()}
        theirs = [u.get_observation() for u, _, _ in self.worlds]
        for w, observation in enumerate(theirs):
            for name, value in observation.items():
                assert got[name][w].shape == value.shape, name
                if name in plain:
                    assert got[name][w].tobytes() == value.astype(np.float32).tobytes(), (w, t, name)
                else:
                    np.testing.assert_allclose(got[name][w], value, rtol=1e-5, atol=1e-6,
                                               err_msg=f"world {w} control step {t} {name}")
        return theirs


def test_each_world_reads_what_an_updater_replaying_its_states_reads(env: Any) -> None:
    """A few control steps of the task (random actions; world 1 restarted by hand at step 3, time-outs at
    step 5): every read of every world is its Updater's, keyed as world `world_offset + w` of a batch seeded
    `seed`; the actor's and critic's first columns are the suite's groups, in their stated order."""
    sensor = env.scene["sensorcfg"]
    replay = Replay(env)
    assert sensor.episodes.tolist() == [1, 1]  # the manager's shape call started every world's first episode
    for w in range(NWORLD):  # (its keys drawn: the Updater draws them too)
        replay.worlds[w][0].reset(replay.worlds[w][1], replay.worlds[w][2])
    groups = sensor.groups
    assert [c.name for c in groups["policy"].columns] == POLICY
    assert [c.name for c in groups["critic"].columns] == [f"{n}_clean" for n in POLICY]
    assert groups["policy"].width == 3 + 3 + 3 + 12 + 12
    obs, _ = env.reset()
    for w in range(NWORLD):
        replay.restart(w)
    rng = np.random.default_rng(0)
    restarts = 0
    for t in range(9):
        if t:
            replay.snapshots.clear()
            if t == 3:  # by hand, mid-episode: the other world goes on without a step
                obs, _ = env.reset(env_ids=torch.tensor([1]))
                restarted = [False, True]
            else:
                actions = torch.tensor(rng.uniform(-1, 1, (NWORLD, env.action_manager.total_action_dim)),
                                       dtype=torch.float32)
                obs, _, terminated, truncated, _ = env.step(actions)
                restarted = (terminated | truncated).tolist()
                assert len(replay.snapshots) == env.cfg.decimation
            for w in range(NWORLD):
                if restarted[w]:
                    replay.restart(w)
                    restarts += 1
                elif t != 3:
                    replay.control_step(w)
        theirs = replay.check(t)
        for mjlab_group, suite_group in example.GROUPS.items():
            group = groups[suite_group]
            for w in range(NWORLD):
                np.testing.assert_allclose(obs[mjlab_group][w, :group.width].numpy(),
                                           group.concatenate(theirs[w]), rtol=1e-5, atol=1e-6)
        assert not torch.equal(obs["actor"][:, :groups["policy"].width], obs["critic"][:, :groups["critic"].width])
    assert restarts >= 3 and (sensor.episodes >= 3).all()  # the hand-made restart and the time-outs


def test_the_suites_term_refuses_mjlabs_own_noise_delay_and_history() -> None:
    """mjlab would apply them after the suite's own: the manager's construction says so at the term."""
    from mjlab.envs import ManagerBasedRlEnv
    from mjlab.tasks.registry import load_env_cfg
    from mjlab.utils.noise import UniformNoiseCfg

    from sensorcfg.mjlab import attach

    cfg = load_env_cfg(example.TASK)
    cfg.scene.num_envs = 1
    attach(cfg, example.SUITE, {"actor": "policy"})
    cfg.observations["actor"].terms["sensorcfg"].noise = UniformNoiseCfg(n_min=-0.1, n_max=0.1)
    cfg.observations["actor"].enable_corruption = True
    with pytest.raises(ArgumentError, match=r"observation term of suite group 'policy': noise=.* would be applied "
                                            r"after the suite's own noise, delays and buffers"):
        ManagerBasedRlEnv(cfg, device="cpu")


def test_a_keyframe_and_a_group_the_suite_lacks_are_refused(tmp_path: Any) -> None:
    from mjlab.tasks.registry import load_env_cfg

    from sensorcfg.mjlab import SuiteSensorCfg, attach

    text = example.SUITE.read_text()
    (tmp_path / "s.yaml").write_text(text.replace("options:\n", "options:\n  keyframe: 0\n"))
    with pytest.raises(SuiteError, match=r"s\.yaml:\d+:\d+: error: options\.keyframe: mjlab resets the worlds"):
        SuiteSensorCfg(suite=tmp_path / "s.yaml", decimation=4).build()
    cfg = load_env_cfg(example.TASK)
    with pytest.raises(ArgumentError, match="observation group 'actor' has no term 'nope' to keep; its terms: "):
        attach(cfg, example.SUITE, {"actor": "policy"}, keep=("nope",))


def test_mjlabs_rsl_rl_runner_trains_two_iterations_on_the_example() -> None:
    """examples/mjlab/train.py with 2 worlds on the CPU: two PPO iterations of the task's runner, whose actor
    reads the suite's policy group (its input is the group's width and the task's kept terms)."""
    runner = example.train(NWORLD, 2, "cpu", seed=0, steps_per_env=8)
    assert runner.current_learning_iteration == 1
    actor = runner.alg.get_policy()
    first = next(p for p in actor.parameters() if p.dim() == 2)
    assert first.shape[1] == 3 + 3 + 3 + 12 + 12 + 12 + 3  # the policy group, last actions, command
    assert all(torch.isfinite(p).all() for p in actor.parameters())
