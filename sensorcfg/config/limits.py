"""How large a suite may be: every bound on input in one table, so reading any file ends quickly.

A suite is a few kilobytes written by hand; these limits are far above any real one and far below what
would make `validate` (a pre-commit hook, run in CI on files from pull requests) hang or exhaust memory.
Each is reported as the problem it is, at the line that passes it, and checked before the work it bounds:
the bytes and values of a suite count over its whole `extends` chain (a parent is read only within what its
children left), the sensors of the merged suite before any is validated. docs/cli.md lists them.
"""

from __future__ import annotations

__all__ = ["MAX_SUITE_BYTES", "MAX_DEPTH", "MAX_NODES", "MAX_INT_DIGITS", "MAX_SENSORS", "MAX_BUFFER",
           "MAX_OBSERVATION_BYTES", "MAX_KEPT_BYTES", "MAX_SCHEDULE_STEPS", "MAX_EXTENDS", "MAX_OVERRIDE_BYTES",
           "MAX_RAYS"]

MAX_SUITE_BYTES = 1 << 20  # a suite's text: its file and every file of its `extends` chain together (1 MiB)
MAX_OVERRIDE_BYTES = 64 << 10  # one --set KEY=VALUE
MAX_DEPTH = 64  # nested mappings and lists (a suite needs about 6)
MAX_NODES = 100_000  # values in a suite's files together (its `extends` chain), aliases expanded
MAX_INT_DIGITS = 30  # digits of an integer (int64 has 19)
MAX_SENSORS = 1_000  # sensors in one suite, merged (counted before any is validated)
MAX_BUFFER = 10_000  # samples a sensor's buffer keeps
MAX_OBSERVATION_BYTES = 1 << 30  # one observation: buffer x one sample (a camera's frames), 1 GiB
MAX_KEPT_BYTES = 1 << 30  # what one sensor keeps between its samples and its reads, all simulations (memory.py)
MAX_SCHEDULE_STEPS = 1_000_000  # physics steps of an interval, a delay or a control step
MAX_EXTENDS = 32  # files in one chain of `extends`
MAX_RAYS = 100_000  # rays of one height scan (a 1.6 x 1.0 m grid at 1 cm has 16,261)
