"""`sensorcfg run`: simulate a suite on its model and record every observation at every control step.

Parse the settings, build an Environment from the suite, step it with zero (or random) actions while a
`Recording` keeps each observation, then report: a summary (speed, samples taken per sensor, samples and
renders the schedule skipped), the `.npz` with its JSON sidecar, and the plot.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..config.tables import IMAGE_KINDS
from ..errors import printable
from .common import (EXIT_INVALID, EXIT_OK, HelpFormatter, UsageError, add_suite_args, importable_cwd,
                     load_suite, model_path, positive_float, positive_int, require_matplotlib, seed, suite_model,
                     writable)
from .describe import SensorRow, describe, naive_samples
from .report import Progress, table

__all__ = ["add_parser", "Settings", "Recording", "execute", "add_run_args", "settings_from", "control_steps"]

TIME_KEY, ACTION_KEY = "sensorcfg.time", "sensorcfg.action"  # '.' is not allowed in sensor names
MAX_RECORDING_BYTES = 4 << 30

EXAMPLES = """examples:
  sensorcfg run configs/imu.yaml                         200 control steps, summary only
  sensorcfg run configs/vision.yaml --steps 500 --out obs.npz --plot obs.png
  sensorcfg run configs/sim2real.yaml --control-timestep 0.02 --random-actions --seed 3

The .npz holds one array per enabled observation, named as the sensor, with a leading axis of control
steps (the reset observation first, so N+1 entries), plus 'sensorcfg.time' (seconds, N+1) and
'sensorcfg.action' (N x actuators). A JSON sidecar (same name, .json) records the spec and the settings.
Load it with: data = numpy.load("obs.npz"); data["joint_pos"].shape

The summary counts, per sensor, the samples taken and those an every-interval schedule would take; the
difference was skipped because no observation could ever show it (for cameras: renders saved).
A run whose simulation diverges stops there, keeps what it recorded, and exits with status 1."""


@dataclasses.dataclass(frozen=True)
class Settings:
    steps: int = 200
    substeps: int | None = None
    control_timestep: float | None = None
    seed: int = 0
    random_actions: bool = False
    keyframe: int | str | None = None


@dataclasses.dataclass
class Recording:
    """Observations per control step (reset first), the actions, and what the run measured."""

    observations: dict[str, np.ndarray]
    time: np.ndarray
    action: np.ndarray
    steps_done: int = 0
    wall_seconds: float = 0.0
    samples_taken: dict[str, int] = dataclasses.field(default_factory=dict)
    diverged: str | None = None

    def truncate(self) -> None:
        n = self.steps_done + 1
        self.observations = {k: v[:n] for k, v in self.observations.items()}
        self.time, self.action = self.time[:n], self.action[:n - 1]


def add_run_args(p: argparse.ArgumentParser, steps: int, random_actions: bool = False) -> None:
    p.add_argument("--steps", type=positive_int, default=steps, metavar="N",
                   help=f"control steps to simulate (default: {steps})")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--substeps", type=positive_int, metavar="K",
                       help="physics steps per control step (default: the suite's options.control_interval, else 1)")
    group.add_argument("--control-timestep", type=positive_float, metavar="T",
                       help="seconds per control step, a whole number of physics steps")
    p.add_argument("--seed", type=seed, default=0, metavar="S",
                   help="seed of the episode and the actions, 0 to 2**32-1 (default 0)")
    p.add_argument("--keyframe", type=_keyframe, metavar="KEY",
                   help="start every episode from this model keyframe, a name or an index (default: the suite's "
                   "options.keyframe, else the model's reset state)")
    if random_actions:
        p.add_argument("--zero-actions", dest="random_actions", action="store_false",
                       help="zero controls (default: uniform random controls within each actuator's ctrlrange)")
    else:
        p.add_argument("--random-actions", action="store_true",
                       help="uniform random controls within each actuator's ctrlrange ([-1, 1] if unlimited); "
                       "default: zero controls")


def _keyframe(text: str) -> int | str:
    from ..selection import ascii_id

    index = ascii_id(text)  # (ASCII digits only: int() would read '١' as 1)
    return text if index is None else index


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("run", help="simulate a suite, record observations to .npz, summarise, plot",
                       description="Simulate the suite's model with zero (or random) controls, record every "
                       "observation at every control step, and print a summary.",
                       epilog=EXAMPLES + "\n\n" + epilog, formatter_class=HelpFormatter)
    add_suite_args(p)
    add_run_args(p, steps=200)
    p.add_argument("--out", metavar="FILE.npz", help="write the observations here (and the sidecar FILE.json)")
    p.add_argument("--plot", metavar="FILE.png", help="draw timing and signals per sensor (needs matplotlib)")
    p.set_defaults(handler=command)


# -- build -----------------------------------------------------------------------------------------------

class _Built:
    """The suite, with its observables already built (so the run can watch their draws): `build` returns
    them, everything else the Environment asks of a suite is the suite's own."""

    def __init__(self, suite: Any, observables: dict[str, Any]):
        self._suite, self._observables = suite, observables

    def build(self, model: Any = None, **kwargs: Any) -> dict[str, Any]:
        return self._observables

    def __getattr__(self, name: str) -> Any:
        return getattr(self._suite, name)


