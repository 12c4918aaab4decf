"""`WarpEnvironment` on Warp's CPU device: episodes, specs, resets, divergence, seeds across processes, and
noise-free reads that copy MuJoCo Warp's fields at the steps their windows name."""

from __future__ import annotations

import math
import warnings

import mujoco
import numpy as np
import pytest

from conftest import warp_or_skip  # noqa: E402
from cpu_batch import cpu_batch  # noqa: E402

wp = warp_or_skip()

import sensorcfg  # noqa: E402
from sensorcfg import SuiteError, assets  # noqa: E402
from sensorcfg.noise import build_noise  # noqa: E402
from sensorcfg.observables.generic import BatchedGeneric  # noqa: E402
from sensorcfg.warp.environment import WarpEnvironment  # noqa: E402

ROBOT = str(assets.path("robot.xml"))
TIMESTEP = float(mujoco.MjModel.from_xml_path(ROBOT).opt.timestep)
FIRST, MID, LAST = 0, 1, 2


def observables(noise: bool = False) -> dict[str, sensorcfg.Observable]:
    out = {
        "qpos_now": sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"]),
        "qpos_late": sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"], delay=2),
        "qvel_mean": sensorcfg.Feature("qvel", "joint:elbow", buffer_size=3, aggregator="mean"),
        "hand": sensorcfg.Feature("xpos", "site:hand_site", update_interval=2, buffer_size=2),
    }
    if noise:
        out["noisy"] = noisy("noisy", [{"type": "gaussian", "std": 0.1}])
    for obs in out.values():
        obs.enabled = True
    return out


def noisy(name: str, stages: list[dict]) -> sensorcfg.Observable:
    obs = sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"])
    obs.noise = build_noise(stages, (2,), np.float64, TIMESTEP)
    return obs


def env(nworld: int = 3, **kwargs) -> WarpEnvironment:
    kwargs.setdefault("physics_steps_per_control_step", 2)
    return WarpEnvironment(ROBOT, observables(kwargs.pop("noise", False)), nworld, device="cpu", **kwargs)


def test_specs_and_observations_are_float32_device_arrays_with_a_world_axis() -> None:
    e = env()
    step = e.reset()
    spec = e.observation_spec()
    assert set(step.observation) == set(spec)
    for name, array in step.observation.items():
        assert isinstance(array, wp.array) and array.dtype == wp.float32
        assert tuple(array.shape) == spec[name].shape and spec[name].dtype == np.float32
    assert spec["qpos_late"].shape == (3, 1, 2) and spec["hand"].shape == (3, 2, 3)
    assert e.action_spec().shape == (3, e._model.nu)


def test_a_noise_free_read_copies_the_field_at_the_step_its_window_names() -> None:
    e = env()
    e.reset()
    at = [int(e._model.jnt_qposadr[e._model.joint(name).id]) for name in ("shoulder", "elbow")]
    previous = e.data.qpos.numpy()[:, at].copy()
    rng = np.random.default_rng(0)
    for _ in range(6):
        actions = rng.uniform(-1, 1, (3, e._model.nu)).astype(np.float32)
        step = e.step(actions)
        qpos = e.data.qpos.numpy()[:, at]
        assert step.observation["qpos_now"].numpy().tobytes() == qpos.tobytes()
        # delay 2 = one control step of 2 physics steps: the values after the previous control step
        assert step.observation["qpos_late"].numpy().tobytes() == previous.tobytes()
        previous = qpos.copy()


def test_time_limits_end_episodes_and_the_next_step_restarts_them() -> None:
    e = env(time_limit=3 * 2 * TIMESTEP)  # 3 control steps of 2 physics steps
    assert e._limit == 3
    e.reset()
    types = [e.step(np.zeros((3, e._model.nu), np.float32)).step_type.numpy().tolist() for _ in range(5)]
    assert types == [[MID] * 3, [MID] * 3, [LAST] * 3, [FIRST] * 3, [MID] * 3]
    assert e.steps.numpy().tolist() == [2, 2, 2]  # one control step since the restart


