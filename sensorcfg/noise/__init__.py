"""Noise pipelines: how a sensor lies. Numpy only.

A pipeline is built from a suite's stage configs (`sensorcfg.config.noise`) for one observation shape and
dtype; the Updater seeds it per sensor and per episode with `reset(rng)` and calls it on each raw sample as
`pipeline(value, step)` (`step` counts physics steps since reset, so time-based stages know the simulated
time between samples). `pipeline(value, step, out=row)` writes into a buffer row instead (in place when
`value is row`).
"""

from .pipeline import NoisePipeline, build_noise

__all__ = ["NoisePipeline", "build_noise"]