def control_steps(suite: Any, model: Any, settings: Settings) -> int:
    """Physics steps per control step: --substeps, --control-timestep, else the suite's control_interval."""
    from ..loop.control import steps_per_control_step
    from ..errors import ArgumentError

    if settings.substeps is None and settings.control_timestep is None:
        return int(suite.updater_kwargs(model)["physics_steps_per_control_step"])
    try:
        return steps_per_control_step(model, settings.substeps, settings.control_timestep)
    except ArgumentError as e:
        raise UsageError(f"--control-timestep: {e}") from None


def make_env(suite: Any, model_file: str, settings: Settings, *, record_timing: bool) -> tuple[Any, dict[str, Any]]:
    """The Environment and the suite's observables (drawn schedules wrapped in Recorders when asked)."""
    from ..env import Environment
    from ..errors import SuiteError
    from ..selection import keyframe_id
    from . import timing

    importable_cwd()
    model = suite_model(suite, model_file)
    substeps = control_steps(suite, model, settings)
    if settings.keyframe is not None:
        try:
            keyframe_id(model, settings.keyframe)
        except SuiteError as e:
            raise UsageError(f"--keyframe: {e.problems[0].message}") from None
    observables = suite.build(model)
    for note in suite.notes(model):  # costly default rendering: said before the run pays for it
        print(note.format("note"))
    if record_timing:
        timing.record_draws(observables)
    env = Environment(model, _Built(suite, observables), physics_steps_per_control_step=substeps, seed=settings.seed,
                      keyframe=settings.keyframe)
    timing.clear_draws(observables)
    return env, observables


# -- simulate --------------------------------------------------------------------------------------------

def _actions(env: Any, settings: Settings) -> Any:
    spec = env.action_spec()
    if not settings.random_actions:
        zero = np.zeros(spec.shape, spec.dtype)
        return lambda: zero
    rng = np.random.default_rng(settings.seed)
    lo = np.where(np.isfinite(spec.minimum), spec.minimum, -1.0)
    hi = np.where(np.isfinite(spec.maximum), spec.maximum, 1.0)
    return lambda: rng.uniform(lo, hi)


