"""Noise for the feature bank: the same numbers as each sensor's own pipeline, applied in a few array ops.

A noise pipeline whose stages are additive noise (gaussian, uniform, outlier, bias: pre-drawn per sample),
a random walk (a drift that does not depend on the signal), a per-episode gain, quantisation or clipping
can run inside the bank. Every `chunk` steps the bank draws, from each sensor's own stage generators and in
the order the pipeline itself would draw them, the per-sample noise of that sensor's samples for the next
chunk into "noise fields" laid out like the bank's history. A read then applies each pipeline's stages, in
order, to the gathered values of every sensor with the same stage sequence at once. Sensors whose
pipelines hold lowpass, dropout or custom stages stay on the per-sample path.

Bit-identity with the per-sample pipeline is the contract (the tests compare both paths).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..noise import stages as rt

__all__ = ["BankNoise", "program"]

Program = tuple[tuple[str, Any], ...]  # (op, stage) pairs


def program(pipeline: Any) -> Program | None:
    """The pipeline as (op, stage) pairs the bank can run, () for no noise, None when it cannot."""
    if pipeline is None:
        return ()
    if np.dtype(pipeline.dtype) != np.float64:
        return None
    ops: list[tuple[str, Any]] = []
    for stage in pipeline._stages:
        if isinstance(stage, rt._Additive):
            ops.append(("field", stage))
        elif isinstance(stage, rt.RandomWalk):
            ops.append(("walk", stage))
        elif isinstance(stage, rt.EpisodeDraw) and stage.op in (np.add, np.multiply):
            ops.append(("add" if stage.op is np.add else "mul", stage))
        elif isinstance(stage, rt.Quantize):
            ops.append(("quantize", stage))
        elif isinstance(stage, rt.Clip):
            ops.append(("clip", stage))
        else:
            return None
    return tuple(ops)


def _next_rows(stage: Any, count: int, width: int) -> np.ndarray:
    """The next `count` per-sample rows of an additive stage, consumed as its pipeline would consume them
    (the same blocks, so the same numbers): sliced from the block behind its row views."""
    out = np.empty((count, width))
    done = 0
    while done < count:
        if stage.k == len(stage.rows):  # the stage's own refill, keeping the block as one array
            stage.rows = stage.draw(stage.rng, stage.ctx.block)
            stage.k = 0
        take = min(count - done, len(stage.rows) - stage.k)
        out[done:done + take] = np.reshape(stage.rows[stage.k:stage.k + take], (take, width))
        stage.k += take
        done += take
    return out


class BankNoise:
    """Noise fields and per-group programs for the noisy members of a bank."""

    def __init__(self, channels: list[Any], programs: list[Program], cols: np.ndarray,
                 rows: int, chunk: int, sample_offsets: list[np.ndarray]):
        self.width = int(cols[-1])
        self.rows, self.chunk, self.cols = rows, chunk, cols
        self.shapes = [ch.shape for ch in channels]
        self.offsets = sample_offsets  # per member: its sample steps within one chunk, relative
        groups: dict[tuple[str, ...], list[int]] = {}
        for i, ops in enumerate(programs):
            if ops:
                groups.setdefault(tuple(op for op, _ in ops), []).append(i)
        self.programs = programs
        self.groups = [(signature, members) for signature, members in groups.items()]
        self.nfields = max((sum(op in ("field", "walk") for op in sig) for sig, _ in self.groups), default=0)
        self.fields = np.zeros((self.nfields, rows, self.width))
        self.flat_fields = self.fields.reshape(self.nfields, -1)
        # per group and op position: a full-width parameter vector (constants now, episode draws at reset)
        self.params: list[list[Any]] = []
        for signature, members in self.groups:
            per_op: list[Any] = []
            for q, op in enumerate(signature):
                if op == "quantize":
                    per_op.append(self._full(members, q, lambda s: s.step, np.nan))
                elif op == "clip":
                    per_op.append((self._full(members, q, lambda s: s.low, -np.inf),
                                   self._full(members, q, lambda s: s.high, np.inf)))
                elif op in ("add", "mul"):
                    per_op.append(np.zeros(self.width))
                else:
                    per_op.append(None)
            self.params.append(per_op)
        self.noisy = np.zeros(self.width, bool)
        for _, members in self.groups:
            for i in members:
                self.noisy[cols[i]:cols[i + 1]] = True

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
            for q, op in enumerate(signature):
                if op in ("add", "mul"):
                    for i in members:
                        per_op[q][self.cols[i]:self.cols[i + 1]] = self.programs[i][q][1].value.ravel()
        self.fill(0)

    def fill(self, step: int) -> None:
        """Draw the noise of every noisy member's samples in steps [step, step + chunk)."""
        for i, ops in enumerate(self.programs):
            if not ops:
                continue
            steps = step + self.offsets[i]
            if step == 0 and (len(steps) == 0 or steps[0] != 0):
                steps = np.concatenate(([0], steps))  # the reset sample is always taken
            rows = (steps % self.rows)[:, None]
            span = np.arange(self.cols[i], self.cols[i + 1])[None, :]
            width = span.shape[1]
            j = 0
            for op, stage in ops:
                if op == "field":
                    self.fields[j][rows, span] = _next_rows(stage, len(steps), width)
                elif op == "walk":
                    zero, out = np.zeros(self.shapes[i]), np.empty((len(steps), width))
                    row = np.empty(self.shapes[i])
                    for n, t in enumerate(steps.tolist()):
                        stage(zero, row, t)
                        out[n] = row.ravel()
                    self.fields[j][rows, span] = out
                else:
                    continue
                j += 1

    # -- reads ------------------------------------------------------------------------------------

    def plan(self, index: np.ndarray) -> list[Any]:
        """For a gather `index` (flat history positions): per group, where its values are and their params."""
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
            ops = []
            for q, op in enumerate(signature):
                p = per_op[q]
                if op == "quantize":
                    ops.append((op, p.take(cols)))
                elif op == "clip":
                    ops.append((op, (p[0].take(cols), p[1].take(cols))))
                elif op in ("add", "mul"):
                    ops.append((op, (p, cols)))
                else:
                    ops.append((op, None))
            out.append((pos, index[pos], ops))
        return out

    def apply(self, gathered: np.ndarray, plan: list[Any]) -> None:
        """Apply every group's stages, in order, to its gathered values (in place)."""
        for pos, fidx, ops in plan:
            v = gathered.take(pos)
            j = 0
            for op, p in ops:
                if op == "field" or op == "walk":
                    np.add(v, self.flat_fields[j].take(fidx), out=v)
                    j += 1
                elif op == "add":
                    np.add(v, p[0].take(p[1]), out=v)
                elif op == "mul":
                    np.multiply(v, p[0].take(p[1]), out=v)
                elif op == "quantize":
                    np.divide(v, p, out=v)
                    np.rint(v, out=v)
                    np.multiply(v, p, out=v)
                else:
                    np.maximum(v, p[0], out=v)
                    np.minimum(v, p[1], out=v)
            gathered[pos] = v