def test_reset_of_some_worlds_leaves_the_others_running() -> None:
    e = env()
    e.reset()
    e.step(np.zeros((3, e._model.nu), np.float32))
    step = e.reset([1])
    assert step.step_type.numpy().tolist() == [MID, FIRST, MID]
    assert e.steps.numpy().tolist() == [2, 0, 2]


def test_a_diverged_world_ends_with_discount_zero_and_the_others_go_on() -> None:
    e = env()
    e.reset()
    qvel = e.data.qvel.numpy()
    qvel[1] = np.nan
    e.data.qvel.assign(qvel)
    step = e.step(np.zeros((3, e._model.nu), np.float32))
    assert step.step_type.numpy().tolist() == [MID, LAST, MID]
    assert step.discount.numpy().tolist() == [1.0, 0.0, 1.0]
    step = e.step(np.zeros((3, e._model.nu), np.float32))
    assert step.step_type.numpy().tolist() == [MID, FIRST, MID]
    assert np.isfinite(e.data.qpos.numpy()).all()


def test_rewards_and_terminations_come_from_device_functions() -> None:
    def reward(env: WarpEnvironment) -> wp.array:
        return wp.array(np.arange(3, dtype=np.float32), dtype=wp.float32, device=env.device)

    def terminate(env: WarpEnvironment) -> wp.array:
        return wp.array(np.array([False, False, True]), dtype=bool, device=env.device)

    e = env(reward_fn=reward, termination_fn=terminate)
    e.reset()
    step = e.step(np.zeros((3, e._model.nu), np.float32))
    assert step.reward.numpy().tolist() == [0.0, 1.0, 2.0]
    assert step.step_type.numpy().tolist() == [MID, MID, LAST] and step.discount.numpy().tolist() == [1, 1, 0]


@wp.kernel
def _hand_height(xpos: wp.array2d[wp.vec3], body: int, out: wp.array[wp.float32]):
    out[wp.tid()] = xpos[wp.tid(), body][2]


@wp.kernel
def _end_world_one(steps: wp.array[wp.int64], at: wp.int64, out: wp.array[bool]):
    w = wp.tid()
    out[w] = w == 1 and steps[w] == at


def test_rewards_see_the_data_the_physics_left_whether_or_not_another_world_restarts() -> None:
    """World 0's reward reads a derived field (a body's height, `xpos`) as the physics left it: the same in the
    control step in which world 1 restarts (whose forward recomputes every world's derived fields) as in an
    environment where no world restarts."""
    body = mujoco.MjModel.from_xml_path(ROBOT).body("hand").id
    rewards: list[list[float]] = []
    for ending in (True, False):
        out = wp.zeros(2, dtype=wp.float32, device="cpu")
        ends = wp.zeros(2, dtype=bool, device="cpu")

        def reward(env: WarpEnvironment, out: wp.array = out) -> wp.array:
            wp.launch(_hand_height, dim=2, inputs=[env.data.xpos, body], outputs=[out], device=env.device)
            return out

        def terminate(env: WarpEnvironment, ends: wp.array = ends, ending: bool = ending) -> wp.array:
            wp.launch(_end_world_one, dim=2, inputs=[env.steps, 4 if ending else -1], outputs=[ends],
                      device=env.device)
            return ends

        e = env(2, reward_fn=reward, termination_fn=terminate)
        e.reset()
        actions = np.tile(e.action_spec().maximum, (2, 1)).astype(np.float32)  # world 0 swings its arm
        got = []
        for _ in range(5):
            step = e.step(actions)
            got.append((float(step.reward.numpy()[0]), int(step.step_type.numpy()[1])))
        rewards.append(got)
    ended, steady = rewards
    assert [t for _, t in ended] == [MID, LAST, FIRST, MID, LAST]  # world 1 restarts in the third step
    assert [r for r, _ in ended] == [r for r, _ in steady]
    assert len({r for r, _ in steady}) == 5  # the hand moves: a stale and a fresh height would differ


