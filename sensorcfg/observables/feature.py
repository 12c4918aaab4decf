"""A feature: one attribute (`kind`) of one or more model elements, as dm_control's `bind` returns it.

Names are resolved once per model into a flat index array; a read is a single `numpy.take` from the
mjData (or mjModel) array, with no name look-ups on the per-sample path.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Sequence
from typing import Any

import mujoco
import numpy as np
from dm_env import specs

from ..errors import SuiteError, did_you_mean
from ..kinds import (CONSTANT, ON_DEMAND, SOFT_RAGGED, STATE, OnDemand, forwards_when_dirty, kinds_of, offered_kinds,
                     ragged_slices, read_type)
from ..physics import raw_structs
from ..selection import select, split_selector
from .base import Observable

__all__ = ["Feature", "FieldReader", "SyncingFieldReader", "feature_index", "forward_if_dirty", "on_demand",
           "OnDemandCompute", "batch_on_demand_problem"]


class FieldReader:
    """Reads a precomputed set of positions of one mjData/mjModel array.

    `compute`, when set, fills a field MuJoCo computes on demand only (`kinds.ON_DEMAND`) before the read.
    """

    __slots__ = ("source", "index", "shape", "dtype", "field", "struct", "compute", "before_step")

    def __init__(self, struct: str, field: str, source: np.ndarray, index: np.ndarray,
                 compute: OnDemandCompute | None = None):
        self.struct = struct
        self.field = field
        self.source = source  # a flat view of the array: it follows the simulation in place
        self.index = index  # positions in `source`, already in the observation's shape
        self.shape = index.shape
        self.dtype = source.dtype
        self.compute = compute
        # for the Updater: call one physics step before each sample (None when nothing needs it)
        self.before_step = compute.before_step if compute is not None and compute.start_qvel is not None else None

    def __call__(self) -> np.ndarray:
        if self.compute is not None:
            self.compute()
        return self.source.take(self.index)

    def read_into(self, out: np.ndarray) -> None:
        if self.compute is not None:
            self.compute()
        np.take(self.source, self.index, out=out)


_FORWARD, _STEP = int(mujoco.mjtTimer.mjTIMER_FORWARD), int(mujoco.mjtTimer.mjTIMER_STEP)


class OnDemandCompute:
    """Fills a field MuJoCo computes on demand only (`kinds.ON_DEMAND`), at most once per physics step:
    MuJoCo's own flag (`flg_rnepost`, `flg_subtreevel`) says whether it ran since the last step.

    A function that reads `qvel` would see, after `mj_step`, the velocity the step ended with, next to
    kinematics from the step's start. `before_step` remembers the velocity the next step starts from (the
    Updater calls it one physics step before each sample), with MuJoCo's counts of steps and forward
    passes; when exactly one step, and no other forward pass, ran since, the computation runs on that
    velocity, as MuJoCo's in-step call does. Otherwise (the reset sample, a read outside our Updater, a
    forward pass after the step, the RK4 integrator) it runs on the data as they are.
    """

    __slots__ = ("model", "data", "function", "flag", "start_qvel", "stamp")

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, spec: OnDemand):
        self.model, self.data = model, data
        self.function = getattr(mujoco, spec.function)
        self.flag = spec.flag if hasattr(data, spec.flag) else None  # None: a MuJoCo without the flags
        self.start_qvel = np.empty(model.nv) if spec.reads_qvel else None
        self.stamp: tuple[int, int] | None = None  # (forward passes, steps) when `start_qvel` was taken

    def _counts(self) -> tuple[int, int]:
        timer = self.data.timer
        return int(timer[_FORWARD].number), int(timer[_STEP].number)

    def before_step(self, step: int = 0) -> None:
        if self.start_qvel is not None:
            np.copyto(self.start_qvel, self.data.qvel)
            self.stamp = self._counts()

    def __call__(self) -> None:
        data = self.data
        if self.flag is not None and getattr(data, self.flag):
            return
        forward, steps = self._counts()
        if self.start_qvel is not None and self.stamp == (forward - 1, steps - 1):
            end_qvel = data.qvel.copy()
            data.qvel[:] = self.start_qvel
            try:
                self.function(self.model, data)
            finally:
                data.qvel[:] = end_qvel
        else:
            self.function(self.model, data)


_COMPUTED_BY_MODEL: weakref.WeakKeyDictionary[mujoco.MjModel, dict[str, bool]] = weakref.WeakKeyDictionary()


def computed_by_model(model: mujoco.MjModel, spec: OnDemand) -> bool:
    """Whether every `mj_step` and `mj_forward` of `model` fills the field itself (its own sensors need it:
    an accelerometer or force sensor runs mj_rnePostConstraint, a subtreelinvel sensor mj_subtreeVel), as
    MuJoCo's flag shows after a forward pass. Then the field is read as it is, like any other."""
    known = _COMPUTED_BY_MODEL.setdefault(model, {})
    if spec.flag not in known:
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        known[spec.flag] = bool(getattr(data, spec.flag, False))
    return known[spec.flag]


