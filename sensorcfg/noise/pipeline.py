"""Building a sensor's noise pipeline from its stage configs, once its shape and dtype are known.

`build_noise` checks what only the bound observation can tell (a per-value list that does not fit the
shape, a stage that cannot apply to the dtype, a custom callable that cannot be imported) and reports every
problem at once, each at `noise.<i>.<field>` so the suite layer can point at the YAML node.
"""

from __future__ import annotations

import importlib
import inspect
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from pydantic import TypeAdapter, ValidationError

from ..config.noise import IMAGE_STAGES, STAGES, NoiseStage
from ..errors import Problem, SuiteError, did_you_mean
from . import stages as rt

__all__ = ["NoisePipeline", "build_noise", "callable_reference", "custom_name"]

_STAGE_LIST = TypeAdapter(tuple[NoiseStage, ...])


class NoisePipeline:
    """The stages of one sensor, applied in order to each raw sample.

    `reset(rng, stride)` starts an episode: each stage draws from its own part of the sensor's counter-based
    streams (`stages.Streams`), so adding or removing a stage leaves the draws of the others unchanged.
    `pipeline(value, step)` returns a new array of the observation's dtype (or writes into `out`); `step` counts
    physics steps since reset.
    """

    def __init__(self, stages: Sequence[rt.Stage], names: Sequence[str], ctx: rt.Context,
                 streams: rt.Streams | None = None):
        """`streams`: the streams `stages` were last reset with, for stages taken over from another pipeline
        (they are then left as they are until the next reset); None: new stages, reset here."""
        self._stages = tuple(stages)
        self.names = tuple(names)
        self.shape = ctx.shape
        self.dtype = ctx.dtype
        self.timestep = ctx.timestep
        self._direct = ctx.work == ctx.dtype  # stages work in the output array itself
        self._image = ctx.dtype == np.uint8
        self._work = np.zeros(ctx.shape, ctx.work)
        lone = self._stages[0] if len(self._stages) == 1 else None
        self._lone = lone if isinstance(lone, rt._Additive) and self._direct else None
        self.streams: rt.Streams
        self.configs: tuple[Any, ...] = ()  # the validated stage configs (`build_noise`)
        self.stride = 1
        if streams is None:
            self.reset(np.random.default_rng(0))
        else:
            self.streams = streams

    def __repr__(self) -> str:
        return f"NoisePipeline({', '.join(self.names)}; shape={self.shape}, dtype={self.dtype})"

    @property
    def stages(self) -> tuple[rt.Stage, ...]:
        """The runtime stages in order, adjacent additive ones fused (`sensorcfg.batch` vectorises each)."""
        return self._stages

    @property
    def stateful(self) -> bool:
        """Whether some stage needs the raw value of every nominal sample (low-pass, dropout holding, a
        custom callable): the sensor then takes every sample of its schedule."""
        return any(stage.stateful for stage in self._stages)

    def reset(self, key: np.ndarray | np.random.Generator | np.random.RandomState, stride: int = 1) -> None:
        """Start an episode: per-episode draws (bias, scale, random-walk start) and cleared state.

        `key` is the sensor's episode key (`draws.sensor_key`: two 64-bit words), or a random stream whose
        next four words make one; `stride` is the sensor's constant interval in steps (1 when drawn):
        sample j is taken at step `j * stride`.
        """
        key = key if isinstance(key, np.ndarray) else rt.stream_key(key)
        if hasattr(self, "streams"):
            self.streams.rekey(key)
        else:
            self.streams = rt.Streams(key)
        self.stride = int(stride)
        for stage in self._stages:
            stage.reset(self.streams, self.stride)

    def __call__(self, value: np.ndarray, step: int, out: np.ndarray | None = None) -> np.ndarray:
        """The noisy version of `value` (never written to), sampled at physics step `step`."""
        lone = self._lone
        if lone is not None:  # additive noise only: one addition, inlined
            return np.add(value, lone.row(step), out=out)
        src = value
        if self._direct:
            dst = np.empty(self.shape, self.dtype) if out is None else out
            for stage in self._stages:
                stage(src, dst, step)
                src = dst
            return dst
        work = self._work
        for stage in self._stages:
            stage(src, work, step)
            src = work
        if self._image:
            np.rint(work, out=work)
            np.maximum(work, 0, out=work)
            np.minimum(work, 255, out=work)
        if out is None:
            return work.astype(self.dtype)
        np.copyto(out, work, casting="unsafe")
        return out


def _fuse(stages: list[rt.Stage]) -> list[rt.Stage]:
    """Adjacent additive stages (white noise, bias) become one `Sum`: one addition per sample."""
    out: list[rt.Stage] = []
    run: list[rt.Stage] = []
    for stage in [*stages, None]:
        if isinstance(stage, (rt.Gaussian, rt.Uniform, rt.Outlier)) or (
                isinstance(stage, rt.EpisodeDraw) and stage.op is np.add):
            run.append(stage)
            continue
        if len(run) > 1:
            out.append(rt.Sum(run[0].ctx, run))  # type: ignore[attr-defined]
        else:
            out.extend(run)
        run = []
        if stage is not None:
            out.append(stage)
    return out