def test_processes_with_world_offsets_make_the_worlds_of_one_batch() -> None:
    whole = env(4, noise=True, seed=5)
    parts = [env(2, noise=True, seed=5, world_offset=o) for o in (0, 2)]
    noisy = whole.reset().observation["noisy"].numpy()
    split = np.concatenate([p.reset().observation["noisy"].numpy() for p in parts])
    assert noisy.tobytes() == split.tobytes()
    assert not np.array_equal(noisy[0], noisy[1])  # worlds draw their own numbers
    other = env(4, noise=True, seed=6).reset().observation["noisy"].numpy()
    assert not np.array_equal(other, noisy)


def test_keys_are_topped_up_over_many_short_episodes() -> None:
    e = env(2, noise=True, seed=1, key_episodes=4, time_limit=2 * TIMESTEP)  # every control step ends an episode
    e.reset()
    firsts = []
    for _ in range(24):  # 12 episodes per world: three tables' worth
        step = e.step(np.zeros((2, e._model.nu), np.float32))
        if step.step_type.numpy()[0] == FIRST:
            firsts.append(step.observation["noisy"].numpy()[0].copy())
    assert len(firsts) >= 10 and len({f.tobytes() for f in firsts}) == len(firsts)
    used = e._sensors.episodes.count.numpy()
    assert (used >= 12).all() and (e._keys.keyed >= used).all()  # every episode started had its keys drawn


needs_site_xquat = pytest.mark.skipif(not hasattr(mujoco.MjData, "site_xquat"), reason="MuJoCo 3 has no site_xquat")


@needs_site_xquat
def test_what_the_engine_does_not_run_is_refused_at_the_sensor() -> None:
    obs = observables()
    obs["tip_quat"] = sensorcfg.Feature("xquat", "site:hand_site")
    obs["tip_quat"].enabled = True
    with pytest.raises(SuiteError, match=r"sensors.tip_quat.kind: kind 'xquat' reads mjData's site_xquat, which "):
        WarpEnvironment(ROBOT, obs, 2, device="cpu")


def test_misalign_and_parameters_drawn_per_episode_run_over_many_episodes() -> None:
    """Every step starts an episode: each reset read of a misaligned sensor with a std drawn per episode is
    the CPU pipeline's, keyed by the world's episode key, on MuJoCo Warp's reset sample (to float32 rounding),
    over more episodes than the key table holds."""
    stages = [{"type": "misalign", "matrix": [[1, 0.02, 0], [0, 1, 0.01], [0.03, 0, 1]], "std": 0.1},
              {"type": "gaussian", "std": {"uniform": [0.01, 0.1]}}, {"type": "scale", "low": {"uniform": [0.8, 0.9]},
                                                                       "high": 1.2}]
    obs = observables()
    obs["turned"] = sensorcfg.Feature("xpos", "site:hand_site")
    obs["turned"].noise = build_noise(stages, (3,), np.float64, TIMESTEP)
    obs["turned"].enabled = True
    e = WarpEnvironment(ROBOT, obs, 2, device="cpu", physics_steps_per_control_step=1, time_limit=TIMESTEP, seed=4,
                        key_episodes=4)
    site = e._model.site("hand_site").id
    cpu = build_noise(stages, (3,), np.float64, TIMESTEP)
    seen = set()
    for t in range(21):
        step = e.reset() if t == 0 else e.step(np.zeros((2, e._model.nu), np.float32))
        if t % 2:
            assert step.step_type.numpy().tolist() == [LAST, LAST]
            continue
        assert step.step_type.numpy().tolist() == [FIRST, FIRST]
        raw = e.data.site_xpos.numpy()[:, site].astype(np.float64)
        keys = e._sensors.episodes.keys.numpy()[:, e._sensors.noisy_names.index("turned")]
        got = step.observation["turned"].numpy()  # (world, buffer 1, 3)
        for w in range(2):
            cpu.reset(keys[w], 1)
            np.testing.assert_allclose(got[w, 0], cpu(raw[w], 0), rtol=1e-5, atol=1e-6, err_msg=f"world {w} step {t}")
            seen.add(got[w].tobytes())
    assert len(seen) == 22 and (e._sensors.episodes.count.numpy() == 11).all()  # 11 episodes per world, each its own