def on_demand(model: mujoco.MjModel, data: mujoco.MjData, field: str) -> OnDemandCompute | None:
    """The computation a field MuJoCo fills only on demand needs before it is read; None for other fields
    and where the model's own sensors make MuJoCo fill it at every step."""
    spec = ON_DEMAND.get(field)
    return None if spec is None or computed_by_model(model, spec) else OnDemandCompute(model, data, spec)


def batch_on_demand_problem(model: mujoco.MjModel, field: str) -> str | None:
    """Why a batched rollout cannot record `field` truly, or None when it can: a rollout steps every
    simulation in C and records after each substep, so a field MuJoCo computes on demand is recorded as
    zeros unless the model's own sensors make every step compute it (mj_forward then leaves the flag set)."""
    spec = ON_DEMAND.get(field)
    if spec is None or computed_by_model(model, spec):
        return None
    return (f"{field} is filled by {spec.function} only when something asks for it, and a BatchEnvironment's "
            "rollout cannot call it between substeps (it would read zeros); give BatchEnvironment the model's "
            "file (it then adds a sensor that makes MuJoCo fill it), give the model a sensor that needs it "
            "(an accelerometer or force sensor for cacc/cfrc_*, a subtreelinvel sensor for subtree_*), or use "
            "the single-simulation Environment")


class SyncingFieldReader(FieldReader):
    """A reader on a dm_control Physics that first brings a dirty physics up to date, as its bind does.

    After a write through a binding (a walker setting `ctrl`), dm_control runs mj_forward before the next
    read of a derived quantity; that read's values, and the state the next step starts from, depend on it.
    `sync` is that check; the Updater also runs it before reading features together.
    """

    __slots__ = ("sync",)

    def __init__(self, struct: str, field: str, source: np.ndarray, index: np.ndarray, sync: Callable[[], None],
                 compute: OnDemandCompute | None = None):
        super().__init__(struct, field, source, index, compute)
        self.sync = sync

    def __call__(self) -> np.ndarray:
        self.sync()
        if self.compute is not None:
            self.compute()
        return self.source.take(self.index)

    def read_into(self, out: np.ndarray) -> None:
        self.sync()
        if self.compute is not None:
            self.compute()
        np.take(self.source, self.index, out=out)


def forward_if_dirty(physics: Any) -> Callable[[], None] | None:
    """For a dm_control Physics (it tracks `is_dirty`), a check that runs `forward()` when dirty."""
    if not isinstance(getattr(type(physics), "is_dirty", None), property) or not callable(
            getattr(physics, "forward", None)):
        return None

    def sync() -> None:
        if physics.is_dirty:
            physics.forward()

    return sync