class _Resolver:
    """Broadcasts one stage's parameters to the observation's shape, collecting problems."""

    def __init__(self, ctx: rt.Context, index: int, problems: list[Problem]):
        self.ctx, self.where, self.problems = ctx, f"noise.{index}", problems

    def problem(self, field: str, message: str) -> None:
        self.problems.append(Problem(message, loc=f"{self.where}.{field}"))

    def __call__(self, value: Any, field: str) -> Any:
        """A float, or a float64 array of the observation's shape; None stays None."""
        if value is None or isinstance(value, float):
            return value
        shape = self.ctx.shape
        entries = np.asarray(value, dtype=np.float64)
        size = math.prod(shape)
        if entries.size == size:
            return entries.reshape(shape)
        if shape and entries.size == shape[-1]:
            return np.ascontiguousarray(np.broadcast_to(entries, shape))
        choices = f"{size} (one per value)"
        if len(shape) > 1:
            choices += f" or {shape[-1]} (one per entry of the last axis)"
        self.problem(field, f"{entries.size} entries do not fit the observation's shape {shape}: give a number "
                            f"or {choices}")
        return 0.0

    def ordered(self, low: Any, high: Any, names: tuple[str, str]) -> None:
        if low is not None and high is not None and np.any(np.greater(low, high)):
            self.problem(names[0], f"{names[0]} must not exceed {names[1]} (for every value once broadcast to "
                                   f"the shape {self.ctx.shape}); swap them")


def _episode(op: Callable[..., Any]) -> Callable[[Any, _Resolver], rt.Stage]:
    def build(s: Any, r: _Resolver) -> rt.Stage:
        if s.uniform:
            low, high = r(s.low, "low"), r(s.high, "high")
            r.ordered(low, high, ("low", "high"))
            return rt.EpisodeDraw(r.ctx, op, None, (low, high))
        mean, std = s.normal_params()
        return rt.EpisodeDraw(r.ctx, op, (r(mean, "mean"), r(std, "std")), None)
    return build


def _uniform(s: Any, r: _Resolver) -> rt.Stage:
    low, high = r(s.low, "low"), r(s.high, "high")
    r.ordered(low, high, ("low", "high"))
    return rt.Uniform(r.ctx, low, high)


def _clip(s: Any, r: _Resolver) -> rt.Stage:
    low, high = r(s.min, "min"), r(s.max, "max")
    r.ordered(low, high, ("min", "max"))
    return rt.Clip(r.ctx, low, high)


def _misalign(s: Any, r: _Resolver) -> rt.Stage:
    from .misalign import Misalign

    if not r.ctx.shape or r.ctx.shape[-1] != 3:
        r.problem("type", f"misalign turns 3-vectors: the observation's last axis must hold 3 values; its shape is "
                          f"{r.ctx.shape}")
    return Misalign(r.ctx, s.matrix, s.std)


def _custom(s: Any, r: _Resolver) -> rt.Stage:
    fn, name = _import(s.callable, r)
    return rt.Custom(r.ctx, fn, name, f"{r.where}.callable")


def callable_reference(spec: Any) -> str:
    """How a custom stage's callable is named: its 'module:function' text, or a function's qualified name (the
    suite plan keeps it as the step's `callable` option)."""
    return spec if isinstance(spec, str) else str(getattr(spec, "__qualname__", spec))


def custom_name(reference: str) -> str:
    """A custom stage's callable as messages name it, from its `callable_reference`."""
    return f"custom noise callable {reference!r}"


def _import(spec: Any, r: _Resolver) -> tuple[Callable[..., Any], str]:
    """The callable a 'module:function' names, checked to take (value, random_state)."""
    if callable(spec):
        fn, name = spec, custom_name(callable_reference(spec))
    else:
        module_name, _, path = spec.partition(":")
        name = custom_name(spec)
        try:
            obj: Any = importlib.import_module(module_name)
        except ImportError as e:
            r.problem("callable", f"cannot import {module_name!r} for {spec!r}: {e}")
            return (lambda value, random_state: value), name
        for part in path.split("."):
            if not hasattr(obj, part):
                names = [n for n in dir(obj) if not n.startswith("_")]
                r.problem("callable", f"{getattr(obj, '__name__', module_name)!r} has no attribute {part!r}"
                                      f"{did_you_mean(part, names)}")
                return (lambda value, random_state: value), name
            obj = getattr(obj, part)
        fn = obj
    if not callable(fn):
        r.problem("callable", f"{name} is a {type(fn).__name__}, not a function")
        return (lambda value, random_state: value), name
    try:
        signature = inspect.signature(fn)
    except (TypeError, ValueError):  # no signature Python can read (some builtins): no way to tell before a call
        r.problem("callable", f"{name} has no signature Python can read, so whether it accepts (value, "
                              "random_state) cannot be checked before it is called: wrap it in a function "
                              "`def corrupt(value, random_state): ...`")
        return fn, name
    try:
        signature.bind(None, random_state=None)  # how the stage calls it (`filters.Custom`)
    except TypeError:
        r.problem("callable", f"{name} must accept (value, random_state), as a dm_control corruptor does; it "
                              f"takes {signature}")
    return fn, name


