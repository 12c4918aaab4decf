"""`Suite`: a loaded sensor suite, and `load` / `loads`, the entry points of the suite language.

Loading parses and validates without a model (this module imports no mujoco until a model is asked for);
`Suite.check(model)` lists every problem against a model without raising, and `Suite.build(model)` returns
the observables ready for `sensorcfg.Updater`.
"""

from __future__ import annotations

import os
import types
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from .config import LoadedSuite, OptionsConfig, SensorConfig, SuiteConfig, load_path, load_text, to_steps
from .config.limits import MAX_OBSERVATION_BYTES
from .config.overrides import override_texts
from .config.units import timestep_problem
from .errors import ArgumentError, Problem, SuiteError, quote

if TYPE_CHECKING:
    import mujoco

    from .native.table import Added
    from .observables import Observable

__all__ = ["Suite", "load", "loads"]

ModelLike = Any  # mujoco.MjModel, a path to an MJCF/MJB file, a Physics, or None for the suite's `model:`
Overrides = Sequence[str] | Mapping[str, Any] | None  # 'dotted.key=value' texts, or dotted keys -> values


class _Compiled(NamedTuple):
    """The model a suite binds to, as `Suite._compiled` made it."""

    model: mujoco.MjModel
    refused: dict[str, str]  # MuJoCo's message for each native sensor it left out, by sensor
    unmounted: list[Problem]  # the suite's cameras that could not be mounted as written (in the world's frame)


