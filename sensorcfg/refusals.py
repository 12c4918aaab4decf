"""Why a BatchEnvironment refuses what it cannot run: the one wording of each rule, for the suite checks
(`checks.batch_problems`, at a suite's line) and for observables built in Python (`plan.bind`, `batch.noise`,
`observables.generic`). It imports nothing of sensorcfg, so every layer may use it.
"""

from __future__ import annotations

__all__ = ["batch_refusal", "per_simulation_refusal"]

_SINGLE = "remove it, or use the single-simulation Environment"


def per_simulation_refusal(camera: bool, what: str) -> str:
    """Why a BatchEnvironment refuses `what` (an aggregator, a drawn schedule, ...) on a camera or a height
    scan, which it samples per simulation: the one wording for suites and for Python observables."""
    does = "renders cameras" if camera else "casts height scans"
    return f"a BatchEnvironment {does} per simulation and cannot apply {what} to them; {_SINGLE}"


# Why a BatchEnvironment refuses a feature, by rule: the one wording `checks.batch_problems` puts at a suite's
# line and the batch raises for Python observables (`plan.bind`, `batch.noise`).
_BATCH_REFUSALS = {
    "generic": "a generic callable runs Python per sample and simulation, which a BatchEnvironment cannot "
               "vectorise; use the single-simulation Environment for it, or, on the Warp engine "
               "(WarpEnvironment), 'batched: true' with a callable that takes every world at once",
    "batched generic": "a batched generic callable takes MuJoCo Warp's Model and Data of every world and runs on "
                       "the Warp engine (WarpEnvironment) only; run this suite there, or drop 'batched' for a "
                       "callable of one simulation's physics",
    "constant": f"a BatchEnvironment reads mjData fields across simulations, not model constants; {_SINGLE}",
    "dtype": "{what} is {dtype}; a BatchEnvironment vectorises float64 features only; " + _SINGLE,
    "noise stage": "a {kind} noise stage{detail} runs Python once per sample and simulation, which a "
                   "BatchEnvironment cannot vectorise; express it with built-in stages, or use the "
                   "single-simulation Environment",
    "corruptor": "a corruptor runs a Python callable per sample and simulation, which a BatchEnvironment cannot "
                 "vectorise; use noise stages instead, or the single-simulation Environment",
}


def batch_refusal(rule: str, **details: str) -> str:
    """Why a BatchEnvironment refuses a feature by `rule` (a key of `_BATCH_REFUSALS`), with its details."""
    return _BATCH_REFUSALS[rule].format(**details)