def test_a_noise_level_applies_from_each_worlds_next_episode() -> None:
    e = env(2, noise=True, seed=3)
    first = e.reset().observation
    assert not np.array_equal(first["noisy"].numpy()[:, 0], first["qpos_now"].numpy()[:, 0])
    e.set_noise_level(0.0)
    assert not np.array_equal(e.step(np.zeros((2, e._model.nu), np.float32)).observation["noisy"].numpy()[:, 0],
                              e.data.qpos.numpy()[:, [7, 8]])  # this episode keeps its level
    clean = e.reset().observation
    assert clean["noisy"].numpy()[:, 0].tobytes() == clean["qpos_now"].numpy()[:, 0].tobytes()


@needs_site_xquat
def test_a_suite_file_is_refused_at_its_lines(tmp_path) -> None:
    suite = tmp_path / "s.yaml"
    suite.write_text("version: 1\nsensors:\n  tip:\n    element: site:hand_site\n    kind: xquat\n")
    with pytest.raises(SuiteError) as raised:
        WarpEnvironment(ROBOT, str(suite), 2, device="cpu")
    assert str(raised.value).startswith(f"{suite}:5:"), str(raised.value)
    assert "sensors.tip.kind: kind 'xquat' reads mjData's site_xquat" in str(raised.value)


def test_bad_ids_and_actions_are_argument_errors() -> None:
    e = env()
    with pytest.raises(sensorcfg.ArgumentError, match=r"world id 5 is out of range: this environment has 3 worlds"):
        e.reset([5])
    with pytest.raises(sensorcfg.ArgumentError, match=r"actions must be a \(3, \d+\) float32 or float64 array "
                                                      r"\(one control per world and actuator; float64 is rounded "
                                                      r"to float32\); got \(2, 3\) float32"):
        e.step(np.zeros((2, e._model.nu), np.float32))


def test_key_episodes_takes_any_integer_but_a_bool() -> None:
    e = env(2, noise=True, key_episodes=np.int64(4))
    assert e._key_episodes == 4 and type(e._key_episodes) is int
    e.reset()
    e.step(np.zeros((2, e._model.nu), np.float32))
    for bad in (True, 4.0, np.int32(3)):
        with pytest.raises(sensorcfg.ArgumentError, match=r"key_episodes must be an integer of at least 4; got "):
            env(2, key_episodes=bad)


QUIET = """
import numpy as np, warp as wp
import sensorcfg
from sensorcfg import assets
from sensorcfg.warp.environment import WarpEnvironment
levels = []
def reward(env):
    levels.append(wp.config.log_level)
    return env._no_reward
obs = {"q": sensorcfg.Feature("qpos", ["joint:shoulder", "joint:elbow"])}
obs["q"].enabled = True
wp.config.log_level = wp.LOG_INFO
e = WarpEnvironment(str(assets.path("robot.xml")), obs, 2, device="cpu", physics_steps_per_control_step=2,
                    reward_fn=reward)
e.reset()
for _ in range(2):
    e.step(np.zeros((2, e._model.nu), np.float32))
print("levels", levels, "after", wp.config.log_level, "info", wp.LOG_INFO, "warning", wp.LOG_WARNING)
"""


def test_building_and_stepping_prints_no_module_load_lines_and_restores_the_log_level() -> None:
    """Warp prints a 'Module ... load on device' line per module a process loads (dozens, over the build,
    the first reset and the first step); the engine quiets them while it works (its callbacks, such as a
    `reward_fn`, run inside it) and gives the user's `wp.config.log_level` back after each call."""
    import os
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", QUIET], capture_output=True, text=True, timeout=600,
                          env={**os.environ})
    assert proc.returncode == 0, proc.stderr
    assert [line for line in proc.stdout.splitlines() if line.startswith("Module ")] == []
    info, warning = wp.LOG_INFO, wp.LOG_WARNING
    assert proc.stdout.splitlines()[-1] == f"levels [{warning}, {warning}] after {info} info {info} warning {warning}"