class Suite:
    """A validated sensor suite: its sensors (with `defaults` applied), Updater options and default model."""

    def __init__(self, loaded: LoadedSuite):
        """A suite from the config layer's result; `sensorcfg.load` and `sensorcfg.loads` make one from a file
        or text, and are how a suite is meant to be made.

        Args:
            loaded: The validated suite (`sensorcfg.config.LoadedSuite`: its config, effective sensors and
                the positions of its nodes, for messages at its lines).
        """
        self._loaded = loaded

    def __repr__(self) -> str:
        return f"Suite({self.file!r}, sensors={list(self.sensors)})"

    @property
    def file(self) -> str:
        """The file the suite was read from (as shown in messages), or '<string>'."""
        return self._loaded.file

    @property
    def config(self) -> SuiteConfig:
        """The suite as written, after `extends` and overrides (before `defaults` are applied)."""
        return self._loaded.config

    @property
    def options(self) -> OptionsConfig:
        """Updater settings: `pad_with_initial_value`, `strip_singleton_buffer_dim`, `control_interval`."""
        return self._loaded.config.options

    @property
    def model(self) -> str | None:
        """The default model's path (resolved from `model:`), or None."""
        return self._loaded.model

    @property
    def sensors(self) -> Mapping[str, SensorConfig]:
        """Each sensor's config with `defaults` filled in, in file order (read-only)."""
        return types.MappingProxyType(self._loaded.sensors)

    @property
    def groups(self) -> Mapping[str, tuple[str, ...]]:
        """Each observation group's members in column order (`groups:`, globs expanded; read-only)."""
        return types.MappingProxyType(self._loaded.groups)

    # -- against a model ------------------------------------------------------------------------

    def _mjmodel(self, model: ModelLike) -> mujoco.MjModel:
        compiled = self._compiled(model)
        if compiled.unmounted:
            raise SuiteError(compiled.unmounted)
        return compiled.model

    def _sources(self) -> dict[str, SensorConfig]:
        """The sensors that may add MuJoCo sensors: clean twins read their source's."""
        return {k: v for k, v in self._loaded.sensors.items() if k not in self._loaded.twins}

    def _compiled(self, model: ModelLike, batch: bool = False, extra: Sequence[Added] = ()) -> _Compiled:
        """The model to bind to, MuJoCo's message for each native sensor it refused, and the problems of the
        suite's cameras that could not be mounted as written (`native.cameras.mount`: mounted in the world's
        frame, so that the sensors reading them are still judged). A path (or the suite's `model:`, or an
        MjSpec) is compiled with the suite's native sensors (for a batch, also with sensors that make MuJoCo
        fill the on-demand fields the suite reads) and its `cameras`; an MjModel is taken as it is (it must
        carry them)."""
        import mujoco

        if isinstance(model, mujoco.MjModel):
            return _Compiled(self._carrying(model), {}, [])
        if isinstance(model, mujoco.MjSpec):
            from .native import compile_model

            spec, unmounted = self._mounted(model)
            return _Compiled(*compile_model(spec, self._sources(), batch, extra), unmounted)
        if model is not None and not isinstance(model, (str, os.PathLike)):
            from .physics import raw_structs

            try:
                return _Compiled(self._carrying(raw_structs(model)[0]), {}, [])
            except TypeError as e:
                raise ArgumentError(f"model: {e}; or pass an MjModel or a path") from None
        if model is None:
            if self.model is None:
                message = "no model to check against: pass one, or name it in the suite with 'model: path/to/robot.xml'"
                top = self._loaded.doc.pos(())
                raise SuiteError(top.problem(message, "model") if top else Problem(message, "model", self.file))
            path, pos = self.model, self._loaded.doc.pos(("model",))
        else:
            path, pos = os.fspath(model), None
        try:
            from .config.files import model_file
            from .native import compile_model

            if pos is None:
                path = model_file(path)  # a package:// or menagerie:// name, as --model and the environments take it
            from .physics import read_model

            if self._mounts():
                from .native.cameras import mount

                source, found = mount(path, self.config.cameras, self._rejected_cameras())
            elif self._adds_to_model(batch) or extra:
                return _Compiled(*compile_model(path, self._sources(), batch, extra), [])
            else:
                return _Compiled(read_model(path), {}, [])
        except (ValueError, OSError) as e:
            message = f"cannot load the model {quote(str(path), 160)}: {str(e).strip()}"
            raise SuiteError(pos.problem(message, "model") if pos else Problem(message, file=str(path))) from None
        return _Compiled(*compile_model(source, self._sources(), batch, extra), self._at_paths(found))

    def _rejected_cameras(self) -> list[str]:
        """The names of the suite's cameras whose definition the schema refused (a partial suite's): still
        cameras it defines, for the sensors that name them."""
        written = self._loaded.doc.value.get("cameras") if isinstance(self._loaded.doc.value, dict) else None
        return [k for k in written if isinstance(k, str) and k not in self.config.cameras] \
            if isinstance(written, dict) else []

    def _mounts(self) -> bool:
        """Whether the suite adds cameras to its model (some of them perhaps with mistakes)."""
        return bool(self.config.cameras or self._rejected_cameras())

    def _adds_to_model(self, batch: bool = False) -> bool:
        """Whether the suite's model differs from its file: MuJoCo sensors for its native kinds, its
        `cameras`, and for a batch the sensors that fill on-demand fields. A caller holding the file's
        MjModel then passes the path instead, for the suite to compile."""
        from .native import native_names, reads_on_demand

        sources = self._sources()
        return bool(native_names(sources) or self._mounts() or (batch and reads_on_demand(sources)))

    def _mounted(self, spec: mujoco.MjSpec) -> tuple[mujoco.MjSpec, list[Problem]]:
        """`spec` with the suite's cameras (a copy), or `spec` itself when the suite adds none; and the problems
        of those that could not be mounted as written."""
        if not self._mounts():
            return spec, []
        from .native.cameras import mount

        mounted, found = mount(spec, self.config.cameras, self._rejected_cameras())
        return mounted, self._at_paths(found)

    def _carrying(self, model: mujoco.MjModel) -> mujoco.MjModel:
        """`model`, which must already carry the suite's cameras."""
        if self.config.cameras:
            from .native.cameras import carried

            found = carried(model, self.config.cameras)
            if found:
                raise SuiteError(self._at_paths(found))
        return model

    def _at_paths(self, found: Sequence[tuple[tuple[str, ...], str]]) -> list[Problem]:
        """(path, message) pairs as problems at the path's line; a path of two keys (a mapping's entry) at
        its key."""
        problems = []
        for path, message in found:
            pos = self._loaded.doc.pos(path, key=len(path) == 2)
            loc = ".".join(path)
            problems.append(pos.problem(message, loc) if pos else Problem(message, loc, self.file))
        return problems

    def _bind(self, model: ModelLike, import_callables: bool, batch: bool = False, call_callables: bool = True,
              warp: bool = False, put_model: bool = False) -> tuple[dict[str, Observable], list[Problem]]:
        """The observables and every problem; with `put_model` (and `warp`), MuJoCo Warp's refusal of the
        model too (`_put_model_problems`: `WarpEnvironment` raises it as an UnsupportedError when it builds)."""
        from .binding import bind

        batch = batch or warp  # the Warp engine refuses what a batch refuses, and more
        mjmodel, refused, unmounted = self._compiled(model, batch)
        observables, problems = bind(self._loaded, mjmodel, import_callables=import_callables,
                                     call_callables=call_callables, batch=batch, refused=refused, warp=warp)
        problems[:0] = unmounted
        problems += self._memory_problems(observables, mjmodel)
        if warp:
            problems += self._warp_problems(observables, mjmodel)
        if warp and put_model:
            problems += self._put_model_problems(mjmodel)
        return observables, problems

    def _put_model_problems(self, model: mujoco.MjModel) -> list[Problem]:
        """What MuJoCo Warp itself refuses of the compiled model (its `put_model`), at the suite's `model:`
        line; nothing where MuJoCo Warp is not installed (then it is found when `WarpEnvironment` builds)."""
        try:
            from .warp.worlds import model_refusal
        except ImportError:
            return []
        message = model_refusal(model)
        if message is None:
            return []
        pos = self._loaded.doc.pos(("model",))
        return [pos.problem(message, "model") if pos else Problem(message, "model", self.file)]

    def _warp_problems(self, observables: Mapping[str, Observable], model: mujoco.MjModel) -> list[Problem]:
        """What `WarpEnvironment` does not run besides what a batch refuses (`warp.support.refusals`), at the
        lines that ask for it: of every enabled sensor that bound; a clean twin's only while its source does
        not run (else its source's problems say the same at the same lines)."""
        from .observables import Feature
        from .physics import Physics
        from .warp.support import refusals

        physics: Physics | None = None
        found: list[tuple[str, str | tuple[str | int, ...], str]] = []
        for name, observable in observables.items():
            source = observables.get(self._loaded.twins.get(name, ""))
            if not observable.enabled or (source is not None and source.enabled):
                continue
            field = None
            if isinstance(observable, Feature):  # the field its reader reads, as WarpEnvironment finds it
                physics = physics or Physics(model)
                field = observable.reader(physics).field
            found += [(name, key, message) for key, message in refusals(observable, field, model)]
        return list(dict.fromkeys(self._at_lines(found)))  # a `defaults` line's problem once, not per sensor

    def compile(self, model: ModelLike = None, *, batch: bool = False) -> mujoco.MjModel:
        """The model with the MuJoCo sensors (and sites) the suite's native kinds add: `model` is an MJCF
        path, an `MjSpec` (copied) or None for the suite's `model:`; an MjModel is returned as it is.
        With `batch` (what `BatchEnvironment` compiles), on-demand fields the suite reads (cfrc_ext, cacc,
        subtree_linvel, ...) get a sensor that makes every step fill them.

        The file is not edited. Raises SuiteError listing every problem of the suite against the model
        when MuJoCo refuses one of its sensors.
        """
        return self._compile(model, batch)

    def _compile(self, model: ModelLike, batch: bool, extra: Sequence[Added] = ()) -> mujoco.MjModel:
        """`compile`, with `extra` sensors added last (a batch's relays, `batch.relay`)."""
        return self._refusing(*self._compiled(model, batch, extra))

    def _add_to(self, spec: mujoco.MjSpec) -> mujoco.MjModel:
        """The suite's MuJoCo sensors and sites (a batch's: on-demand fields filled) added to `spec` itself, a
        scene that another library compiles (mjlab's); the model compiled. A suite that adds cameras cannot be
        added so (its cameras are mounted on a copy): SuiteError at `cameras`."""
        if self.config.cameras:
            message = ("a suite added to another library's scene cannot add cameras (`cameras:`): add them to the "
                       "scene itself, and name them in the sensors' `element`")
            pos = self._loaded.doc.pos(("cameras",))
            raise SuiteError(pos.problem(message, "cameras") if pos else Problem(message, "cameras", self.file))
        from .native import add_native

        return self._refusing(*add_native(spec, self._sources(), True))

    def _refusing(self, mjmodel: mujoco.MjModel, refused: Mapping[str, str],
                  unmounted: Sequence[Problem] = ()) -> mujoco.MjModel:
        """`mjmodel`, or SuiteError at each sensor MuJoCo refused (`refused`: its message, by sensor) and each
        camera that could not be mounted (`unmounted`)."""
        if refused:
            from .binding import bind

            raise SuiteError([*unmounted, *bind(self._loaded, mjmodel, import_callables=False, refused=refused)[1]])
        if unmounted:
            raise SuiteError(list(unmounted))
        return mjmodel

    def _memory_problems(self, observables: Mapping[str, Observable], model: mujoco.MjModel,
                         nsim: int = 1, batch: bool = False) -> list[Problem]:
        """What the sensors would hold, at the lines that set it, before anything is allocated: an
        observation of more than `MAX_OBSERVATION_BYTES` (a deep buffer of large images), at its buffer;
        a sensor that keeps more than `MAX_KEPT_BYTES` between its samples and its reads (`memory.py`: its
        ring or history by its schedule, over `nsim` simulations), at its delay or buffer."""
        import numpy as np

        from .memory import kept_problems

        found: list[tuple[str, str, str]] = []
        for name, observable in observables.items():
            spec = observable.array_spec
            if spec is None:
                continue
            sample = int(np.prod(spec.shape)) * np.dtype(spec.dtype).itemsize
            buffer = observable.buffer_size or 1
            if buffer * sample > MAX_OBSERVATION_BYTES:
                shape = "x".join(map(str, spec.shape))
                found.append((name, "buffer", f"{buffer} samples of {sample:,} bytes ({shape} {np.dtype(spec.dtype)}) "
                              f"make {buffer * sample / 2**30:.1f} GiB; an observation may hold at most "
                              f"{MAX_OBSERVATION_BYTES / 2**30:g} GiB: use a smaller buffer or image"))
        if found:
            return self._at_lines(found)
        return self._at_lines(kept_problems(observables, model, self._substeps(model), nsim, batch))

    def _substeps(self, model: mujoco.MjModel) -> int:
        """Physics steps per control step by the suite's options (1 when it gives none, or none that fits:
        that is a problem of its own)."""
        value = self.options.control_interval
        if value is None or timestep_problem(float(model.opt.timestep)):
            return 1
        try:
            return to_steps(value, float(model.opt.timestep), minimum=1)
        except ValueError:  # reported by binding at its line
            return 1

    def _at_lines(self, found: Sequence[tuple[str, str | tuple[str | int, ...], str]]) -> list[Problem]:
        """(sensor, key, message) as problems at the key's line (a key, or a path below the sensor such as
        ("noise", 0, "type"); the nearest written node above it when the suite does not write it); a clean
        twin's at its source's, which wrote it."""
        from .binding import twin_message

        problems = []
        for name, key, message in found:
            source = self._loaded.twins.get(name)
            if source is not None:
                name, message = source, twin_message(name, message)
            head, rest = (key, ()) if isinstance(key, str) else (str(key[0]), tuple(key[1:]))
            raw = self._loaded.doc.value["sensors"].get(name) or {}
            defaults = self._loaded.doc.value.get("defaults") or {}
            path = (("sensors", name, head) if head in raw or head not in defaults else ("defaults", head)) + rest
            path = next((path[:n] for n in range(len(path), 2, -1) if path[:n] in self._loaded.doc.values), path)
            pos = self._loaded.doc.pos(path) or self._loaded.doc.pos(("sensors", name))
            loc = ".".join(map(str, path))
            problems.append(pos.problem(message, loc) if pos else Problem(message, loc))
        return problems

    def build(self, model: ModelLike = None, *, import_callables: bool = True,
              batch: bool = False, warp: bool = False) -> dict[str, Observable]:
        """The observables of every sensor, in file order, with their `enabled` flags set.

        `model` is a `mujoco.MjModel`, a model path, an `MjSpec`, or None for the suite's own `model:`; a
        path or spec is compiled with the suite's MuJoCo sensor kinds, an MjModel must already carry them
        (`Suite.compile`), and the observables then run only on that model. `generic`
        callables are imported (pass `import_callables=False` to leave them unimported placeholders).
        With `batch`, what BatchEnvironment cannot run is a problem too; with `warp`, what WarpEnvironment cannot
        run (all a batch cannot, and more: `sensorcfg.warp.support`). Raises SuiteError listing every problem.
        """
        observables, problems = self._bind(model, import_callables, batch, warp=warp)
        if problems:
            raise SuiteError(problems)
        return observables

    def check(self, model: ModelLike = None, *, import_callables: bool = False, batch: bool = False,
              warp: bool = False) -> list[Problem]:
        """Every problem of the suite against `model` (empty when it builds); never raises for a mistake.

        `generic` and `custom` callables are not imported unless `import_callables` is true; imported, a `generic`
        callable whose noise or aggregator needs its value's shape is called once on a fresh state of the model,
        as `build` calls it, so what the shape decides is found here too (custom noise is never called); with
        `batch`, what BatchEnvironment cannot run is a problem too; with `warp`, what WarpEnvironment
        cannot run (all a batch cannot, and more: `sensorcfg.warp.support`; Warp need not be installed; where
        MuJoCo Warp is installed, also a model it refuses, at the `model:` line).
        `options` are checked too (the keyframe exists; a control interval is a whole number of the model's
        physics steps).
        """
        try:
            return self._bind(model, import_callables, batch, call_callables=import_callables, warp=warp,
                              put_model=True)[1]
        except SuiteError as e:
            return list(e.problems)

    def notes(self, model: ModelLike = None) -> list[Problem]:
        """Advice on a suite that builds, at its lines (`validate` and `spec` print it as notes): an image
        sensor that renders costly shadows or reflections of this model with MuJoCo's default flags
        (`checks.render_cost`). Never raises for a mistake (`check` reports those)."""
        from .config.tables import IMAGE_KINDS

        images = {name: cfg for name, cfg in self.sensors.items() if cfg.kind in IMAGE_KINDS and
                  cfg.kind != "segmentation" and cfg.enabled is not False and name not in self._loaded.twins}
        if not images:
            return []
        from .checks import render_cost

        try:
            mjmodel = self._mjmodel(model)
        except SuiteError:
            return []
        found = []
        for name, cfg in images.items():
            message = render_cost(mjmodel, cfg.camera.scene if cfg.camera is not None else {})
            if message is not None:
                written = [p for p in (("sensors", name, "camera", "scene"), ("sensors", name, "camera"))
                           if p in self._loaded.doc.keys]  # where the fix goes, else the sensor's name
                found.append((written[0] if written else ("sensors", name), message))
        return self._at_paths(found)

    def updater_kwargs(self, model: ModelLike = None) -> dict[str, Any]:
        """Keyword arguments for `sensorcfg.Updater` from `options` (time converted with the model)."""
        options = self.options
        steps = 1
        if options.control_interval is not None:
            timestep = float(self._mjmodel(model).opt.timestep)
            problem = timestep_problem(timestep)  # (said at the model's line, as binding says it)
            path, message = (("model",), problem) if problem else (("options", "control_interval"), "")
            try:
                steps = to_steps(options.control_interval, timestep, minimum=1)
            except ValueError as e:
                pos, loc = self._loaded.doc.pos(path), ".".join(path)
                message = message or str(e)
                raise SuiteError(pos.problem(message, loc) if pos else Problem(message, loc, self.file)) from None
        return {"physics_steps_per_control_step": steps,
                "strip_singleton_buffer_dim": options.strip_singleton_buffer_dim,
                "pad_with_initial_value": options.pad_with_initial_value}


