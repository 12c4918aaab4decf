"""`sensorcfg spec`: what a suite produces on a model: one row per enabled observation.

Build the suite's observables on the model, reset an Updater once to learn each observation's dm_env spec
(shape and dtype after buffering and aggregation), then print a table (or JSON).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from .common import (EXIT_OK, HelpFormatter, add_suite_args, importable_cwd, load_suite, model_path,
                     suite_model)
from .describe import SensorRow, describe
from .report import table

__all__ = ["add_parser", "Spec", "build_spec", "format_spec", "REPORTERS"]

EXAMPLES = """examples:
  sensorcfg spec configs/sim2real.yaml
  sensorcfg spec configs/imu.yaml --model my_robot.xml --format json
  sensorcfg spec configs/vision.yaml --set sensors.wrist_rgb.interval=50Hz

Columns: elements selected, shape and dtype of the observation (buffer axis first), sampling interval in
physics steps and Hz, delay in steps and ms, buffer length, aggregator, and the noise stages in order.
A drawn interval shows as lo..hi or {a,b} steps."""


class Spec:
    """The rows of an enabled suite on a model, with the timing context they are read in."""

    def __init__(self, suite: Any, model_file: str, model: Any, rows: list[SensorRow], disabled: list[str],
                 control_steps: int):
        self.suite, self.model_file, self.model, self.rows = suite, model_file, model, rows
        self.disabled, self.control_steps = disabled, control_steps
        self.timestep = float(model.opt.timestep)

    def as_dict(self) -> dict[str, Any]:
        return {"suite": self.suite.file, "model": self.model_file, "physics_timestep": self.timestep,
                "physics_steps_per_control_step": self.control_steps,
                "sensors": [r.as_dict() for r in self.rows], "disabled": self.disabled}


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("spec", help="table of every enabled observation: shape, dtype, rate, delay, noise",
                       description="Show what a suite produces on a model: every enabled observation with its "
                       "element count, shape, dtype, interval, delay, buffer, aggregator and noise.",
                       epilog=EXAMPLES + "\n\n" + epilog, formatter_class=HelpFormatter)
    add_suite_args(p)
    p.add_argument("--format", choices=sorted(REPORTERS), default="text", help="output format (default: text)")
    p.set_defaults(handler=command)


def build_spec(suite: Any, model_file: str, control_steps: int | None = None) -> Spec:
    """Build the suite on the model and read the specs (imports generic callables: their shapes are needed)."""
    import numpy as np

    from ..physics import Physics
    from ..runtime.updater import Updater

    importable_cwd()
    model = suite_model(suite, model_file)
    observables = suite.build(model)
    steps = control_steps or suite.updater_kwargs(model)["physics_steps_per_control_step"]
    updater = Updater(observables, steps, strip_singleton_buffer_dim=suite.options.strip_singleton_buffer_dim,
                      pad_with_initial_value=suite.options.pad_with_initial_value)
    updater.reset(Physics(model), np.random.RandomState(0))
    rows = describe(suite, observables, updater.observation_spec(), model)
    disabled = [name for name, o in observables.items() if not o.enabled]
    return Spec(suite, model_file, model, rows, disabled, steps)


def format_spec(spec: Spec) -> str:
    dt = spec.timestep
    n = spec.control_steps
    head = (f"{spec.suite.file} on {spec.model_file}\n"
            f"physics step {dt * 1e3:g} ms; control step {n} physics step{'s' if n != 1 else ''} "
            f"({n * dt * 1e3:g} ms, {1 / (n * dt):.4g} Hz)\n")
    header = ["name", "kind", "elems", "shape", "dtype", "interval", "Hz", "delay", "ms", "buffer", "aggregator",
              "noise"]
    rows = [[r.name, r.kind, r.elements, "(" + ", ".join(map(str, r.shape)) + ("," if len(r.shape) == 1 else "")
             + ")", r.dtype, r.interval, r.rate_hz, r.delay, r.delay_ms, r.buffer, r.aggregator, r.noise]
            for r in spec.rows]
    out = head + "\n" + table(header, rows, right=(2, 5, 6, 7, 8, 9))
    count = len(spec.rows)
    out += f"\n\n{count} enabled observation{'s' if count != 1 else ''}"
    if spec.disabled:
        out += f"; disabled: {', '.join(spec.disabled)}"
    return out


REPORTERS: dict[str, Callable[[Spec], str]] = {
    "text": format_spec, "json": lambda spec: json.dumps(spec.as_dict(), indent=2)}


def command(args: argparse.Namespace) -> int:
    suite = load_suite(args.suite, args.overrides)
    spec = build_spec(suite, model_path(suite, args.model))
    print(REPORTERS[args.format](spec))
    return EXIT_OK
