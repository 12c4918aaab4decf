"""The Warp engine's physics (`sensorcfg.warp.worlds.Worlds`) on Warp's CPU device: each world follows
`mujoco.mj_step` (to float32 accuracy), a masked reset restarts only its worlds, divergence is per world."""

from __future__ import annotations


import mujoco
import numpy as np
import pytest

from conftest import MODELS, warp_or_skip  # noqa: E402

wp = warp_or_skip()

from sensorcfg.errors import UnsupportedError  # noqa: E402
from sensorcfg.warp.worlds import Worlds  # noqa: E402

DEVICE = "cpu"
MODEL = MODELS / "arm.xml"  # free base, hinges, slide, ball, tendon, filtered actuators
NWORLD = 3
CTRL = np.array([[0.0, 0.0, 0.0, 0.0], [0.5, -0.3, 0.8, -1.0], [-1.0, 1.0, -0.5, 0.2]])  # a control per world


@pytest.fixture(scope="module")
def mjm() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MODEL))


def _cpu(mjm: mujoco.MjModel, ctrl: np.ndarray, steps: int) -> mujoco.MjData:
    """`mj_step` from the keyframe with a constant control."""
    data = mujoco.MjData(mjm)
    mujoco.mj_resetDataKeyframe(mjm, data, 0)
    data.ctrl[:] = ctrl
    for _ in range(steps):
        mujoco.mj_step(mjm, data)
    return data


def _set_ctrl(worlds: Worlds, rows: list[int]) -> None:
    ctrl = worlds.state("ctrl")
    ctrl[rows] = CTRL[rows]
    worlds.data.ctrl.assign(ctrl)


def test_worlds_follow_mj_step(mjm: mujoco.MjModel) -> None:
    worlds = Worlds(mjm, NWORLD, device=DEVICE, keyframe=0)
    np.testing.assert_array_equal(worlds.state("qpos"), np.tile(mjm.key_qpos[0], (NWORLD, 1)).astype(np.float32))
    _set_ctrl(worlds, list(range(NWORLD)))
    worlds.step(20)
    worlds.step(30)
    np.testing.assert_array_equal(worlds.steps.numpy(), [50] * NWORLD)
    for w in range(NWORLD):
        ref = _cpu(mjm, CTRL[w], 50)
        np.testing.assert_allclose(worlds.state("qpos")[w], ref.qpos, rtol=1e-4, atol=1e-5)
        np.testing.assert_allclose(worlds.state("qvel")[w], ref.qvel, rtol=1e-3, atol=1e-4)
    assert not worlds.diverged.numpy().any()


def test_reset_restarts_only_the_masked_worlds(mjm: mujoco.MjModel) -> None:
    worlds = Worlds(mjm, NWORLD, device=DEVICE, keyframe=0)
    _set_ctrl(worlds, list(range(NWORLD)))
    worlds.step(10)
    before = worlds.state("qpos")
    worlds.reset(wp.array([0, 1, 0], dtype=wp.int32, device=DEVICE))
    qpos = worlds.state("qpos")
    np.testing.assert_array_equal(qpos[1], mjm.key_qpos[0].astype(np.float32))
    np.testing.assert_array_equal(worlds.state("qvel")[1], mjm.key_qvel[0].astype(np.float32))
    np.testing.assert_array_equal(qpos[[0, 2]], before[[0, 2]])
    np.testing.assert_array_equal(worlds.steps.numpy(), [10, 0, 10])
    _set_ctrl(worlds, [1])  # the keyframe's control came back with the reset
    worlds.step(15)
    np.testing.assert_array_equal(worlds.steps.numpy(), [25, 15, 25])
    for w, n in ((0, 25), (1, 15), (2, 25)):
        np.testing.assert_allclose(worlds.state("qpos")[w], _cpu(mjm, CTRL[w], n).qpos, rtol=1e-4, atol=1e-5)
    worlds.reset(wp.array([True, False, False], dtype=bool, device=DEVICE))
    np.testing.assert_array_equal(worlds.steps.numpy(), [0, 15, 25])


def test_reset_without_keyframe_is_qpos0(mjm: mujoco.MjModel) -> None:
    worlds = Worlds(mjm, 2, device=DEVICE)
    np.testing.assert_array_equal(worlds.state("qpos"), np.tile(mjm.qpos0, (2, 1)).astype(np.float32))
    np.testing.assert_array_equal(worlds.state("qvel"), 0.0)


def test_divergence_is_per_world_until_reset(mjm: mujoco.MjModel) -> None:
    worlds = Worlds(mjm, NWORLD, device=DEVICE, keyframe=0)
    worlds.step(2)
    qvel = worlds.state("qvel")
    qvel[2, 3] = np.nan
    worlds.data.qvel.assign(qvel)
    worlds.step(3)
    np.testing.assert_array_equal(worlds.diverged.numpy(), [False, False, True])
    assert np.isfinite(worlds.state("qpos")[:2]).all()
    worlds.reset(wp.array([False, False, True], dtype=bool, device=DEVICE))
    worlds.step(1)
    np.testing.assert_array_equal(worlds.diverged.numpy(), [False, False, False])
    np.testing.assert_array_equal(worlds.steps.numpy(), [6, 6, 1])


def test_bad_masks_and_keyframes_are_refused(mjm: mujoco.MjModel) -> None:
    with pytest.raises(ValueError):
        Worlds(mjm, 2, device=DEVICE, keyframe=1)
    worlds = Worlds(mjm, 2, device=DEVICE)
    with pytest.raises(ValueError):
        worlds.reset(wp.zeros(3, dtype=bool, device=DEVICE))
    with pytest.raises(ValueError):
        worlds.reset(wp.zeros(2, dtype=wp.float32, device=DEVICE))


def test_step_and_reset_allocate_nothing_of_their_own(mjm: mujoco.MjModel, monkeypatch: pytest.MonkeyPatch) -> None:
    """A reset allocates no device memory; a step only the temporaries `mjw.step` itself allocates (from the
    device's stream-ordered memory pool on CUDA, which graph capture records, as mujoco_warp's own
    `ScopedCapture` of `mjw.step` does)."""
    import mujoco_warp as mjw

    worlds = Worlds(mjm, NWORLD, device=DEVICE, keyframe=0)
    masks = [wp.array([0, 1, 1], dtype=wp.int32, device=DEVICE), wp.array([True, False, True], device=DEVICE)]
    worlds.step(1)
    worlds.reset(masks[0])
    allocator = worlds.device.get_allocator()
    sizes: list[int] = []
    allocate = allocator.allocate
    monkeypatch.setattr(allocator, "allocate", lambda size: sizes.append(size) or allocate(size))
    for mask in masks:
        worlds.reset(mask)
    assert sizes == []
    worlds.step(2)
    ours = list(sizes)
    sizes.clear()
    with wp.ScopedDevice(DEVICE):
        mjw.step(worlds.model, worlds.data)
        mjw.step(worlds.model, worlds.data)
    assert ours == sizes


def test_a_model_mujoco_warp_does_not_run_is_an_error_that_says_so() -> None:
    """MuJoCo Warp refuses some model features (here the PGS solver): an UnsupportedError naming it and what
    to do, not MuJoCo Warp's NotImplementedError from inside its model transfer."""
    pgs = mujoco.MjModel.from_xml_string('<mujoco><option solver="PGS"/><worldbody><body><freejoint/>'
                                         '<geom size=".1"/></body></worldbody></mujoco>')
    with pytest.raises(UnsupportedError, match=r"MuJoCo Warp .* cannot run this model: .*PGS.* CPU engines"):
        Worlds(pgs, 2, "cpu")