# One builder per row of the stage table (`config.noise.STAGES`); a test checks the keys agree.
BUILDERS: dict[str, Callable[[Any, _Resolver], rt.Stage]] = {
    "gaussian": lambda s, r: rt.Gaussian(r.ctx, r(s.mean, "mean"), r(s.std, "std")),
    "uniform": _uniform,
    "bias": _episode(np.add),
    "scale": _episode(np.multiply),
    "random_walk": lambda s, r: rt.RandomWalk(r.ctx, r(s.std, "std"), r(s.correlation_time, "correlation_time")),
    "quantize": lambda s, r: rt.Quantize(r.ctx, r(s.step, "step")),
    "clip": _clip,
    "dropout": lambda s, r: rt.Dropout(r.ctx, r(s.p, "p"), s.mode, s.per == "value"),
    "outlier": lambda s, r: rt.Outlier(r.ctx, r(s.p, "p"), r(s.scale, "scale")),
    "lowpass": lambda s, r: rt.Lowpass(r.ctx, r(s.cutoff, "cutoff")),
    "misalign": lambda s, r: _misalign(s, r),
    "custom": _custom,
}


def _build(config: Any, r: _Resolver) -> rt.Stage:
    """The stage; one with parameters drawn per episode is rebuilt at each reset (`noise.redrawn`), after
    both ends of every range are checked here."""
    from .redrawn import Redrawn, drawn_fields

    drawn = drawn_fields(config)
    if not drawn:
        return BUILDERS[config.type](config, r)
    for end in ("low", "high"):
        BUILDERS[config.type](config.model_copy(update={f: getattr(v, end) for f, v in drawn.items()}), r)
    return Redrawn(config, lambda concrete: BUILDERS[concrete.type](concrete, _Resolver(r.ctx, 0, [])))


def _work_dtype(dtype: np.dtype) -> np.dtype:
    if dtype.kind == "f":
        return np.dtype(np.float64) if dtype.itemsize >= 8 else np.dtype(np.float32)
    if dtype == np.uint8:
        return np.dtype(np.float32)
    return dtype  # custom stages only


def _check_dtype(stage: Any, dtype: np.dtype, r: _Resolver) -> bool:
    row = STAGES[stage.type]
    if dtype.kind == "f":
        return True
    if dtype == np.uint8:
        if not row.images:
            r.problem("type", f"{stage.type} cannot apply to a uint8 image: images take "
                              f"{', '.join(IMAGE_STAGES)} (results are rounded and clipped to 0..255)")
            return False
        if stage.type == "dropout" and stage.mode == "nan":
            r.problem("mode", "a uint8 image cannot hold NaN; use mode hold or zero")
            return False
        return True
    if not row.integers:
        r.problem("type", f"{stage.type} cannot apply to {dtype} values (ids or counts, such as a segmentation "
                          "image): only a custom stage can")
        return False
    return True


def _validated(stages: Sequence[Any]) -> tuple[Any, ...]:
    """Stage configs; plain mappings are validated here (errors located at `noise.<i>.<field>`)."""
    try:
        return _STAGE_LIST.validate_python(tuple(stages))
    except ValidationError as e:
        raise SuiteError([Problem(err["msg"], loc=".".join(["noise", *map(str, err["loc"])]))
                          for err in e.errors()]) from None


def build_noise(stages: Sequence[NoiseStage], shape: tuple[int, ...], dtype: Any,
                timestep: float) -> NoisePipeline | None:
    """A pipeline for one observation of `shape` and `dtype`, or None when it has no stages.

    `timestep` is the physics timestep in seconds (time-based stages use `step * timestep`). Raises
    SuiteError listing every problem, each located at `noise.<i>.<field>`.
    """
    configs = _validated(stages)
    if not configs:
        return None
    if not timestep > 0:
        raise ValueError(f"timestep must be positive seconds, got {timestep!r}")
    dtype = np.dtype(dtype)
    ctx = rt.Context(tuple(int(n) for n in shape), dtype, _work_dtype(dtype), float(timestep))
    problems: list[Problem] = []
    built = []
    for i, config in enumerate(configs):
        r = _Resolver(ctx, i, problems)
        if _check_dtype(config, dtype, r):
            built.append(_build(config, r))
    if problems:
        raise SuiteError(problems)
    for i, stage in enumerate(built):
        stage.stream = i  # its part of the sensor's counter-based streams
    pipeline = NoisePipeline(_fuse(built), [c.type for c in configs], ctx)
    pipeline.configs = configs  # the stages as configured: the suite plan's noise program (`plan.noise`)
    return pipeline
