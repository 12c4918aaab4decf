"""nworld MuJoCo Warp worlds of one MjModel on one Warp device: step, reset by mask, step counts, divergence.

Everything stays on the device: `step` and `reset` only launch kernels (no host copy, no Python per world,
no allocation of their own: `mjw.step` allocates its temporaries, from the stream-ordered memory pool on CUDA),
so both can be recorded in a CUDA graph (`wp.ScopedCapture`, as mujoco_warp captures `mjw.step`) and replayed.

Conventions:
- `steps[w]` (int64) counts the physics steps (`mjw.step`, one timestep each) of world w since its last
  reset: the engine's clock. MuJoCo Warp's `data.time` is float32 and drifts; never schedule by it.
- `diverged[w]` (bool) is set once a step leaves world w's qpos, qvel or qacc bad or ran on a bad control,
  and stays set until the world is reset: MuJoCo's test (`mju_isBad`: NaN, or beyond +-`mujoco.mjMAXVAL`; a
  control as MuJoCo applies it, clamped to its `ctrlrange` where ctrl-limited unless clamping is disabled,
  a NaN staying NaN), whose warnings the CPU engines read as divergence (`loop.episode`). Unlike
  `mujoco.mj_step` (whose checks reset a diverged world, or zero its bad controls, and warn), MuJoCo Warp
  goes on with such numbers (`ctrl` keeps what was written): the caller decides what a diverged world's
  readings are.
- `overflow` is MuJoCo Warp's per-world bitmask (`mjw.OverflowType` on 4.x) of contacts or constraints that
  did not fit `nconmax` / `njmax`: such a world's physics is wrong, not just slow.
- A reset world starts from keyframe `keyframe` (`KEYFRAME_STATE`: time, qpos, qvel, act, ctrl, mocap, and
  plastic where MuJoCo has plasticity), or from the model's qpos0 and zeros with no keyframe, as
  `mujoco.mj_resetDataKeyframe` / `mj_resetData` do; its derived quantities (positions, sensors) are those of
  the old state until the next `forward` or `step`.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp

from ..errors import UnsupportedError
from .quiet import quiet_loads

__all__ = ["KEYFRAME_STATE", "ControlBounds", "WorldCounts", "Worlds", "control_bounds", "default_sizes",
           "model_refusal", "put_model"]

wp.set_module_options({"enable_backward": False})

_MAX_VALUE = wp.constant(float(mujoco.mjMAXVAL))  # MuJoCo's bound of a sane value (1e10)


def default_sizes(mjm: mujoco.MjModel, keyframe: int | None = None) -> tuple[int, int]:
    """(nconmax, njmax) per world: at least 64 contacts and 128 constraint rows, and four times what
    `mj_forward` finds at the initial state (the keyframe's, else qpos0)."""
    data = mujoco.MjData(mjm)
    if keyframe is not None:
        mujoco.mj_resetDataKeyframe(mjm, data, keyframe)
    mujoco.mj_forward(mjm, data)
    return max(64, 4 * data.ncon), max(128, 4 * data.nefc)


@wp.struct
class WorldCounts:
    """Per world since its reset: its physics `steps` and whether it `diverged` (the module's conventions)."""

    steps: wp.array[wp.int64]
    diverged: wp.array[bool]


@wp.kernel
def _select(
    # In:
    mask: wp.array[wp.int32],
    # Out: the worlds selected; their step counts and divergence cleared
    selected: wp.array[bool], counts: WorldCounts,
):
    """The worlds to reset (mask nonzero): their step counts and divergence cleared."""
    w = wp.tid()
    on = mask[w] != 0
    selected[w] = on
    if on:
        counts.steps[w] = wp.int64(0)
        counts.diverged[w] = False


@wp.kernel
def _select_bool(
    # In:
    mask: wp.array[bool],
    # Out: as `_select`'s
    selected: wp.array[bool], counts: WorldCounts,
):
    w = wp.tid()
    on = mask[w]
    selected[w] = on
    if on:
        counts.steps[w] = wp.int64(0)
        counts.diverged[w] = False


# a keyframe's state: (MjModel's key field, the Data field it restarts); a field one MuJoCo lacks (MuJoCo 3.11 has
# no plasticity) is none of its keyframes' state
KEYFRAME_STATE = (("key_time", "time"), ("key_qpos", "qpos"), ("key_qvel", "qvel"), ("key_act", "act"),
                  ("key_ctrl", "ctrl"), ("key_mpos", "mocap_pos"), ("key_mquat", "mocap_quat"),
                  ("key_plastic", "plastic"))


@wp.kernel
def _keyframe(
    # In:
    selected: wp.array[bool], row: wp.array[wp.float32],
    # Out: the field's (nworld, values) view
    out: wp.array2d[wp.float32],
):
    """One field of a keyframe's state (`row`, float32 as MuJoCo Warp holds it) into the selected worlds
    (after `mjw.reset_data` cleared them)."""
    w, i = wp.tid()
    if selected[w]:
        out[w, i] = row[i]


def _values(array: wp.array, nworld: int) -> wp.array:
    """An (nworld, ...) float32 array of MuJoCo Warp's Data (scalars, vectors or quaternions) as (nworld, values)."""
    size = array.size * wp.types.type_size_in_bytes(array.dtype) // (4 * nworld)
    return wp.array(ptr=array.ptr, dtype=wp.float32, shape=(nworld, size), device=array.device, copy=False)


class _KeyRow(NamedTuple):
    """One non-empty field of a keyframe's state: its `row` (float32) and the Data `field` it restarts, as an
    (nworld, values) view."""

    row: wp.array
    field: wp.array


def _keyframe_rows(mjm: mujoco.MjModel, key: int, data: object, nworld: int) -> list[_KeyRow]:
    """Keyframe `key`'s state, its non-empty fields (read from `mjm`: MuJoCo Warp 3.11's Model holds no
    keyframes)."""
    out = []
    for key_field, field in KEYFRAME_STATE:
        if not hasattr(mjm, key_field):
            continue
        row = np.ravel(getattr(mjm, key_field)[key]).astype(np.float32)
        if row.size:
            out.append(_KeyRow(wp.array(row, dtype=wp.float32), _values(getattr(data, field), nworld)))
    return out


@wp.func
def _bad(x: float) -> bool:
    """MuJoCo's `mju_isBad`: NaN, or beyond +-mjMAXVAL."""
    return not (wp.abs(x) <= _MAX_VALUE)


@wp.struct
class ControlBounds:
    """Each control's [low, high] as MuJoCo clamps it before its bad-control test (`control_bounds`)."""

    low: wp.array[float]
    high: wp.array[float]


@wp.kernel
def _count(
    # Data in:
    qpos: wp.array2d[float], qvel: wp.array2d[float], qacc: wp.array2d[float], ctrl: wp.array2d[float],
    # In:
    bounds: ControlBounds,
    # In and out:
    counts: WorldCounts,
):
    """After one step: the world's step count advanced, and it is marked diverged if its state is bad or its
    controls were (each clamped to `bounds` as MuJoCo clamps it: +-inf where it is not; none checked where
    MuJoCo checks none, `bounds` then empty)."""
    w = wp.tid()
    counts.steps[w] = counts.steps[w] + wp.int64(1)
    bad = counts.diverged[w]
    for i in range(qpos.shape[1]):
        bad = bad or _bad(qpos[w, i])
    for i in range(qvel.shape[1]):
        bad = bad or _bad(qvel[w, i]) or _bad(qacc[w, i])
    for i in range(bounds.low.shape[0]):
        c = ctrl[w, i]
        if c < bounds.low[i]:  # (mju_clip: a NaN compares false and stays NaN)
            c = bounds.low[i]
        elif c > bounds.high[i]:
            c = bounds.high[i]
        bad = bad or _bad(c)
    counts.diverged[w] = bad


def control_bounds(mjm: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of each control as `mj_fwdActuation` clamps it before its bad-control test: `ctrlrange`
    where the actuator is ctrl-limited, +-inf where not or where `<flag clampctrl="disable"/>`; both empty where
    actuation is disabled (MuJoCo then tests no control)."""
    disabled = int(mjm.opt.disableflags)
    if disabled & int(mujoco.mjtDisableBit.mjDSBL_ACTUATION):
        return np.zeros(0, np.float32), np.zeros(0, np.float32)
    clamped = mjm.actuator_ctrllimited.astype(bool) & ~bool(disabled & int(mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL))
    low, high = mjm.actuator_ctrlrange.T
    return (np.where(clamped, low, -np.inf).astype(np.float32), np.where(clamped, high, np.inf).astype(np.float32))


def _version() -> str:
    return str(getattr(mjw, "__version__", "")) or "(version unknown)"


def put_model(mjm: mujoco.MjModel) -> mjw.Model:
    """MuJoCo Warp's model of `mjm` on the current device; UnsupportedError saying what MuJoCo Warp does not
    run of it (a model feature: the PGS solver, a plugin, a dense Jacobian past 60 dofs, ...), not where."""
    try:
        return mjw.put_model(mjm)
    except (NotImplementedError, ValueError) as e:
        raise UnsupportedError(f"MuJoCo Warp {_version()} cannot run this model: {e} Run it on the CPU engines "
                               "(Environment, BatchEnvironment), or change the model") from None


def model_refusal(mjm: mujoco.MjModel) -> str | None:
    """What MuJoCo Warp refuses of `mjm` (`put_model`, tried on Warp's CPU device, quietly), or None when it
    takes it: what `validate --engine warp` checks of the model where MuJoCo Warp is installed."""
    try:
        with quiet_loads(), wp.ScopedDevice("cpu"):
            put_model(mjm)
    except UnsupportedError as e:
        return str(e)
    return None


class Worlds:
    """nworld worlds of `mjm` on `device`, all reset to `keyframe` (an index of mjm's keyframes; None: qpos0).

    `model`, `data`: MuJoCo Warp's (`mjw.put_model(mjm)`, `mjw.make_data(mjm, nworld, nconmax, njmax)`);
    `steps` (nworld,) int64 and `diverged` (nworld,) bool device arrays (see the module's conventions).
    nconmax / njmax (contacts / constraint rows per world) default to `default_sizes` (None in `over`'s)."""

    nconmax: int | None
    njmax: int | None

    def __init__(self, mjm: mujoco.MjModel, nworld: int, device: wp.Device | str | None = None,
                 keyframe: int | None = None, nconmax: int | None = None, njmax: int | None = None):
        if nworld < 1:
            raise ValueError(f"nworld must be at least 1; got {nworld}")
        if keyframe is not None and not 0 <= keyframe < mjm.nkey:
            raise ValueError(f"keyframe {keyframe} is not one of the model's {mjm.nkey} keyframes")
        device = wp.get_device(device)
        sizes = default_sizes(mjm, keyframe) if nconmax is None or njmax is None else (nconmax, njmax)
        nconmax = sizes[0] if nconmax is None else nconmax
        njmax = sizes[1] if njmax is None else njmax
        with wp.ScopedDevice(device):
            model = put_model(mjm)
            data = mjw.make_data(mjm, nworld=nworld, nconmax=nconmax, njmax=njmax)
        self._adopt(mjm, model, data, nworld, device, keyframe)
        self.nconmax, self.njmax = nconmax, njmax
        with wp.ScopedDevice(device):
            everything = wp.ones(nworld, dtype=bool)
        self.reset(everything)

    @classmethod
    def over(cls, mjm: mujoco.MjModel, model: mjw.Model, data: mjw.Data, device: wp.Device | str | None) -> Worlds:
        """The worlds of a MuJoCo Warp `model` and `data` (of `mjm`) that another library made and steps
        (mjlab's simulation): `count` after each of its physics steps, `restarted` after it resets worlds;
        `step` and `reset` are the owner's, not these worlds'."""
        worlds = cls.__new__(cls)
        worlds._adopt(mjm, model, data, int(data.qpos.shape[0]), wp.get_device(device), None)
        worlds.nconmax, worlds.njmax = None, None
        return worlds

    def _adopt(self, mjm: mujoco.MjModel, model: mjw.Model, data: mjw.Data, nworld: int, device: wp.Device,
               keyframe: int | None) -> None:
        self.device, self.nworld, self.keyframe, self.model, self.data = device, nworld, keyframe, model, data
        with wp.ScopedDevice(device):
            self.counts = counts = WorldCounts()
            counts.steps = wp.zeros(nworld, dtype=wp.int64)
            counts.diverged = wp.zeros(nworld, dtype=bool)
            low, high = control_bounds(mjm)
            self._ctrl_bounds = bounds = ControlBounds()
            bounds.low, bounds.high = wp.array(low, dtype=float), wp.array(high, dtype=float)
            self._selected = wp.zeros(nworld, dtype=bool)
            self._key_rows = [] if keyframe is None else _keyframe_rows(mjm, keyframe, data, nworld)

    @property
    def steps(self) -> wp.array:
        """(nworld,) int64: each world's physics steps since its reset (`counts.steps`)."""
        return self.counts.steps

    @property
    def diverged(self) -> wp.array:
        """(nworld,) bool: whether each world diverged since its reset (`counts.diverged`)."""
        return self.counts.diverged

    @property
    def overflow(self) -> wp.array:
        """(nworld,) int32: MuJoCo Warp's overflow bits of each world (nonzero: its physics is not to be trusted)."""
        return self.data.overflow

    def step(self, substeps: int = 1) -> None:
        """`substeps` physics steps of every world (each `mjw.step`, then the step counts and divergence)."""
        with wp.ScopedDevice(self.device):
            for _ in range(substeps):
                mjw.step(self.model, self.data)
                self.count()

    def count(self) -> None:
        """After one physics step of every world: the step counts advanced, divergence checked."""
        data = self.data
        wp.launch(_count, dim=self.nworld, inputs=[data.qpos, data.qvel, data.qacc, data.ctrl, self._ctrl_bounds],
                  outputs=[self.counts], device=self.device)

    def forward(self) -> None:
        """`mjw.forward` of every world: derived quantities (and sensors) of the current states, which a step's
        next forward recomputes anyway (the states themselves are not changed)."""
        with wp.ScopedDevice(self.device):
            mjw.forward(self.model, self.data)

    def reset(self, mask: wp.array) -> None:
        """Restart the worlds where `mask` ((nworld,) bool or int32 device array) is set: state from the
        keyframe or qpos0, step count 0, divergence cleared. The other worlds are not touched."""
        if mask.shape != (self.nworld,):
            raise ValueError(f"a reset mask is ({self.nworld},); got {mask.shape}")
        if mask.dtype not in (wp.bool, wp.int32):
            raise ValueError(f"a reset mask is bool or int32; got {wp.types.type_repr(mask.dtype)}")
        with wp.ScopedDevice(self.device):
            self.restarted(mask)
            mjw.reset_data(self.model, self.data, self._selected)
            for key in self._key_rows:
                wp.launch(_keyframe, dim=key.field.shape, inputs=[self._selected, key.row], outputs=[key.field])

    def restarted(self, mask: wp.array) -> None:
        """The worlds where `mask` ((nworld,) bool or int32) is set start again: step count 0, divergence cleared
        (their physics is reset by `reset`, or by the owner of `over`'s worlds)."""
        select = _select_bool if mask.dtype == wp.bool else _select
        wp.launch(select, dim=self.nworld, inputs=[mask], outputs=[self._selected, self.counts], device=self.device)

    def state(self, name: str) -> np.ndarray:
        """A host copy of one of `data`'s (nworld, ...) arrays, for tests and diagnostics (not per step)."""
        return np.array(getattr(self.data, name).numpy(), copy=True)  # on the CPU device .numpy() is a view
