"""A feature bank's read as one call of the compiled kernel (`_kernel.read`, where it is built).

A compiled read (`bank_read.compile_read`) is a fixed list of numpy calls on its own work buffer: the gather
from the history, the noise layers (`bank_noise.Layer`), the take that stacks the families' blocks, the
families' reductions and the means' divisions. Here the same list is encoded once as records of int64s (an
op code, the addresses of the arrays it works on, counts), which the kernel runs in one call: the same
arithmetic, in the same order, on the same arrays, so the bits are numpy's (the numpy steps are the
reference; tests/runtime/test_read_kernel.py compares the two). The encoder keeps every array it points to alive.

A read with a step the kernel does not have (a reduction that runs alone: a median of 3 or more, a one-value
sum or mean) keeps its numpy steps, and so does every read when the kernel is not built or
SENSORCFG_NUMPY_STREAMS=1. A read that writes padding between its noise and its reductions (early in an
episode) runs the program in two calls around it (`noised`, `reduced`).

A bank's snapshot (a take of the state into a history row, at every sampled step) is one kernel call too
(`kernel_snapshot`), where the kernel is built; numpy's take otherwise.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .. import compiled
from .bank_noise import Layer
from .bank_read import CompiledRead, KernelRead, Step

__all__ = ["kernel_read", "kernel_snapshot"]

# the kernel's op codes (`_kernel.c`, `read`), by the name of the numpy step they stand for
_CODES = {"gather": 1, "term": 2, "add": 3, "mul": 4, "quantize": 5, "clip": 6, "take": 7, "sum": 8, "max": 9,
          "min": 10, "divide": 11}




class _Program:
    """Records of (op code, out, a, b, positions or rows, count), each array kept."""

    def __init__(self) -> None:
        self.records: list[tuple[int, ...]] = []
        self.arrays: list[np.ndarray] = []
        self.made = 0  # bytes of the arrays made here

    def at(self, array: np.ndarray | None, dtype: Any = np.float64) -> int:
        """The address of `array` (0 for None), kept alive; it must be contiguous of `dtype` (views of the
        work buffer and the tables are)."""
        if array is None:
            return 0
        if array.dtype != dtype or not array.flags.c_contiguous:
            raise ValueError("a compiled read's arrays are contiguous float64 and int64")
        self.arrays.append(array)
        return int(array.__array_interface__["data"][0])

    def add(self, kind: str, out: np.ndarray, a: np.ndarray, b: int, positions: int, count: int) -> None:
        self.records.append((_CODES[kind], self.at(out), self.at(a), b, positions, count))

    def made_here(self, array: np.ndarray, dtype: Any) -> int:
        """The address of a contiguous copy of `array` (positions, columns, constants) made for the program."""
        copy = np.array(array, dtype, order="C")
        self.made += copy.nbytes
        return self.at(copy, dtype)

    def layer(self, layer: Layer, gathered: np.ndarray) -> None:
        at, count = self.made_here(layer.pos, np.int64), len(layer.pos)
        table = layer.table
        if layer.kind == "term":
            assert table is not None
            self.add("term", gathered, table, table.size, at, count)
        elif layer.kind in ("add", "mul"):
            assert table is not None
            self.add(layer.kind, gathered, table, self.made_here(layer.args[0], np.int64), at, count)
        else:  # quantize (step) and clip (low, high)
            first = np.array(layer.args[0], np.float64, order="C")
            self.made += first.nbytes
            high = self.made_here(layer.args[1], np.float64) if len(layer.args) > 1 else 0
            self.add(layer.kind, gathered, first, high, at, count)

    def step(self, step: Step) -> None:
        if step.kind == "take":
            assert step.positions is not None
            self.add("take", step.out, step.source, 0, self.made_here(step.positions, np.int64), len(step.positions))
        elif step.kind == "divide":
            self.add("divide", step.out, step.source, 0, 0, len(step.out))
        else:  # a family's reduction of a (buffer, width) window
            self.add(step.kind, step.out, step.source.reshape(-1), 0, step.source.shape[0], step.source.shape[1])


def kernel_read(compiled_read: CompiledRead, layers: Sequence[Layer], history: np.ndarray) -> KernelRead | None:
    """`compiled_read` (with its noise `layers`) as one kernel call reading `history` (flat), or None when the kernel
    is not built or a step is not one of its ops."""
    read = getattr(compiled.MODULE, "read", None)
    if read is None or any(step.kind not in _CODES for step in compiled_read.records):
        return None
    program = _Program()
    # the kernel checks the index
    program.add("gather", compiled_read.gathered, history, history.size, 0, len(compiled_read.gathered))
    for layer in layers:
        program.layer(layer, compiled_read.gathered)
    noised = len(program.records)
    for step in compiled_read.records:
        program.step(step)
    records = np.array(program.records, np.int64).reshape(-1, 6)  # (an empty program: no records at all)
    code, before, after = (part.tobytes() for part in (records, records[:noised], records[noised:]))
    return KernelRead(functools.partial(read, code), tuple(program.arrays), program.made + len(code),
                      functools.partial(read, before), functools.partial(read, after))


def kernel_snapshot(raw: np.ndarray, source: np.ndarray, history: np.ndarray, needed: bytearray | None,
                    owner: object) -> Callable[[int], None] | None:
    """A bank's snapshot task as one kernel call (`_kernel.snapshot`): at `step`, row step % rows of `history`
    takes raw[source] (numpy's take, mode="clip"), where `needed` marks the row (then cleared; None: at every
    call); or None when the kernel is not built or an array is not contiguous. The task keeps the arrays its
    program points to alive, and `owner` (what keeps `raw`'s memory)."""
    kernel = getattr(compiled.MODULE, "snapshot", None)
    arrays = (raw, source, history)
    if (kernel is None or raw.ndim != 1 or history.ndim != 2 or history.shape[1] != len(source)
            or not all(a.flags.c_contiguous for a in arrays)
            or (raw.dtype.type, source.dtype.type, history.dtype.type) != (np.float64, np.int64, np.float64)):
        return None
    need = None if needed is None else np.frombuffer(needed, np.uint8)
    at = 0 if need is None else need.ctypes.data
    program = np.array([at, raw.ctypes.data, raw.size, source.ctypes.data, len(source), history.ctypes.data,
                        history.shape[0]], np.int64).tobytes()
    return functools.partial(kernel, program, (arrays, need, owner))