def feature_index(model: mujoco.MjModel, kind: str, element: str | Sequence[str],
                  within: str | Sequence[str] | None = None, index: Any = None,
                  data: mujoco.MjData | None = None) -> tuple[str, str, np.ndarray, np.dtype]:
    """(struct, field, flat positions shaped like the value, dtype) for a feature on `model`."""
    sel = select(model, element, within, added=True, kind=kind)  # a suite's own selectors were resolved at binding
    spec = kinds_of(sel.type)[kind]
    if spec.struct == "data" and data is None:
        data = mujoco.MjData(model)
    array = getattr(model if spec.struct == "model" else data, spec.field)
    row_width = math.prod(array.shape[1:])
    trailing = tuple(array.shape[1:])
    ids = list(sel.ids)
    if spec.ragged:
        slices = ragged_slices(model, spec, ids)
        if spec.size == "nmocap" and not all(slices):
            names = [sel.names[j] for j, s in enumerate(slices) if not s]
            raise SuiteError(f"{kind} exists only for mocap bodies (mocap=\"true\" in the MJCF); "
                             f"{', '.join(repr(n) for n in names)} {'is' if len(names) == 1 else 'are'} not: "
                             "read xpos / xquat instead, or select a mocap body")
        if spec.size in SOFT_RAGGED and all(len(s) == 1 for s in slices):
            rows = [s.start for s in slices]
            shape = ((len(rows),) if sel.batched else ()) + trailing
        else:
            rows = [r for s in slices for r in s]
            shape = (len(rows),) + trailing
    else:
        rows = ids
        shape = ((len(rows),) if sel.batched else ()) + trailing
    rows_arr = np.asarray(rows, dtype=np.intp)
    flat = (rows_arr[:, None] * row_width + np.arange(row_width, dtype=np.intp)[None, :]).reshape(shape)
    if index is not None:
        flat = indexed(flat, index, kind, element, len(sel.ids))
    # np.array, not np.ascontiguousarray: the latter turns a 0-d index (one element of a per-element
    # scalar field, e.g. the `mass` of one body) into shape (1,), where dm_control gives a scalar.
    return spec.struct, spec.field, np.array(flat, dtype=np.intp, order="C"), array.dtype


def indexed(positions: np.ndarray, index: Any, kind: str, element: Any, count: int) -> np.ndarray:
    """`positions[index]`, a suite's `index` applied to a value's positions (a feature's, a MuJoCo sensor
    kind's): the one rule for both, so an index past its axis is a mistake for every kind."""
    _check_slices(index, positions.shape, kind, element, count)
    try:
        return np.array(positions[index], dtype=np.intp)
    except (IndexError, TypeError, ValueError) as e:
        raise SuiteError(f"index {index!r} does not fit {kind} of {element!r} with shape {positions.shape}: "
                         f"{e}") from None


def _check_slices(index: Any, shape: tuple[int, ...], kind: str, element: Any, count: int) -> None:
    """numpy clips a slice to its axis silently; a suite's slice must lie within the value's axis instead
    (`3:6` of 4 elements is a mistake, not 1 element)."""
    parts = index if isinstance(index, tuple) else (index,)
    at = next((i for i, part in enumerate(parts) if part is Ellipsis), None)  # (`in` would compare arrays)
    if at is not None:
        parts = parts[:at] + (slice(None),) * (len(shape) - len(parts) + 1) + parts[at + 1:]
    for axis, part in enumerate(parts[:len(shape)]):
        if not isinstance(part, slice):
            continue
        size = shape[axis]
        for bound in (part.start, part.stop):
            if bound is not None and not -size <= bound <= size:
                what = f"{count} elements" if count > 1 else "one element"
                text = ":".join("" if b is None else str(b) for b in (part.start, part.stop))
                raise SuiteError(f"index {text!r} reaches past axis {axis} of {kind} of {what} (shape {shape}: "
                                 f"{size} entries on that axis, 0 to {size - 1}); numpy would silently return fewer "
                                 f"values: use a range within 0:{size}")


