"""Each noise stage's arithmetic, written once: array functions over any leading axes. Numpy only.

The per-sample pipeline (`stages`) calls them on one sample, the feature bank (`runtime.bank_noise`) on
the gathered values of many sensors, the batch (`batch.noise`, from the suite plan's programs) on
(simulations, ...) arrays; elementwise, so every path gives the same bits. What the numbers drawn per sample
become (`scaled`, `outlier`: a term added to the value) is written here too, and so are the numbers a stage
computes from its parameters before any sample (`width`, `clip_bounds`, `lowpass_alpha`,
`walk_coefficients`): the CPU stages and the suite plan's kernel numbers (`plan.noise`) both call them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["add", "scaled", "outlier", "multiply", "quantize", "clip", "walk", "lowpass", "dropout", "width",
           "clip_bounds", "lowpass_alpha", "walk_coefficients"]


def add(src: np.ndarray, term: Any, dst: np.ndarray) -> None:
    """Additive noise (white noise, outliers, bias, a random walk's state): dst = src + term."""
    np.add(src, term, dst)  # out positionally: a read applies this to a few values, where keywords cost


def scaled(x: np.ndarray, scale: Any, offset: Any = None) -> np.ndarray:
    """Numbers drawn per sample made a term, in place: x scale (+ offset), a gaussian's std z (+ mean: none for
    a centred one), a uniform's width u + low (`streams.Affine`, which `streams.add_sums` computes in one pass).
    Returns x."""
    np.multiply(x, scale, out=x)
    if offset is not None:
        np.add(x, offset, out=x)
    return x


def outlier(u: np.ndarray, z: np.ndarray, p: Any, scale: Any) -> np.ndarray:
    """An outlier's term, in place of the normals z: scale z where a value is hit (its uniform u < p), else 0.
    Returns z."""
    np.multiply(z, scale, out=z)
    z[~(u < p)] = 0
    return z


def multiply(src: np.ndarray, gain: Any, dst: np.ndarray) -> None:
    """A per-episode gain: dst = src * gain."""
    np.multiply(src, gain, dst)


def quantize(src: np.ndarray, step: Any, dst: np.ndarray) -> None:
    """Rounds to the nearest multiple of `step`."""
    np.divide(src, step, dst)
    np.rint(dst, dst)
    np.multiply(dst, step, dst)


def clip(src: np.ndarray, low: Any, high: Any, dst: np.ndarray) -> None:
    """Saturation (either bound may be None)."""
    if low is not None:
        np.maximum(src, low, out=dst)
        src = dst
    if high is not None:
        np.minimum(src, high, out=dst)
    elif low is None and dst is not src:
        np.copyto(dst, src)


def walk(carry: np.ndarray, z: np.ndarray, a: Any, c: Any, first: bool) -> np.ndarray:
    """A random walk over one block: state_j = a state_(j-1) + c z_j (Brownian: a is None), from `carry`
    (the state before the block, updated in place to the block's last). `z` is (block, *lead) and is
    scaled in place; with `first`, row 0 is the episode's start (`carry` itself, its z unused).
    Returns the states (block, *lead)."""
    np.multiply(z, c, out=z)
    if first:
        z[0] = 0
    if a is None:  # b_j = b_(j-1) + c z_j: one sequential sum, the same additions in the same order
        states = np.cumsum(np.concatenate([carry[None], z]), axis=0)[1:]
        if first:
            states[0] = carry
    else:
        states = np.empty_like(z)
        for j in range(len(z)):
            if not (first and j == 0):
                np.multiply(carry, a, out=carry)
                np.add(carry, z[j], out=carry)
            states[j] = carry
    carry[...] = states[-1]
    return states


def lowpass(state: np.ndarray, src: np.ndarray, alpha: Any, dst: np.ndarray) -> None:
    """One step of the first-order filter: state += alpha (src - state); dst = state."""
    np.subtract(src, state, out=dst)
    np.multiply(dst, alpha, out=dst)
    np.add(state, dst, out=state)
    np.copyto(dst, state)


def dropout(src: np.ndarray, lost: Any, replacement: Any, dst: np.ndarray) -> None:
    """Lost values (a mask broadcasting to the values) become `replacement` (held values, 0 or NaN)."""
    if dst is not src:
        np.copyto(dst, src)
    np.copyto(dst, replacement, where=lost)


# -- numbers made from a stage's parameters, before any sample ---------------------------------------

def width(low: Any, high: Any) -> Any:
    """A uniform draw's width: its values are low + width u, u in [0, 1)."""
    return np.subtract(high, low)


def clip_bounds(low: Any, high: Any) -> tuple[Any, Any]:
    """A clip's limits, a missing one infinite (no limit)."""
    return (-np.inf if low is None else low), (np.inf if high is None else high)


def lowpass_alpha(cutoff: Any, dt: float) -> Any:
    """A low-pass's coefficient for samples `dt` seconds apart: 1 - exp(-2 pi cutoff dt) (float64)."""
    return -np.expm1(-dt * np.multiply(2.0 * math.pi, cutoff))


def walk_coefficients(std: Any, tau: Any, dt: float) -> tuple[Any, Any]:
    """A random walk's (a, c) for sample indices `dt` seconds apart (float64): a = exp(-dt / tau), c = std
    sqrt(1 - a^2) with a correlation time; a Brownian walk (tau None): a None (b_j = b_(j-1) + c z_j),
    c = std sqrt(dt)."""
    if tau is None:
        return None, np.multiply(std, math.sqrt(dt))
    a = np.exp(-dt / np.asarray(tau))
    return a, np.multiply(std, np.sqrt(-np.expm1(-2.0 * dt / np.asarray(tau))))