def load(path: str | os.PathLike[str], overrides: Overrides = None, *,
         extends_root: str | os.PathLike[str] | None = None) -> Suite:
    """Read and validate the suite at `path` (no model needed).

    Args:
        path: The suite file.
        overrides: Applied after `extends`: `dotted.key=value` strings, each value parsed as YAML
            (`["sensors.wrist_cam.interval=10", "defaults.buffer=2"]`), or a mapping of dotted keys to Python
            values (`{"sensors.wrist_cam.interval": 10, "defaults.buffer": 2}`); their problems are reported
            in the override's text (`override 'defaults.buffer=0':1:17`).
        extends_root: The folder tree `extends` and `model:` may name files in ('/' allows any file).
            Default: the suite's folder.

    Returns:
        The validated `Suite`.

    Raises:
        SuiteError: Every problem of the files and overrides, each at its line.
        ArgumentError: `path` is not a path, `extends_root` cannot be resolved, or `overrides` is neither a
            list of strings nor a mapping of dotted keys to values YAML can hold.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ArgumentError(f"load takes a path to a suite file; got {type(path).__name__} (use loads for text)")
    return Suite(load_path(Path(path), _overrides(overrides), extends_root=extends_root))


def loads(text: str, overrides: Overrides = None, *, file: str = "<string>",
          base_dir: str | os.PathLike[str] | None = None,
          extends_root: str | os.PathLike[str] | None = None) -> Suite:
    """Like `load`, for YAML text.

    Args:
        text: The suite's YAML.
        overrides: As `load`'s.
        file: The name its problems give the text.
        base_dir: The folder `extends` and `model:` paths are relative to. Default: the working directory.
        extends_root: The folder tree `extends` and `model:` may name files in. Default: `base_dir`.

    Returns:
        The validated `Suite`.

    Raises:
        SuiteError: Every problem of the text and overrides, each at its line.
        ArgumentError: `text` is not a str, `base_dir` or `extends_root` cannot be resolved, or `overrides`
            is not one of `load`'s forms.
    """
    if not isinstance(text, str):
        raise ArgumentError(f"loads takes the suite's YAML text as a str; got {type(text).__name__} "
                            "(use sensorcfg.load for a path)")
    return Suite(load_text(text, _overrides(overrides), file=file, base_dir=base_dir, extends_root=extends_root))


def _overrides(overrides: Overrides) -> list[str] | None:
    return None if overrides is None else override_texts(overrides)