class Feature(Observable):
    """`kind` of the elements selected by `element` ('type:name', a glob, or a list of them).

    Values and shapes are those of dm_control's `physics.bind(elements).<kind>`: one element gives the
    unbatched shape, a list or a glob the batched one. `index` selects a part of the value; `within`
    ('body:name') restricts a selection to a body's subtree.
    """

    def __init__(self, kind: str, element: str | Sequence[str], update_interval: Any = 1,
                 buffer_size: int | None = None, delay: Any = None, aggregator: Any = None,
                 corruptor: Callable[..., Any] | None = None, index: Any = None,
                 within: str | Sequence[str] | None = None):
        """Check the kind against the element type now; the elements are resolved when bound to a model.

        Args:
            kind: What to read, by dm_control's bind name (`qpos`, `xpos`, `sensordata`, ...).
            element: A selector 'type:name' (a glob such as 'joint:*' too), or a list of them.
            update_interval, buffer_size, delay, aggregator, corruptor: The schedule settings of every
                observable (`Observable`).
            index: A part of the value (`numpy` indexing of one element's value, as `Feature(...)[index]`).
            within: A 'body:name' (or a list of them) whose subtree the selection is restricted to.

        Raises:
            SuiteError: The element type has no such kind (with "did you mean"), the element list is empty,
                or a setting is not one an observable takes.
        """
        self._kind = kind
        self._element = element if isinstance(element, str) else tuple(element)
        self._index = index
        self._within = within if within is None or isinstance(within, str) else tuple(within)
        self._check_kind()
        self._bound: tuple[weakref.ref, FieldReader] | None = None
        super().__init__(update_interval, buffer_size, delay, aggregator, corruptor)

    def __getitem__(self, index: Any) -> Feature:
        """A copy reading part of the value (dm_control's `MJCFFeature[...]`): `Feature('xpos', 'body:b')[2]`."""
        if self._index is not None:
            raise SuiteError(f"{self!r} already has index {self._index!r}; give one index that selects both parts")
        return Feature(self._kind, self._element, self._update_interval, self._buffer_size, self._delay,
                       self._aggregator, self._corruptor, index, self._within)

    def _check_kind(self) -> None:
        selectors = [self._element] if isinstance(self._element, str) else list(self._element)
        if not selectors:
            raise SuiteError(f"{self!r}: an empty element list selects nothing")
        type_name = read_type(split_selector(selectors[0])[0], self._kind)
        kinds = kinds_of(type_name)
        if self._kind not in kinds:
            hint = did_you_mean(self._kind, offered_kinds(type_name, STATE)) or did_you_mean(
                self._kind, offered_kinds(type_name, CONSTANT))
            raise SuiteError(
                f"{self!r}: a {type_name} has no kind {self._kind!r}{hint}; "
                f"{type_name} kinds include {', '.join(offered_kinds(type_name, STATE)[:40])}")

    def __repr__(self) -> str:
        element = getattr(self, "_element", "?")
        return f"Feature({getattr(self, '_kind', '?')!r}, {element if isinstance(element, str) else list(element)!r})"

    @property
    def kind(self) -> str:
        return self._kind

    @property
    def element(self) -> str | tuple[str, ...]:
        return self._element

    def reader(self, physics: Any) -> FieldReader:
        """A reader bound to `physics`; resolved once per model, reused afterwards."""
        model, data = raw_structs(physics)
        bound = self._bound
        if bound is None or bound[0]() is not model:
            struct, field, flat, dtype = feature_index(
                model, self._kind, self._element, self._within, self._index, data)
            bound = (weakref.ref(model), FieldReader(struct, field, np.empty(0, dtype), flat))
            self._bound = bound
        template = bound[1]
        source = getattr(data if template.struct == "data" else model, template.field).reshape(-1)
        compute = on_demand(model, data, template.field) if template.struct == "data" else None
        sync = forward_if_dirty(physics) if forwards_when_dirty(template.struct, self._kind) else None
        if sync is not None:
            return SyncingFieldReader(template.struct, template.field, source, template.index, sync, compute)
        return FieldReader(template.struct, template.field, source, template.index, compute)

    def _callable(self, physics: Any) -> Callable[[], np.ndarray]:
        return self.reader(physics)

    @property
    def array_spec(self) -> specs.Array | None:
        """Known once the feature has been bound to a model (the Updater binds it at reset).

        None while a corruptor is set: a corruptor may change the dtype or shape, so the Updater learns
        them from one corrupted sample, exactly as dm_control does for its MJCFFeature (which has no spec).
        """
        if self._bound is None or self._corruptor is not None:
            return None
        template = self._bound[1]
        return specs.Array(shape=template.shape, dtype=template.dtype)
