"""`--plot`: one row per sensor: when samples were taken and delivered, and what they said.

Left, on a time axis shared by every sensor, a short window of the run: a tick per sample (top), a tick
per delivery (bottom) and a line joining them, over faint lines at the control steps (when the agent
reads); samples that no read could show, which the Updater skips, are light grey (a legend under the figure
says so). Interval, delay and jitter are visible at a glance. Right, the signal over the whole run (the
newest sample of a buffer), one axis per quantity and unit with a legend naming each value (up to eight per
axis), or for a camera a contact sheet of frames.
Uses matplotlib's object API with the Agg canvas: no display, no pyplot state.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..config.tables import IMAGE_KINDS
from ..errors import printable
from .common import UsageError, require_matplotlib
from .describe import SensorRow
from .quantities import ValueGroup

__all__ = ["plot_run"]

MAX_LINES = 8
FRAMES = 6
SKIPPED, READ = "0.8", "0.88"  # colours of skipped samples' ticks and of the control steps' lines


def _window(timings: dict[str, Any], physics_steps: int, n: int) -> int:
    """Physics steps shown in the timing column: enough for a few samples of the slowest sensor."""
    span = n
    for t in timings.values():
        if len(t.sampled) > 1:
            span = max(span, int(np.max(np.diff(t.sampled))))
        if len(t.sampled):
            span = max(span, int(np.max(t.delivered - t.sampled)))
    return max(1, min(physics_steps, max(10 * n, 4 * span)))


def _timing(ax: Any, timing: Any, window: int, n: int, dt: float) -> None:
    for read in np.arange(0, window + 1, n):
        ax.axvline(read * dt, color=READ, lw=0.6, zorder=0)
    if timing is not None:
        keep = timing.sampled <= window
        s, d, seen = timing.sampled[keep] * dt, timing.delivered[keep] * dt, timing.visible[keep]
        if not seen.all():  # samples no read can show: the Updater skips them
            ax.plot(s[~seen], np.ones((~seen).sum()), "|", color=SKIPPED, ms=7, mew=1)
            ax.plot(d[~seen], np.zeros((~seen).sum()), "|", color=SKIPPED, ms=7, mew=1)
        for a, b in zip(s[seen], d[seen]):
            ax.plot([a, b], [1, 0], color="0.55", lw=0.6, zorder=1)
        ax.plot(s[seen], np.ones(seen.sum()), "|", color="C0", ms=10, mew=1.5)
        ax.plot(d[seen], np.zeros(seen.sum()), "|", color="C3", ms=10, mew=1.5)
    ax.set_yticks([0, 1], ["delivered", "sampled"], fontsize=7)
    ax.set_ylim(-0.5, 1.5)
    ax.set_xlim(-0.5 * dt, window * dt + 0.5 * dt)
    ax.tick_params(axis="x", labelsize=7)


def _newest(values: np.ndarray, row: SensorRow) -> np.ndarray:
    """Drop the buffer axis (keep the newest sample) when the observation has one and no aggregator."""
    return values[:, -1] if row.buffer_axis else values
    return values


def _signal(fig: Any, cell: Any, t: np.ndarray, values: np.ndarray, row: SensorRow,
            groups: Sequence[ValueGroup], share: Any) -> list[Any]:
    """One axis per quantity and unit (a gyro's rad/s apart from an accelerometer's m/s²), each value a
    labelled line; returns the axes, top first."""
    flat = _newest(values, row).reshape(len(t), -1).astype(np.float64)
    grid = cell.subgridspec(len(groups), 1)
    axes: list[Any] = []
    for k, group in enumerate(groups):
        ax = fig.add_subplot(grid[k, 0], sharex=share or (axes[0] if axes else None))
        shown = group.columns[:MAX_LINES]
        for j, column in enumerate(shown):
            ax.plot(t, flat[:, column], lw=1, drawstyle="steps-post", label=printable(group.labels[j], 40))
        more = len(group.columns) - len(shown)
        title = group.quantity + (f"\n(first {len(shown)} of {len(group.columns)})" if more else "")
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.005, 1.0), ncol=1 + (len(shown) > 4),
                  frameon=False, borderaxespad=0.0, title=title, title_fontsize=6, alignment="left")
        ax.set_ylabel(group.unit or "no unit", fontsize=7)
        ax.tick_params(labelsize=7)
        if k < len(groups) - 1:
            ax.tick_params(labelbottom=False)
        axes.append(ax)
    note = f"{flat.shape[1]} value{'s' if flat.shape[1] != 1 else ''}"
    axes[0].set_title(note, loc="right", fontsize=7, color="0.35")
    return axes


def _timing_legend(fig: Any) -> None:
    """What the ticks of the timing column mean, once for the figure."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], ls="", marker="|", ms=9, mew=1.5, color="C0"),
               Line2D([], [], ls="", marker="|", ms=9, mew=1.5, color="C3"),
               Line2D([], [], ls="", marker="|", ms=9, mew=1, color=SKIPPED),
               Line2D([], [], color=READ, lw=1.2)]
    labels = ["sampled", "delivered (after the delay)", "skipped: no read can show it, so the Updater does not take "
              "it", "control step (a read)"]
    fig.legend(handles, labels, loc="outside lower left", ncol=4, fontsize=7, frameon=False)


