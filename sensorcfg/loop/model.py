"""What an environment runs: its model (an MjModel, or one loaded from a path or a `package://` or
`menagerie://` name) and its suite (a `Suite`, a suite path or a dict of observables), compiled together into
the model, its observables and the Updater's settings (`model_and_observables`); one rule for every engine.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any, TypeAlias

import mujoco

from ..config.files import model_file
from ..errors import ArgumentError, Problem, SuiteError
from ..physics import read_model

__all__ = ["ModelArg", "load_model", "model_and_observables", "model_source"]


def load_model(model: mujoco.MjModel | str | os.PathLike[str]) -> mujoco.MjModel:
    """An MjModel, or one loaded from an MJCF (or MJB) path (or a `package://` or `menagerie://` name, as in
    a suite's `model:`) with a clear error."""
    if isinstance(model, mujoco.MjModel):
        return model
    path = _model_file(model)
    if not os.path.isfile(path):
        raise SuiteError(f"model file {path!r} does not exist")
    try:
        return read_model(path)
    except ValueError as e:
        raise SuiteError(f"{path}: MuJoCo could not load the model: {e}") from None


def _model_file(model: str | os.PathLike[str]) -> str:
    try:
        return model_file(model)
    except ValueError as e:
        raise SuiteError(f"model {os.fspath(model)!r}: {e}") from None


ModelArg: TypeAlias = "mujoco.MjModel | mujoco.MjSpec | str | os.PathLike[str] | None"


def model_source(model: ModelArg, suite: Any) -> tuple[mujoco.MjModel | mujoco.MjSpec | str, Any]:
    """What an environment runs on, and its suite (loaded when given as a path): `model` (a `package://` or
    `menagerie://` name resolved as a suite's `model:` is), or, when it is None, the suite's own `model:`."""
    if isinstance(suite, (str, os.PathLike)):
        from ..suite import load
        from ..config.overrides import with_model

        suite = load(suite, with_model(None, model))  # a model given: the suite's `model:` is not resolved
    if model is None:
        if isinstance(suite, Mapping):
            raise ArgumentError("model is None, and a dict of observables names no model: pass an MjModel, an "
                                "MjSpec or a model path")
        path = getattr(suite, "model", None)
        if path is None:
            raise SuiteError(Problem("the suite names no model: add 'model: path/to/robot.xml' to the suite, or "
                                     "pass the model (an MjModel, an MjSpec or a path) as the first argument",
                                     "model", getattr(suite, "file", None)))
        return path, suite
    if isinstance(model, (str, os.PathLike)):
        return _model_file(model), suite
    if not isinstance(model, (mujoco.MjModel, mujoco.MjSpec)):
        raise ArgumentError(f"model must be an MjModel, an MjSpec, a model path (package:// and menagerie:// names "
                            f"too) or None for the suite's 'model:'; got {type(model).__name__}")
    return model, suite


def model_and_observables(model: Any, suite: Any, batch: bool = False, extra: Sequence[Any] = (), nsim: int = 1,
                          warp: bool = False) -> tuple[mujoco.MjModel, dict[str, Any], dict[str, Any]]:
    """The model (a path or an MjSpec compiled with the suite's MuJoCo sensor kinds, then the `extra`
    sensors: a batch's relays), its observables and the Updater's keyword arguments, from a Suite, a suite
    path, or a dict of observables; the suite's `options.keyframe` and its observation `groups` (names in
    column order) too, under "keyframe" and "groups" (the environment pops them). With `batch`, what a
    BatchEnvironment cannot run is a problem too (with `warp`, what a WarpEnvironment cannot), and so is what
    the suite's sensors would keep in `nsim` simulations (`Suite._memory_problems`)."""
    if isinstance(suite, Mapping):
        if isinstance(model, (str, os.PathLike, mujoco.MjSpec)) and (extra or isinstance(model, mujoco.MjSpec)):
            from ..native import compile_model

            if not isinstance(model, mujoco.MjSpec):
                load_model(model)  # a missing or broken file: the same error as without extra sensors
            try:
                return compile_model(model, {}, False, extra)[0], dict(suite), {}
            except ValueError as e:
                raise SuiteError(f"MuJoCo could not compile the model: {str(e).strip()}") from None
        return load_model(model), dict(suite), {}
    if isinstance(suite, (str, os.PathLike)):
        from ..suite import load

        suite = load(suite)
    if isinstance(model, (str, os.PathLike, mujoco.MjSpec)):
        if not isinstance(model, mujoco.MjSpec):
            load_model(model)  # a missing or broken file: the same error as without a suite
        model = suite._compile(model, batch, extra)
    model = load_model(model)
    observables = suite.build(model, batch=True, warp=warp) if batch else suite.build(model)
    problems = suite._memory_problems(observables, model, nsim, batch) if nsim > 1 else []
    if problems:
        raise SuiteError(problems)
    return model, observables, {**suite.updater_kwargs(model), "keyframe": getattr(suite.options, "keyframe", None),
                                "groups": dict(getattr(suite, "groups", {}))}
