"""A sensor's noise pipeline as data (`NoiseProgram`): each configured stage's type, stream and parameters, its
kernel-ready numbers and what it draws at each reset (`ResetDraw` records), and the level blend's bounds.

The numbers come from the rules' one home in `noise/` (`noise.arithmetic`'s `width`, `clip_bounds`,
`lowpass_alpha`, `walk_coefficients`; the draws' builders `stages.value_draw`, `stages.start_draw`,
`misalign.rotation_draw`, `redrawn.params_draw`), which the CPU stages call too. `episode` is what an engine
does with a program at a reset: every value drawn from the episode key (`noise.streams.draw_episode`), a step
with parameters drawn per episode rebuilt with this episode's (`redrawn`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..config.noise import EpisodeUniform, NoiseStage
from ..noise.level import LeveledPipeline
from ..noise.arithmetic import clip_bounds, lowpass_alpha, walk_coefficients, width
from ..noise.misalign import matrix as misalign_matrix
from ..noise.misalign import rotation_draw
from ..noise.pipeline import callable_reference
from ..noise.redrawn import params_draw
from ..noise.stages import Sum, start_draw, value_draw
from ..noise.streams import ResetDraw, Streams, draw_episode
from .records import DrawnTiming, FixedTiming, FloatArray, NoiseProgram, NoiseStep, UInt64Array, frozen

if TYPE_CHECKING:
    from ..noise.pipeline import NoisePipeline

__all__ = ["ADDITIVE", "StepEpisode", "episode", "episodes", "program", "redrawn", "step"]

ADDITIVE = frozenset({"gaussian", "uniform"})  # stages that only add numbers drawn per sample
_WORDS = (str,)


def _param(value: object, shape: tuple[int, ...]) -> FloatArray:
    """A numeric parameter broadcast to the sensor's values and raveled (a 3 x 3 matrix stays 3 x 3)."""
    array = np.asarray(value, np.float64)
    if array.shape == (3, 3):
        return frozen(array)
    return frozen(np.broadcast_to(array, shape).ravel())


def step(config: NoiseStage, stream: int, shape: tuple[int, ...]) -> NoiseStep:
    """One stage's config (a validated `config.noise` model) as a `NoiseStep` of its parameters alone (no
    kernel numbers nor draws: `program` adds them)."""
    params: list[tuple[str, FloatArray]] = []
    options: list[tuple[str, str]] = []
    drawn: list[str] = []
    for name in type(config).model_fields:
        value = getattr(config, name)
        if name == "type" or value is None:
            continue
        if callable(value):  # a custom stage's function: its name alone (a plan holds no callables)
            options.append((name, callable_reference(value)))
            continue
        if isinstance(value, EpisodeUniform):
            drawn.append(name)
            value = value.low
        if isinstance(value, _WORDS):
            options.append((name, value))
        elif isinstance(value, bool):
            options.append((name, str(value).lower()))
        else:
            try:
                params.append((name, _param(value, shape)))
            except (TypeError, ValueError):  # a word list or a callable reference: not numeric
                options.append((name, str(value)))
    redraw = None
    if drawn:
        redraw = _frozen_draw(params_draw(stream, [getattr(config, name) for name in drawn]))
    return NoiseStep(config.type, stream, tuple(params), tuple(options), tuple(drawn), (), None, redraw)


def _frozen_draw(draw: ResetDraw | None) -> ResetDraw | None:
    if draw is None:
        return None
    return draw._replace(scale=frozen(draw.scale), offset=None if draw.offset is None else frozen(draw.offset))


class _At(NamedTuple):
    """What a stage's kernel numbers depend on besides its parameters."""

    stream: int
    size: int  # values per sample
    dt: float  # seconds between two nominal samples (stride x timestep)
    timestep: float
    gaps: int  # the most steps between two samples of a drawn schedule (0: fixed)


_Numbers = tuple[dict[str, object], "ResetDraw | None"]  # kernel numbers by name, the draw at a reset