# -- episode rules as on the CPU engines -----------------------------------------------------------------

# a free motor and one limited to [-1, 1]; `clamp` off: MuJoCo applies the limited one's control unclamped
MOTORS = """<mujoco><option>{flag}</option><worldbody><body><joint name="j" type="hinge" axis="0 1 0"/>
<geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.05" mass="1"/></body></worldbody>
<actuator><motor joint="j" name="free"/><motor joint="j" name="limited" ctrlrange="-1 1" ctrllimited="true"/>
</actuator></mujoco>"""
# (actuator, control, whether it ends the episode): MuJoCo's test of the control as it applies it, and of the
# acceleration (a finite 1e9 N m gives a qacc beyond 1e10)
CONTROLS = [(1, math.nan, True), (1, math.inf, False), (1, -1e11, False), (1, 0.5, False),
            (0, math.nan, True), (0, math.inf, True), (0, -1e11, True), (0, 0.5, False), (0, 1e9, True)]


@pytest.mark.parametrize("flag", ["", '<flag clampctrl="disable"/>'], ids=["clamped", "unclamped"])
def test_a_bad_control_ends_a_worlds_episode_as_on_the_cpu_engines(flag: str) -> None:
    """World k steps control k of `CONTROLS`: the step types and discounts are `BatchEnvironment`'s (MuJoCo's
    bad-control warning: NaN, or beyond 1e10 once clamped where clamped; its bad-qacc warning), and the next step
    restarts exactly the worlds that ended."""
    model = mujoco.MjModel.from_xml_string(MOTORS.format(flag=flag))
    obs = {"q": sensorcfg.Feature("qpos", "joint:j")}
    obs["q"].enabled = True
    n = len(CONTROLS)
    actions = np.zeros((n, 2))
    for k, (a, value, _) in enumerate(CONTROLS):
        actions[k, a] = value
    ends = [e or (bool(flag) and a == 1 and abs(v) > 1e10) for a, v, e in CONTROLS]
    warp = WarpEnvironment(model, obs, n, device="cpu")
    batch = cpu_batch(model, lambda: {"q": sensorcfg.Feature("qpos", "joint:j")}, n)
    warp.reset(), batch.reset()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # (the batch's divergence warning)
        ours, theirs = warp.step(actions), batch.step(actions)
    assert theirs.step_type.tolist() == [LAST if e else MID for e in ends]
    assert ours.step_type.numpy().tolist() == theirs.step_type.tolist()
    assert ours.discount.numpy().tolist() == theirs.discount.tolist() == [0.0 if e else 1.0 for e in ends]
    again = warp.step(np.zeros((n, 2)))
    assert again.step_type.numpy().tolist() == [FIRST if e else MID for e in ends]


@pytest.mark.parametrize("time_limit", [None, math.inf, (2**32 + 3) * 2 * TIMESTEP],
                         ids=["None", "inf", "2**32+3-steps"])
def test_no_time_limit_and_one_beyond_int32_steps_do_not_cut_episodes(time_limit) -> None:
    e = env(time_limit=time_limit)
    assert e._limit == (0 if time_limit in (None, math.inf) else 2**32 + 3)
    e.reset()
    types = [e.step(np.zeros((3, e._model.nu), np.float32)).step_type.numpy().tolist() for _ in range(5)]
    assert types == [[MID] * 3] * 5


def test_a_time_limit_beyond_what_an_episode_counts_is_an_argument_error() -> None:
    with pytest.raises(sensorcfg.ArgumentError, match=r"time_limit 1e\+300s is more than 9,223,372,036,854,775,"
                                                      r"807 control steps of 0.004s .* or None or float\('inf'\) "
                                                      r"for no limit"):
        env(time_limit=1e300)


@wp.kernel
def _zeros(out: wp.array[wp.float32]):
    out[wp.tid()] = wp.float32(0.0)


class Fails:
    """A reward, a termination or a batched generic callable that raises while `armed` (else zeros)."""

    def __init__(self, dtype):
        self.armed, self.dtype = False, dtype

    def __call__(self, *args):
        if self.armed:
            raise ZeroDivisionError("user code")
        return wp.zeros(3, dtype=self.dtype, device="cpu")


