"""`sensorcfg demo`: the bundled demo suite on the bundled robot, end to end, into the current folder.

It shows what sensorcfg is for in one command: the spec table, a run with a summary, the recorded
observations (`sensorcfg-demo.npz` + `.json`) and the plot (`sensorcfg-demo.png`). Without matplotlib it
does everything but the plot and says how to get it.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..errors import install_hint, printable
from .common import (EXIT_OK, HelpFormatter, UsageError, add_suite_args, load_model, load_suite, model_path,
                     require_matplotlib, writable)
from .run import add_run_args, control_steps, execute, settings_from
from .spec import build_spec, format_spec

__all__ = ["add_parser"]

DEMO_SUITE = "demo.yaml"
PREFIX = "sensorcfg-demo"

EXAMPLES = """examples:
  sensorcfg demo                              spec, run and plot into the current folder
  sensorcfg demo --steps 500 --zero-actions
  sensorcfg demo --prefix arm my_suite.yaml

The robot is driven by uniform random controls (seeded: --seed) so the signals move; --zero-actions
lets it settle instead. Writes PREFIX.npz, PREFIX.json and PREFIX.png (PREFIX defaults to
'sensorcfg-demo'). The plot needs matplotlib (pip install matplotlib, or from a clone pip install '.[plot]');
without it the demo skips the plot and says so."""


def add_parser(sub: Any, epilog: str) -> None:
    p = sub.add_parser("demo", help="run the bundled demo suite end to end: spec, run, plot (into this folder)",
                       description="Run the bundled demo suite on the bundled robot: print its spec, simulate "
                       "it, and write the observations and a plot into the current folder.",
                       epilog=EXAMPLES + "\n\n" + epilog, formatter_class=HelpFormatter)
    add_suite_args(p, suite_optional=True)
    add_run_args(p, steps=300, random_actions=True)
    p.add_argument("--prefix", default=PREFIX, help=f"output file prefix (default: {PREFIX})")
    p.add_argument("--no-plot", action="store_true", help="skip the plot")
    p.set_defaults(handler=command)


def command(args: argparse.Namespace) -> int:
    from .. import assets

    suite_file = args.suite or str(assets.path(DEMO_SUITE))
    if args.suite is None and not Path(suite_file).is_file():
        raise UsageError(f"the bundled demo suite is missing ({suite_file}); reinstall sensorcfg")
    out = writable(f"{args.prefix}.npz")
    plot = None if args.no_plot else writable(f"{args.prefix}.png")
    if plot is not None:
        try:
            require_matplotlib()
        except UsageError:
            print(f"note: matplotlib is not installed, so there will be no plot; {install_hint('plot', 'matplotlib')} "
                  "to get one\n")
            plot = None
    suite = load_suite(suite_file, args.overrides, args.extends_root, args.model)
    model_file = model_path(suite, args.model)
    settings = settings_from(args)
    spec = build_spec(suite, model_file, control_steps=control_steps(suite, load_model(model_file), settings))
    if args.suite is None:
        actions = "random" if settings.random_actions else "zero"
        print(f"sensorcfg demo: the bundled sensor suite on the bundled robot, {settings.steps} control steps of "
              f"{actions} controls\n")
    spec.notes = []  # said once, by the run, before it pays for what they are about
    print(format_spec(spec), end="\n\n")
    title = "sensorcfg demo (bundled suite and robot)" if args.suite is None else None
    status = execute(suite, model_file, settings, out, plot, args.overrides, label="demo", title=title)
    if status == EXIT_OK:
        print(f"\nnext: open {plot or out}; the suite it ran is {printable(suite.file)}")  # as the spec names it
    return status
