"""The per-sample numbers of a noise program's additive steps, from the program alone: what a term draws for a
sample (`noise.streams.Draw` records), the values it makes of them, and those values as affine terms where they
are (for `streams.add_sums`). A term is one step, or a fused run of adjacent additive steps (`NoiseProgram.sums`:
their values added up first, x + (a + b)).

The CPU stages (`noise.stages`) are the reference these are held to, bit for bit: the same numbers (stream =
the step's position, lane, value), the same float64 roundings in the same order (`noise.arithmetic.scaled` and
`outlier`, which the CPU stages and the batch call too; `random_walk`: the normals its walk is made of; a bias:
its episode's values).
"""

from __future__ import annotations

import types
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from ..noise import arithmetic as ar
from ..noise.streams import MAX_TERMS, Affine, Draw
from .records import FloatArray, NoiseProgram, NoiseStep, UInt64Array

__all__ = ["LANES", "NUMBERS", "NumberOf", "Term", "affine", "draws", "kernel_number", "term_of", "terms", "values"]

# per stage type drawing per-sample numbers: per lane, normals (True) or uniforms in [0, 1)
LANES: Mapping[str, tuple[bool, ...]] = types.MappingProxyType({
    "gaussian": (True,),
    "uniform": (False,),
    "outlier": (False, True),  # hits, jumps
    "random_walk": (True,),
    "dropout": (False,),
})
_TERMS = frozenset({"gaussian", "uniform", "outlier", "random_walk"})  # steps that are terms alone
# per stage type whose term computes with kernel numbers: their names (`NumberOf`)
NUMBERS: Mapping[str, tuple[str, ...]] = types.MappingProxyType({
    "gaussian": ("std", "mean"),
    "uniform": ("low", "width"),
    "outlier": ("p", "scale"),
})


class Term(NamedTuple):
    """An additive term of a sensor's program: its steps (one, or a fused run) and values per sample."""

    steps: tuple[NoiseStep, ...]
    size: int

    @property
    def first(self) -> int:
        """The position of its first step in the program."""
        return self.steps[0].stream


def term_of(program: NoiseProgram, first: int, size: int) -> Term:
    """The term that starts at step `first`: its fused run (`program.sums`), or the step alone."""
    stop = dict(program.sums).get(first, first + 1)
    return Term(program.steps[first:stop], size)


def terms(program: NoiseProgram, size: int) -> list[tuple[int, Term | None]]:
    """(position, term) of each stage as the CPU pipeline runs it: a fused run is one term, a step outside any
    run a term of its own when it is additive (None for the others, which are not terms)."""
    out: list[tuple[int, Term | None]] = []
    q = 0
    while q < len(program.steps):
        term = term_of(program, q, size)
        fused = len(term.steps) > 1
        out.append((q, term if fused or program.steps[q].stage in _TERMS else None))
        q += len(term.steps)
    return out


def _sizes(step: NoiseStep, size: int) -> tuple[int, ...]:
    """Values per sample of each lane (a dropout of whole samples draws one)."""
    per_value = dict(step.options).get("per") == "value"
    return tuple(1 if step.stage == "dropout" and not per_value else size for _ in LANES[step.stage])


def draws(term: Term, samples: npt.NDArray[np.int64], keys: UInt64Array) -> list[Draw]:
    """What `values` needs for samples `samples` of episode keys `keys` (m, 2), lane by lane, step by step."""
    return [Draw(keys, samples, s.stream, lane, n, normal)
            for s in term.steps if s.stage in LANES
            for lane, (n, normal) in enumerate(zip(_sizes(s, term.size), LANES[s.stage]))]


# A step's kernel number `name` (`NoiseStep.kernel`) as a term computes with it: one sample's values (size,),
# shared by every sample, or one row per sample (m, size) where its episode's numbers are its own (the batch's
# parameters drawn per episode); None where the step has no such number (a gaussian's mean when it is 0).
NumberOf = Callable[[NoiseStep, str], FloatArray | None]


def kernel_number(step: NoiseStep, name: str) -> FloatArray | None:
    """The program's own numbers (`NumberOf`): shared by every sample."""
    return dict(step.kernel).get(name)


def _fresh(raw: FloatArray, m: int, size: int) -> FloatArray:
    return np.array(raw.reshape(m, size), dtype=np.float64)


def _gaussian(z: FloatArray, std: FloatArray | None, mean: FloatArray | None) -> FloatArray:
    """std z (+ mean): a centred gaussian adds std z alone, and so does a sample whose own mean is all 0 (its
    episode's gaussian is centred: x + 0.0 would turn a -0.0 into 0.0)."""
    if mean is None or mean.ndim == 1:
        return ar.scaled(z, std, mean)
    z = ar.scaled(z, std)
    offset = np.any(mean, axis=1)
    if offset.any():
        z[offset] += mean[offset]
    return z


def _one(step: NoiseStep, raw: Sequence[FloatArray], m: int, size: int, number: NumberOf) -> FloatArray:
    """One drawing step's values (m, size) from its lanes' numbers."""
    stage = step.stage
    if stage == "gaussian":
        return _gaussian(_fresh(raw[0], m, size), number(step, "std"), number(step, "mean"))
    if stage == "uniform":
        return ar.scaled(_fresh(raw[0], m, size), number(step, "width"), number(step, "low"))
    if stage == "outlier":
        return ar.outlier(raw[0].reshape(m, size), _fresh(raw[1], m, size), number(step, "p"), number(step, "scale"))
    return _fresh(raw[0], m, size)  # a random walk's normals


def values(term: Term, raw: Sequence[FloatArray], m: int, episode: Sequence[FloatArray] = (),
           number: NumberOf = kernel_number) -> FloatArray:
    """The term's values of m samples (m, size) from the numbers `draws` gave (`raw`, lane by lane); `episode`:
    its bias steps' values this episode (each (size,) or per sample (m, size)), in order; `number`: the steps'
    numbers (the program's own, or each sample's episode's)."""
    total: FloatArray | None = None
    biases = iter(episode)
    at = 0
    for s in term.steps:
        if s.stage in LANES:
            lanes = len(LANES[s.stage])
            part = _one(s, raw[at:at + lanes], m, term.size, number)
            at += lanes
        else:
            part = np.asarray(next(biases))
        if total is None:  # the first step's values (a fresh array), or zeros plus the first bias
            total = part if s.stage in LANES else np.zeros((m, term.size)) + part
        else:
            total += part
    if total is None:
        raise ValueError("a term without steps (an internal error)")
    return total


def affine(term: Term) -> list[Affine] | None:
    """The term as numbers x scale (+ offset), lane by lane, added up (`streams.add_sums`): gaussian and uniform
    steps only, at most `MAX_TERMS` of them; else None."""
    out = []
    for s in term.steps:
        if s.stage == "gaussian":
            out.append(Affine(s.number("std"), s.number("mean") if "mean" in dict(s.kernel) else None))
        elif s.stage == "uniform":
            out.append(Affine(s.number("width"), s.number("low")))
        else:
            return None
    return out if len(out) <= MAX_TERMS else None
