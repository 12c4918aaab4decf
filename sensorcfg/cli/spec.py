"""`sensorcfg spec`: what a suite produces on a model: one row per enabled observation.

Build the suite's observables on the model, reset an Updater once to learn each observation's dm_env spec
(shape and dtype after buffering and aggregation), then print a table (or JSON).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from ..errors import printable
from ..groups import layout
from .common import (EXIT_OK, HelpFormatter, add_suite_args, importable_cwd, load_suite, model_path,
                     suite_model)
from .describe import SensorRow, describe
from .report import table

__all__ = ["add_parser", "Spec", "build_spec", "format_spec", "REPORTERS"]

EXAMPLES = """examples:
  sensorcfg spec configs/sim2real.yaml
  sensorcfg spec configs/imu.yaml --model my_robot.xml --format json
  sensorcfg spec configs/vision.yaml --set sensors.wrist_rgb.interval=50Hz

Columns: elements selected, shape and dtype of the observation (buffer axis first), the bounds every value
keeps (min..max; '-' when unbounded; '- (noise)' when noise that can leave them dropped them; a clip stage
sets them; images keep theirs), sampling interval in physics steps and Hz, delay in steps and ms, buffer
length, aggregator, and the noise stages in order. A drawn interval shows as lo..hi or {a,b} steps. With a
drawn delay a read shows the sample that arrived last, which can be older than the largest delay."""

# under the table when some delay is drawn: its ms are the delays samples draw, not the ages reads show
# (measured: interval 1, delay {uniform: [1, 3]}, 100,000 reads; 2/81 exactly, docs/semantics.md)
DRAWN_DELAYS = ("drawn delays: a read shows the sample that arrived last (dm_control's rule), which can be older "
                "than the largest delay: with interval 1 and delay {uniform: [1, 3]}, 2.5% of reads are 4 steps old")


class Spec:
    """The rows of an enabled suite on a model, with the timing context they are read in."""

    def __init__(self, suite: Any, model_file: str, model: Any, rows: list[SensorRow], disabled: list[str],
                 control_steps: int):
        self.suite, self.model_file, self.model, self.rows = suite, model_file, model, rows
        self.disabled, self.control_steps = disabled, control_steps
        self.timestep = float(model.opt.timestep)
        self.notes = suite.notes(model)  # advice at the suite's lines (costly default rendering)
        self.groups = layout(suite.groups, {r.name: tuple(r.shape) for r in rows})

    def as_dict(self) -> dict[str, Any]:
        return {"suite": printable(self.suite.file), "model": printable(self.model_file),
                "physics_timestep": self.timestep,
                "physics_steps_per_control_step": self.control_steps,
                "sensors": [r.as_dict() for r in self.rows], "disabled": self.disabled,
                "groups": {name: {"width": g.width, "columns": g.describe()} for name, g in self.groups.items()},
                "notes": [{"severity": "note", **p.as_dict()} for p in self.notes]}


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("spec", help="table of every enabled observation: shape, dtype, rate, delay, noise",
                       description="Show what a suite produces on a model: every enabled observation with its "
                       "element count, shape, dtype, interval, delay, buffer, aggregator and noise.",
                       epilog=EXAMPLES + "\n\n" + epilog, formatter_class=HelpFormatter)
    add_suite_args(p)
    p.add_argument("--format", choices=sorted(REPORTERS), default="text", help="output format (default: text)")
    p.set_defaults(handler=command)


def build_spec(suite: Any, model_file: str, control_steps: int | None = None) -> Spec:
    """Build the suite on the model and read the specs without taking a sample: no camera renders and no
    noise stage runs (custom noise is never called); a generic callable is called once, on a fresh state,
    because its shape is known only from a value."""
    model = suite_model(suite, model_file)
    importable_cwd()
    observables = suite.build(model)
    steps = control_steps or suite.updater_kwargs(model)["physics_steps_per_control_step"]
    spec = observation_spec(observables, model, strip=suite.options.strip_singleton_buffer_dim,
                            pad=suite.options.pad_with_initial_value)
    rows = describe(suite, observables, spec, model)
    disabled = [name for name, o in observables.items() if not o.enabled]
    return Spec(suite, model_file, model, rows, disabled, steps)


def observation_spec(observables: dict[str, Any], model: Any, *, strip: bool, pad: bool) -> dict[str, Any]:
    """The engines' dm_env specs (their one rule, `plan.spec.observation_spec`), from each observable's spec instead
    of a sample."""
    import mujoco
    import numpy as np

    from ..physics import Physics
    from ..plan.bound import buffered_shape
    from ..plan.spec import observation_spec as one_spec

    physics = Physics(model)
    mujoco.mj_forward(model, physics.data)
    out = {}
    for name, obs in observables.items():
        if not obs.enabled:
            continue
        sample_spec = obs.array_spec
        if sample_spec is None:  # a feature binds first; a generic callable is called once, as the Updater does
            sampler = obs.observation_callable(physics, np.random.RandomState(0))
            sample_spec = obs.array_spec
            if sample_spec is None:
                probe = np.asarray(sampler())
                sample_spec = type("Probe", (), {"shape": probe.shape, "dtype": probe.dtype})
        shape = buffered_shape(tuple(sample_spec.shape), obs.buffer_size or 1, strip)
        out[name] = one_spec(name, obs, shape, np.dtype(sample_spec.dtype), pad)
    return out


def format_spec(spec: Spec) -> str:
    dt = spec.timestep
    n = spec.control_steps
    keyframe = getattr(spec.suite.options, "keyframe", None)
    head = (f"{printable(spec.suite.file)} on {printable(spec.model_file)}\n"
            f"physics step {dt * 1e3:g} ms; control step {n} physics step{'s' if n != 1 else ''} "
            f"({n * dt * 1e3:g} ms, {1 / (n * dt):.4g} Hz)"
            + (f"; episodes start from keyframe {printable(repr(keyframe))}" if keyframe is not None else "") + "\n")
    header = ["name", "kind", "elems", "shape", "dtype", "bounds", "interval", "Hz", "delay", "ms", "buffer",
              "aggregator", "noise"]
    rows = [[r.name, r.kind, r.elements, "(" + ", ".join(map(str, r.shape)) + ("," if len(r.shape) == 1 else "")
             + ")", r.dtype, r.bounds, r.interval, r.rate_hz, r.delay, r.delay_ms, r.buffer, r.aggregator, r.noise]
            for r in spec.rows]
    out = head + "\n" + table(header, rows, right=(2, 6, 7, 8, 9, 10))
    count = len(spec.rows)
    out += f"\n\n{count} enabled observation{'s' if count != 1 else ''}"
    if spec.disabled:
        out += f"; disabled: {', '.join(spec.disabled)}"
    if any(r.delay_steps is None for r in spec.rows):
        out += "\n" + DRAWN_DELAYS
    for name, group in spec.groups.items():
        out += f"\ngroup {printable(name)} ({group.width} values): " + ", ".join(
            f"{c.name} [{c.start}:{c.stop}]" for c in group.columns)
    unnamed = _unnamed(spec)
    if unnamed:
        out += "\nunnamed elements, labelled by id: " + "; ".join(
            f"{label} ({', '.join(names)})" for label, names in unnamed.items())
    return out + "".join("\n" + p.format("note") for p in spec.notes)


def _unnamed(spec: Spec) -> dict[str, list[str]]:
    """The unnamed elements the enabled sensors select, as `type:#id`, with the sensors selecting each."""
    from ..selection import ID_PREFIX, select

    out: dict[str, list[str]] = {}
    enabled = {r.name for r in spec.rows}
    for name, cfg in spec.suite.sensors.items():
        if name not in enabled or cfg.element is None or cfg.kind == "generic":
            continue
        sel = select(spec.model, cfg.element, cfg.within, kind=cfg.kind)
        for label in sel.names:
            if label.startswith(ID_PREFIX):
                out.setdefault(f"{sel.type}:{label}", []).append(name)
    return out


REPORTERS: dict[str, Callable[[Spec], str]] = {
    "text": format_spec, "json": lambda spec: json.dumps(spec.as_dict(), indent=2)}


def command(args: argparse.Namespace) -> int:
    suite = load_suite(args.suite, args.overrides, args.extends_root, args.model)
    spec = build_spec(suite, model_path(suite, args.model))
    print(REPORTERS[args.format](spec))
    return EXIT_OK