def _gaussian(p: dict[str, FloatArray], at: _At) -> _Numbers:
    mean = {"mean": p["mean"]} if np.any(p["mean"]) else {}  # (`stages.Gaussian`: a centred one adds std z alone)
    return {"std": p["std"], **mean}, None


def _clip(p: dict[str, FloatArray], at: _At) -> _Numbers:
    low, high = clip_bounds(p.get("min"), p.get("max"))
    return {"low": np.broadcast_to(low, (at.size,)), "high": np.broadcast_to(high, (at.size,))}, None


def _lowpass(p: dict[str, FloatArray], at: _At) -> _Numbers:
    alphas = {"alphas": np.stack([lowpass_alpha(p["cutoff"], gap * at.timestep) for gap in range(at.gaps + 1)])}
    return {"alpha": lowpass_alpha(p["cutoff"], at.dt), **(alphas if at.gaps else {})}, None


def _random_walk(p: dict[str, FloatArray], at: _At) -> _Numbers:
    tau = p.get("correlation_time")
    a, c = walk_coefficients(p["std"], tau, at.dt)
    return {"a": np.ones(at.size) if a is None else a, "c": c}, start_draw(at.stream, (at.size,), p["std"], tau)


def _drawn_value(centre: float) -> Callable[[dict[str, FloatArray], _At], _Numbers]:
    """A bias's (centred on 0) or a scale's (on 1: `config.noise.ScaleStage`'s mean unless given) values."""
    def numbers(p: dict[str, FloatArray], at: _At) -> _Numbers:
        uniform = (p["low"], p["high"]) if "low" in p else None
        return {}, value_draw(at.stream, (at.size,), (p.get("mean", centre), p.get("std", 0.0)), uniform)
    return numbers


def _misalign(p: dict[str, FloatArray], at: _At) -> _Numbers:
    std = None if "std" not in p else float(p["std"][0])
    return {"matrix": p.get("matrix", np.eye(3))}, rotation_draw(at.stream, std)


def _named(*names: str) -> Callable[[dict[str, FloatArray], _At], _Numbers]:
    """A stage whose kernel numbers are its parameters of these names, as they are."""
    return lambda p, at: ({name: p[name] for name in names if name in p}, None)


# per stage type: its kernel numbers and its draw at a reset, from its parameters (`noise.arithmetic` and the
# draws' builders: what the CPU stage computes); `warp.support.STAGES` names each type the Warp engine runs
_NUMBERS: dict[str, Callable[[dict[str, FloatArray], _At], _Numbers]] = {
    "gaussian": _gaussian,
    "uniform": lambda p, at: ({"low": p["low"], "width": width(p["low"], p["high"])}, None),
    "clip": _clip,
    "quantize": _named("step"),
    "dropout": _named("p"),
    "outlier": _named("p", "scale"),
    "lowpass": _lowpass,
    "random_walk": _random_walk,
    "bias": _drawn_value(0.0),
    "scale": _drawn_value(1.0),
    "misalign": _misalign,
}


def _numbers(s: NoiseStep, size: int, stride: int, timestep: float, gaps: int) -> NoiseStep:
    """`s` with its kernel numbers and its own draw at a reset (`_NUMBERS`; none for a stage without a row)."""
    numbers = _NUMBERS.get(s.stage)
    kernel, draw = ({}, None) if numbers is None else numbers(dict(s.params), _At(s.stream, size, stride * timestep,
                                                                                    timestep, gaps))
    frozen_kernel = tuple((name, frozen(np.asarray(value, np.float64))) for name, value in kernel.items())
    return s._replace(kernel=frozen_kernel, episode=_frozen_draw(draw))


def _gaps(timing: FixedTiming | DrawnTiming) -> int:
    """The most steps between two samples of a drawn schedule (its largest interval); 0 for a fixed one."""
    if isinstance(timing, FixedTiming):
        return 0
    return int(np.max(timing.interval.values))