def _calling(where: str, fails: Fails) -> WarpEnvironment:
    """An environment whose `where` (`reward_fn`, `termination_fn` or a batched generic sensor) is `fails`."""
    obs, kwargs = observables(noise=True), {}
    if where == "generic":
        obs["g"] = BatchedGeneric(fails)
        obs["g"].enabled = True
    else:
        kwargs[where] = fails
    return WarpEnvironment(ROBOT, obs, 3, device="cpu", seed=3, physics_steps_per_control_step=2, **kwargs)


@pytest.mark.parametrize("where", ["reward_fn", "termination_fn", "generic"])
def test_an_exception_in_a_step_restarts_every_world_at_the_next(where: str) -> None:
    """The step raises after its physics and samples ran; the next step is FIRST for every world, each starting
    its next episode (the second here: a fresh environment's second reset), as `BatchEnvironment` does."""
    dtype = bool if where == "termination_fn" else wp.float32
    fails = Fails(dtype)
    e = _calling(where, fails)
    e.reset()
    actions = np.full((3, e._model.nu), 0.5, np.float32)
    e.step(actions)
    fails.armed = True
    with pytest.raises(ZeroDivisionError):
        e.step(actions)
    fails.armed = False
    restarted = e.step(actions)
    assert restarted.step_type.numpy().tolist() == [FIRST] * 3
    assert e.steps.numpy().tolist() == [0, 0, 0]
    fresh = _calling(where, Fails(dtype))
    fresh.reset()
    second = fresh.reset()
    for name, array in second.observation.items():
        assert restarted.observation[name].numpy().tobytes() == array.numpy().tobytes(), name
    assert e.step(actions).step_type.numpy().tolist() == [MID] * 3


def test_an_exception_in_a_reset_restarts_every_world_at_the_next_step() -> None:
    """A batched generic callable raising in `reset(ids)` (the reset samples): its worlds are half restarted,
    so the next step restarts every world, as after an exception in a step."""
    fails = Fails(wp.float32)
    e = _calling("generic", fails)
    e.reset()
    actions = np.zeros((3, e._model.nu), np.float32)
    e.step(actions)
    fails.armed = True
    with pytest.raises(ZeroDivisionError):
        e.reset([1])
    fails.armed = False
    assert e.step(actions).step_type.numpy().tolist() == [FIRST] * 3


# -- actions ---------------------------------------------------------------------------------------------


def test_actions_are_float32_as_the_spec_says_and_float64_is_rounded_alike_from_numpy_and_torch() -> None:
    """The spec says float32 (MuJoCo Warp's ctrl); a float64 array, host or device (numpy, torch, Warp), is
    rounded to nearest float32 alike; a torch tensor that requires grad is read detached; another dtype is an
    ArgumentError naming what fits."""
    import torch

    e = env()
    spec = e.action_spec()
    assert spec.dtype == np.float32 and spec.shape == (3, e._model.nu)
    np.testing.assert_array_equal(spec.maximum, e._model.actuator_ctrlrange[:, 1].astype(np.float32))
    e.reset()
    values = np.random.default_rng(0).uniform(-1, 1, (3, e._model.nu)) * (1 + 2.0**-30)  # not float32 numbers
    expected = values.astype(np.float32)
    assert not np.array_equal(expected.astype(np.float64), values)
    for given in (values, torch.from_numpy(values), wp.array(values, dtype=wp.float64, device="cpu"),
                  torch.from_numpy(expected), torch.from_numpy(values.copy()).requires_grad_(),
                  torch.from_numpy(expected.copy()).requires_grad_()):
        e.step(given)
        assert e.data.ctrl.numpy().tobytes() == expected.tobytes(), type(given)
    with pytest.raises(sensorcfg.ArgumentError, match=r"actions must be a \(3, 3\) float32 or float64 array .*; got "
                                                      r"\(3, 3\) float16"):
        e.step(torch.zeros((3, e._model.nu), dtype=torch.float16))