def simulate(env: Any, settings: Settings, *, keep: bool, label: str = "running") -> Recording:
    """Step the environment `settings.steps` control steps (fewer if it diverges); with `keep`, record each
    observation, the time and the action (the arrays are allocated once, before the first step)."""
    spec, nu = env.observation_spec(), env.action_spec().shape
    n = settings.steps
    rows = n + 1 if keep else 0
    size = sum(int(np.prod(s.shape)) * np.dtype(s.dtype).itemsize for s in spec.values()) * rows
    if size > MAX_RECORDING_BYTES:
        raise UsageError(f"recording {n} steps would take {size / 2**30:.1f} GiB; use fewer --steps or smaller "
                         "camera images (--set defaults.camera.width=64)")
    rec = Recording({k: np.zeros((rows,) + tuple(s.shape), s.dtype) for k, s in spec.items()},
                    np.zeros(rows), np.zeros((max(rows - 1, 0),) + nu))
    act = _actions(env, settings)
    progress = Progress(n, label)
    with warnings.catch_warnings():  # a divergence is reported once, by `execute`, not as a Python warning
        warnings.filterwarnings("ignore", message="sensorcfg: the simulation diverged", category=RuntimeWarning)
        ts = env.reset()
        if keep:
            _store(rec, 0, ts.observation, env)
        start = time.perf_counter()
        for i in range(1, n + 1):
            action = act()
            ts = env.step(action)
            if keep:
                rec.action[i - 1] = action
                _store(rec, i, ts.observation, env)
            rec.steps_done = i
            progress.update(i)
            if ts.last():
                rec.diverged = env.last_divergence or "the episode ended"
                break
        rec.wall_seconds = time.perf_counter() - start
    progress.close()
    rec.samples_taken = dict(env.updater.samples_taken())
    if keep:
        rec.truncate()
    return rec


def _store(rec: Recording, i: int, observation: dict[str, Any], env: Any) -> None:
    rec.time[i] = env.physics.data.time
    for name, value in observation.items():
        rec.observations[name][i] = value


# -- report ----------------------------------------------------------------------------------------------

def summary(rec: Recording, rows: list[SensorRow], substeps: int, timestep: float) -> str:
    physics_steps = rec.steps_done * substeps  # samples_taken counts to the last step taken
    wall = max(rec.wall_seconds, 1e-9)
    sim = physics_steps * timestep
    lines = [f"ran {rec.steps_done} control steps ({physics_steps} physics steps, {sim:.3g} s simulated) in "
             f"{rec.wall_seconds:.3g} s: {_per_second(rec.steps_done, wall)} control steps/s, "
             f"{_per_second(physics_steps, wall)} physics steps/s, {sim / wall:.3g}x real time", ""]
    if not rows:
        return "\n".join(lines + ["the suite has no enabled observations"])
    body, renders = [], [0, 0]
    for r in rows:
        taken = rec.samples_taken.get(r.name)
        naive = naive_samples(r, physics_steps)
        skipped = None if naive is None or taken is None else naive - taken
        body.append([r.name, r.kind, taken, naive if naive is not None else "drawn", skipped])
        if r.kind in ("rgb", "depth", "segmentation") and taken is not None:
            renders[0] += taken
            renders[1] += skipped or 0
    lines.append(table(["sensor", "kind", "samples taken", "every interval", "skipped"], body, right=(2, 3, 4)))
    lines.append("(every interval: what sampling at every interval would take; skipped: samples no read "
                 "could ever show, so not taken)")
    if any(r.kind in ("rgb", "depth", "segmentation") for r in rows):
        total = renders[0] + renders[1]
        share = f" ({100 * renders[1] / total:.0f}%)" if total else ""
        lines += ["", f"camera renders: {renders[0]} taken, {renders[1]} skipped by the schedule{share}"]
    return "\n".join(lines)


def save(rec: Recording, path: Path, sidecar: dict[str, Any]) -> Path:
    """Write the .npz (exactly at `path`) and its JSON sidecar; returns the sidecar's path."""
    side = path.with_suffix(".json")
    if side == path:
        side = path.with_name(path.name + ".json")
    arrays: dict[str, Any] = {**rec.observations, TIME_KEY: rec.time, ACTION_KEY: rec.action}
    try:
        with open(path, "wb") as f:
            np.savez_compressed(f, **arrays)
        side.write_text(json.dumps(sidecar, indent=2) + "\n", encoding="utf-8")
    except OSError as e:
        where, why = printable(str(e.filename or path)), printable(str(e.strerror or e))
        raise UsageError(f"{where}: cannot write: {why}") from None
    return side


