"""Noise for the feature bank: the same numbers as each sensor's own pipeline, applied in a few array ops.

A noise pipeline whose stages are additive noise (gaussian, uniform, outlier, bias), a random walk (a drift
that does not depend on the signal), a per-episode gain, quantisation or clipping can run inside the bank.
Every `chunk` steps the bank asks each sensor's own stages for the per-sample terms of that sensor's
samples in the next chunk (counter-based: the same numbers the per-sample path uses for those samples)
and writes them into "noise fields" laid out like the bank's history. A read then applies each pipeline's
stages, in order, with the stages' own array arithmetic (`noise.stages`), to the gathered values of every
sensor with the same stage sequence at once. Sensors whose pipelines hold lowpass, dropout or custom
stages stay on the per-sample path.

Bit-identity with the per-sample pipeline is the contract (the tests compare both paths).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..noise import arithmetic as ar
from ..noise import stages as rt
from ..noise.streams import Draw, numbers

__all__ = ["BankNoise", "program"]

Program = tuple[tuple[str, Any], ...]  # (kind, stage) pairs

# What the bank does with each runtime stage type: "term" stages add a per-sample row (white noise,
# outliers, their sums, a random walk's state: drawn a chunk ahead into a noise field); an episode draw
# adds or multiplies; quantize and clip are elementwise. A type missing here keeps its sensor per sample.
_KINDS: dict[type, Callable[[Any], str]] = {
    rt.Gaussian: lambda stage: "term",
    rt.Uniform: lambda stage: "term",
    rt.Outlier: lambda stage: "term",
    rt.Sum: lambda stage: "term",
    rt.RandomWalk: lambda stage: "term",
    rt.EpisodeDraw: lambda stage: "add" if stage.op is np.add else "mul",
    rt.Quantize: lambda stage: "quantize",
    rt.Clip: lambda stage: "clip",
}


def program(pipeline: Any) -> Program | None:
    """The pipeline as (kind, stage) pairs the bank can run, () for no noise, None when it cannot."""
    if pipeline is None:
        return ()
    if np.dtype(pipeline.dtype) != np.float64:
        return None
    ops: list[tuple[str, Any]] = []
    for stage in pipeline.stages:
        kind = _KINDS.get(type(stage))
        if kind is None:
            return None
        ops.append((kind(stage), stage))
    return tuple(ops)


def _term(v: np.ndarray, field: np.ndarray, positions: np.ndarray) -> None:
    ar.add(v, field.take(positions), v)


def _add(v: np.ndarray, values: np.ndarray, cols: np.ndarray) -> None:
    ar.add(v, values.take(cols), v)


def _mul(v: np.ndarray, values: np.ndarray, cols: np.ndarray) -> None:
    ar.multiply(v, values.take(cols), v)


def _quantize(v: np.ndarray, step: np.ndarray) -> None:
    ar.quantize(v, step, v)


def _clip(v: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    ar.clip(v, low, high, v)


# kind -> how a read applies it to the gathered values of a group (the stage's own arithmetic)
_APPLY: dict[str, Callable[..., None]] = {"term": _term, "add": _add, "mul": _mul, "quantize": _quantize,
                                          "clip": _clip}


class BankNoise:
    """Noise fields and per-group programs for the noisy members of a bank."""

    def __init__(self, channels: list[Any], programs: list[Program], cols: np.ndarray,
                 rows: int, chunk: int, sample_offsets: list[np.ndarray]):
        self.width = int(cols[-1])
        self.rows, self.chunk, self.cols = rows, chunk, cols
        self.shapes = [ch.shape for ch in channels]
        self.strides = [ch.interval for ch in channels]  # sample j of member i is taken at step j * stride
        self.offsets = sample_offsets  # per member: its sample steps within one chunk, relative
        self.places, self.first, self.first_places = self._layout(sample_offsets)
        groups: dict[tuple[str, ...], list[int]] = {}
        for i, ops in enumerate(programs):
            if ops:
                groups.setdefault(tuple(kind for kind, _ in ops), []).append(i)
        self.programs = programs
        self.groups = [(signature, members) for signature, members in groups.items()]
        self.nfields = max((sig.count("term") for sig, _ in self.groups), default=0)
        self.fields = np.zeros((self.nfields, rows, self.width))
        self.flat_fields = self.fields.reshape(self.nfields, rows * self.width)
        # per group and op position: full-width parameter vectors (constants now, episode draws at reset)
        self.params: list[list[Any]] = []
        for signature, members in self.groups:
            per_op: list[Any] = []
            for q, kind in enumerate(signature):
                if kind == "quantize":
                    per_op.append((self._full(members, q, lambda s: s.step, np.nan),))
                elif kind == "clip":
                    per_op.append((self._full(members, q, lambda s: s.low, -np.inf),
                                   self._full(members, q, lambda s: s.high, np.inf)))
                else:  # add / mul: this episode's draws, filled at `start`; term: a noise field
                    per_op.append((np.zeros(self.width),) if kind in ("add", "mul") else ())
            self.params.append(per_op)

    def _full(self, members: list[int], q: int, get: Any, missing: float) -> np.ndarray:
        full = np.full(self.width, missing)
        for i in members:
            value = get(self.programs[i][q][1])
            full[self.cols[i]:self.cols[i + 1]] = missing if value is None else np.broadcast_to(
                value, self.shapes[i]).ravel()
        return full

    # -- per episode and per chunk ----------------------------------------------------------------

    def start(self) -> None:
        """After the pipelines' reset: this episode's draws, and the first chunk of noise."""
        for (signature, members), per_op in zip(self.groups, self.params):
            for q, kind in enumerate(signature):
                if kind in ("add", "mul"):
                    for i in members:
                        per_op[q][0][self.cols[i]:self.cols[i + 1]] = self.programs[i][q][1].value.ravel()
        self.fill(0)

    def _layout(self, sample_offsets: list[np.ndarray]) -> tuple[list[np.ndarray], ...]:
        """Per member: the flat positions (in a noise field, from a chunk's first row) of its values at its
        sample steps; the steps of an episode's first chunk (the reset sample first, when it is not among
        them) and their positions."""
        def places(i: int, offsets: np.ndarray) -> np.ndarray:
            return (offsets[:, None] * self.width + np.arange(self.cols[i], self.cols[i + 1])[None, :]).ravel()

        first = [offsets if len(offsets) and offsets[0] == 0 else np.concatenate(([0], offsets)).astype(np.intp)
                 for offsets in sample_offsets]
        return ([places(i, o) for i, o in enumerate(sample_offsets)], first,
                [places(i, o) for i, o in enumerate(first)])

    def fill(self, step: int) -> None:
        """Write the per-sample terms of every noisy member's samples in steps [step, step + chunk): the
        numbers of the samples taken only, of every member, from one Philox call (`streams.numbers`); a
        random walk walks every index (`rows_at`). `step` is a multiple of the chunk, which divides the
        rows, so a chunk's rows do not wrap."""
        jobs: list[tuple[Any, int, np.ndarray, int, int]] = []
        draws: list[Draw] = []
        start = (step % self.rows) * self.width
        for i, ops in enumerate(self.programs):
            if not ops:
                continue
            offsets, places = (self.first[i], self.first_places[i]) if step == 0 else (self.offsets[i], self.places[i])
            places = places + start
            indices = (step + offsets) // self.strides[i]
            terms = [stage for kind, stage in ops if kind == "term"]
            for j, stage in enumerate(terms):
                if isinstance(stage, rt.RandomWalk):
                    self.flat_fields[j].put(places, stage.rows_at(indices))
                    continue
                drawn = stage.draws(indices, np.broadcast_to(stage.streams.keys, (len(indices), 2)))
                jobs.append((stage, j, places, len(draws), len(drawn)))
                draws.extend(drawn)
        raw = numbers(draws)
        for stage, j, places, at, count in jobs:
            self.flat_fields[j].put(places, stage.shape(raw[at:at + count], len(places) // stage.size))

    # -- reads ------------------------------------------------------------------------------------

    def plan(self, index: np.ndarray) -> list[Any]:
        """For a gather `index` (flat history positions): per group, where its values are and what to do."""
        columns = index % self.width
        out = []
        for (signature, members), per_op in zip(self.groups, self.params):
            wanted = np.zeros(self.width, bool)
            for i in members:
                wanted[self.cols[i]:self.cols[i + 1]] = True
            pos = np.flatnonzero(wanted[columns])
            if not len(pos):
                continue
            cols = columns[pos]
            ops, j = [], 0
            for kind, p in zip(signature, per_op):
                if kind == "term":
                    args: tuple[Any, ...] = (self.flat_fields[j], index[pos])
                    j += 1
                elif kind in ("add", "mul"):
                    args = (p[0], cols)
                else:
                    args = tuple(a.take(cols) for a in p)
                ops.append((_APPLY[kind], args))
            out.append((pos, ops))
        return out

    def apply(self, gathered: np.ndarray, plan: list[Any]) -> None:
        """Apply every group's stages, in order, to its gathered values (in place)."""
        for pos, ops in plan:
            v = gathered.take(pos)
            for apply, args in ops:
                apply(v, *args)
            gathered[pos] = v