def _frame(image: np.ndarray, kind: str) -> np.ndarray:
    """A displayable RGB float image of one camera sample."""
    if kind == "rgb":
        return image[..., :3].astype(np.float64) / 255.0
    if kind == "depth":
        d = image[..., 0].astype(np.float64)
        finite = d[np.isfinite(d)]
        lo, hi = (finite.min(), finite.max()) if finite.size else (0.0, 1.0)
        g = 1.0 - (d - lo) / (hi - lo if hi > lo else 1.0)
        return np.repeat(np.nan_to_num(g)[..., None], 3, axis=-1)
    ids = image[..., 0].astype(np.int64)
    palette = np.random.default_rng(7).uniform(0.15, 0.95, size=(max(int(ids.max()) + 2, 2), 3))
    palette[0] = 0.0  # background (id -1)
    return palette[ids + 1]


def _contact_sheet(ax: Any, t: np.ndarray, values: np.ndarray, row: SensorRow) -> None:
    frames = _newest(values, row)
    picks = np.unique(np.linspace(0, len(t) - 1, min(FRAMES, len(t))).round().astype(int))
    tiles = [_frame(frames[i], row.kind) for i in picks]
    h, w = tiles[0].shape[:2]
    gap = max(2, w // 20)
    sheet = np.ones((h, len(tiles) * (w + gap) - gap, 3))
    for k, tile in enumerate(tiles):
        sheet[:, k * (w + gap):k * (w + gap) + w] = tile
    ax.imshow(sheet, interpolation="nearest", aspect="equal")
    labels = [f"t={t[i]:.3g}s" + ("\n(nothing delivered yet)" if not np.any(frames[i]) else "") for i in picks]
    ax.set_xticks([k * (w + gap) + w / 2 for k in range(len(tiles))], labels, fontsize=7)
    ax.set_yticks([])


def _steps(text: str) -> str:
    return f"{text} step" if text == "1" else f"{text} steps"


def plot_run(path: Path, rec: Any, rows: list[SensorRow], timings: dict[str, Any], dt: float, *,
             title: str, groups: Mapping[str, Sequence[ValueGroup]]) -> None:
    """The figure of a run; `groups` says, per sensor that is not a camera, which values share a quantity
    and unit (`quantities.value_groups`): each group is an axis with its unit and a legend."""
    require_matplotlib()
    from matplotlib.figure import Figure
    n = int(round((rec.time[1] - rec.time[0]) / dt)) if len(rec.time) > 1 else 1
    physics_steps = rec.steps_done * n
    window = _window(timings, physics_steps, n)
    heights = [2.0 if r.kind in IMAGE_KINDS else 1.3 * max(1.0, 0.8 * len(groups[r.name])) for r in rows] or [1.0]
    fig = Figure(figsize=(13, 1.2 + sum(heights)), layout="constrained")
    grid = fig.add_gridspec(len(heights), 2, width_ratios=[1, 2.4], height_ratios=heights)
    fig.suptitle(f"{title}: {rec.steps_done} control steps of {n * dt * 1e3:g} ms", fontsize=10)
    first_timing = first_signal = None
    for i, row in enumerate(rows):
        ax_t = fig.add_subplot(grid[i, 0], sharex=first_timing)
        first_timing = first_timing or ax_t
        _timing(ax_t, timings.get(row.name), window, n, dt)
        label = (f"{row.name}: {row.kind}, every {_steps(row.interval)} ({row.rate_hz} Hz), "
                 f"delay {_steps(row.delay)} ({row.delay_ms} ms)")
        ax_t.set_title(label, fontsize=8, loc="left")
        values = rec.observations[row.name]
        signal = None
        if row.kind in IMAGE_KINDS:
            _contact_sheet(fig.add_subplot(grid[i, 1]), rec.time, values, row)
        else:
            axes = _signal(fig, grid[i, 1], rec.time, values, row, groups[row.name], first_signal)
            first_signal, signal = first_signal or axes[0], axes[-1]
        if i == len(rows) - 1:
            ax_t.set_xlabel("time (s), the first steps", fontsize=8)
            if signal is not None:
                signal.set_xlabel("time (s)", fontsize=8)
    if first_signal is not None:
        first_signal.set_title("signal over the run (newest sample, held between reads)", fontsize=8, loc="left")
    _timing_legend(fig)
    try:
        fig.savefig(path, dpi=100)
    except OSError as e:
        raise UsageError(f"{printable(str(path))}: cannot write the plot: {printable(str(e.strerror or e))}") from None