def execute(suite: Any, model_file: str, settings: Settings, out: Path | None, plot: Path | None,
            overrides: list[str], *, label: str = "running", title: str | None = None) -> int:
    """Build, simulate, summarise, save and plot; what `run` and `demo` share."""
    env, observables = make_env(suite, model_file, settings, record_timing=plot is not None)
    n, dt = env.physics_steps_per_control_step, float(env.physics.model.opt.timestep)
    rows = describe(suite, observables, env.observation_spec(), env.physics.model)
    rec = simulate(env, settings, keep=out is not None or plot is not None, label=label)
    print(summary(rec, rows, n, dt))
    if out is not None:
        sidecar = {"sensorcfg": __version__, "suite": suite.file, "model": model_file, "overrides": overrides,
                   "settings": {"steps": settings.steps, "steps_done": rec.steps_done, "seed": settings.seed,
                                "random_actions": settings.random_actions, "keyframe": settings.keyframe,
                                "physics_timestep": dt,
                                "physics_steps_per_control_step": n, "control_timestep": n * dt},
                   "arrays": {TIME_KEY: "time in seconds at each control step, reset first",
                              ACTION_KEY: "controls applied at each control step"},
                   "observations": [r.as_dict() for r in rows], "samples_taken": rec.samples_taken,
                   "wall_seconds": rec.wall_seconds, "diverged": rec.diverged}
        side = save(rec, out, sidecar)
        count = len(rec.observations)
        print(f"\nwrote {printable(str(out))} ({count} observation{'s' if count != 1 else ''} x "
              f"{rec.steps_done + 1} steps) and {printable(str(side))}")
    if plot is not None and not rows:
        print(f"no plot: the suite has no enabled observations to draw ({printable(str(plot))} not written)")
    elif plot is not None:
        from . import timing
        from .plot import plot_run

        from .quantities import value_groups

        times = timing.timings(observables, rec.steps_done * n, n)
        groups = {r.name: value_groups(env.physics.model, suite.sensors[r.name], _width(r)) for r in rows
                  if r.kind not in IMAGE_KINDS}
        plot_run(plot, rec, rows, times, dt, title=title or printable(f"{suite.file} on {Path(model_file).name}"),
                 groups=groups)
        print(f"wrote {printable(str(plot))}")
    if rec.diverged:
        print(f"sensorcfg: error: the simulation diverged after {rec.steps_done} control steps ({rec.diverged}); "
              "the run stopped there, and what it recorded is kept", file=sys.stderr)
        return EXIT_INVALID
    return EXIT_OK


def _width(row: SensorRow) -> int:
    """Values in one sample of an observation (its newest, when it has a buffer axis)."""
    return int(np.prod(row.shape[1:] if row.buffer_axis else row.shape))


def _per_second(count: float, seconds: float) -> str:
    """A rate with three significant digits when small ('0.412'), whole numbers with separators when not."""
    rate = count / seconds
    return f"{rate:,.0f}" if rate >= 100 else f"{rate:.3g}"


def settings_from(args: argparse.Namespace) -> Settings:
    return Settings(args.steps, args.substeps, args.control_timestep, args.seed, args.random_actions, args.keyframe)


def command(args: argparse.Namespace) -> int:
    formats: tuple[str, ...] = ()
    if args.plot:
        require_matplotlib()
        from matplotlib.backend_bases import FigureCanvasBase

        # what matplotlib writes by itself (pgf needs LaTeX; avif a Pillow built with it)
        formats = ("png", *sorted(set(FigureCanvasBase.get_supported_filetypes()) - {"png", "pgf", "avif"}))
    out, plot = writable(args.out, ("npz",)), writable(args.plot, formats)
    suite = load_suite(args.suite, args.overrides, args.extends_root, args.model)
    return execute(suite, model_path(suite, args.model), settings_from(args), out, plot, args.overrides)