def program(pipeline: NoisePipeline | None, shape: tuple[int, ...], stride: int,
            timing: FixedTiming | DrawnTiming) -> NoiseProgram | None:
    """The program of a sensor's pipeline (`noise.pipeline.NoisePipeline`, leveled or not), or None."""
    if pipeline is None:
        return None
    size, gaps = int(np.prod(shape, dtype=np.int64)), _gaps(timing)
    steps = tuple(_numbers(step(config, i, shape), size, int(stride), pipeline.timestep, gaps)
                  for i, config in enumerate(pipeline.configs))
    leveled = isinstance(pipeline, LeveledPipeline)
    bounds = pipeline.blend_bounds() if isinstance(pipeline, LeveledPipeline) else None
    if bounds is not None:
        bounds = (frozen(np.broadcast_to(np.asarray(bounds[0], np.float64), shape).ravel()),
                  frozen(np.broadcast_to(np.asarray(bounds[1], np.float64), shape).ravel()))
    sums = tuple((min(p.stream for p in stage.parts), max(p.stream for p in stage.parts) + 1)
                 for stage in pipeline.stages if isinstance(stage, Sum))  # adjacent additive steps (`pipeline._fuse`)
    return NoiseProgram(steps, int(stride), bool(pipeline.stateful), leveled,
                        all(s.stage in ADDITIVE and not s.drawn for s in steps), float(pipeline.timestep), gaps,
                        bounds, sums)


def redrawn(s: NoiseStep, values: FloatArray, noise: NoiseProgram) -> NoiseStep:
    """Step `s` of program `noise` with its parameters drawn per episode set to `values` (one per name of
    `s.drawn`, as `draw_episode(s.redraw, ...)` gives them), its kernel numbers and draw made from them."""
    size = s.params[0][1].size if s.params else 1
    update = {name: frozen(np.full(size, float(v))) for name, v in zip(s.drawn, values)}
    params = tuple((name, update.get(name, value)) for name, value in s.params)
    return _numbers(s._replace(params=params, drawn=(), redraw=None), size, noise.stride, noise.timestep, noise.gaps)


class StepEpisode(NamedTuple):
    """A step of a program in one episode: `step` with its parameters drawn per episode this episode's (its
    kernel numbers made from them), `values` drawn at the reset (a bias's or scale's values, a random walk's
    start; None for none) and `matrix` (a misalign's R M, 3 x 3; None for other stages)."""

    step: NoiseStep
    values: FloatArray | None
    matrix: FloatArray | None


def episode(noise: NoiseProgram, key: UInt64Array) -> tuple[StepEpisode, ...]:
    """What program `noise` draws at the reset of an episode whose sensor key is `key` ((2,) uint64,
    `draws.sensor_key`), step by step: the parameters drawn per episode first (`NoiseStep.redraw`), then the
    step's own draw (`NoiseStep.episode`), each by `noise.streams.draw_episode`."""
    return _episode(noise, Streams(key))


def episodes(noise: NoiseProgram, keys: UInt64Array) -> list[tuple[StepEpisode, ...]]:
    """`episode` of each key of `keys` (m, 2): the episodes of many simulations reset at once (one generator,
    rekeyed for each)."""
    if not len(keys):
        return []
    streams = Streams(keys[0])
    out = []
    for key in keys:
        streams.rekey(key)
        out.append(_episode(noise, streams))
    return out


def _episode(noise: NoiseProgram, streams: Streams) -> tuple[StepEpisode, ...]:
    out = []
    for s in noise.steps:
        if s.redraw is not None:
            s = redrawn(s, draw_episode(s.redraw, streams), noise)
        values = None if s.episode is None else draw_episode(s.episode, streams)
        if s.stage == "misalign":
            out.append(StepEpisode(s, None, misalign_matrix(s.number("matrix"), values)))
        else:
            out.append(StepEpisode(s, values, None))
    return tuple(out)
