"""Binding a validated suite to an `MjModel`: names, kinds, time in steps, shapes; then observables.

Everything the config layer could not know without the model is checked here: that elements exist
(with "did you mean" from the model's names), that their type has the `kind` asked for (listing the
kinds it has), that durations are whole numbers of the model's timestep, that an index fits the value,
and that noise stages fit the observation's shape and dtype. Every problem is collected and positioned
at the YAML node it is about; `generic` callables are imported only when asked.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import sys
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, Literal, cast

import mujoco
import numpy as np

from .config.loader import LoadedSuite
from .config.models import ChoiceDraw, SensorConfig, UniformDraw
from .config.noise import GaussianStage
from .config.source import Path_
from .config.tables import GENERIC_KIND, HEIGHTSCAN_KIND, IMAGE_KINDS
from .config.units import timestep_problem, to_steps
from .draws import ChoiceSteps, UniformSteps
from .checks import batch_problems, constant_problem, kind_problems, sensor_problems
from .refusals import batch_refusal
from .errors import Problem, SuiteError, did_you_mean
from .kinds import kinds_of, read_type
from .native import NATIVE, bind_native, native_row
from .noise import build_noise
from .observables import Camera, Feature, Generic, Observable
from .observables.generic import BatchedGeneric
from .observables.camera import MAX_SIDE, MODES, SCENE_FLAGS, default_size
from .observables.feature import feature_index
from .physics import Physics
from .selection import keyframe_id, resolve, select, split_selector, within_problems

__all__ = ["bind", "scene_flags", "twin_message"]


def twin_message(twin: str, message: str) -> str:
    """A problem of clean twin `twin`, said at its source's line (which wrote it): the twin runs on its own."""
    return f"its clean twin {twin!r} runs (enabled; 'twin: false' drops it): {message}"


Schedule = int | Callable[..., int] | None


def scene_flags() -> tuple[str, ...]:
    """The names `camera.scene` accepts: render flags (mjtRndFlag) and visualisation flags (mjtVisFlag), lower
    case without prefix."""
    return tuple(SCENE_FLAGS)


@dataclasses.dataclass
class _Binder:
    suite: LoadedSuite
    model: mujoco.MjModel
    import_callables: bool
    call_callables: bool = True  # a generic sensor with noise or an aggregator is called once for its shape
    batch: bool = False  # also check what BatchEnvironment needs
    warp: bool = False  # for the Warp engine: batched generic callables run (elsewhere they are refused)
    refused: Mapping[str, str] = dataclasses.field(default_factory=dict)  # the problem of each native sensor left out
    problems: list[Problem] = dataclasses.field(default_factory=list)
    seen: set[Problem] = dataclasses.field(default_factory=set)  # `problems` as a set: each reported once
    twin: tuple[str, str] | None = None  # (twin, source) while binding a clean twin: reported at its source's lines

    # -- where a key came from, and problems there --------------------------------------------

    def origin(self, name: str, key: str) -> Path_:
        """`sensors.<name>.<key>` when the sensor wrote it, else `defaults.<key>` (so a bad default is
        reported once, at its own line)."""
        raw = self.suite.doc.value["sensors"].get(self.suite.twins.get(name, name)) or {}
        if key in raw or key not in (self.suite.doc.value.get("defaults") or {}):
            return ("sensors", name, key)
        return ("defaults", key)

    def report(self, path: Path_, message: str, *, key: bool = False) -> None:
        problem = self.problem(path, message, self.twin, key=key)
        if problem not in self.seen:
            self.seen.add(problem)
            self.problems.append(problem)

    def problem(self, path: Path_, message: str, twin: tuple[str, str] | None, *, key: bool = False) -> Problem:
        """`message` at `path`'s line; of clean twin `twin` (twin, source), at its source's."""
        if twin is not None:
            # a twin is bound only after its source bound cleanly: what fails is the twin's own (it runs
            # while its source is disabled), said at the source's line, which wrote it
            path = ("sensors", twin[1]) + path[2:] if path[:2] == ("sensors", twin[0]) else path
            message = twin_message(twin[0], message)
        pos = self.suite.doc.pos(path, key=key)
        loc = ".".join(map(str, path))
        return pos.problem(message, loc) if pos else Problem(message, loc, self.suite.file)

    def locator(self, name: str) -> Callable[[tuple[str | int, ...], str], Problem]:
        """The problem at a key below sensor `name` (its own, or `defaults`'), for problems found after
        binding (a batched generic's noise, once the Warp engine knows its value's shape)."""
        twin = self.twin
        return lambda key, message: self.problem(self.origin(name, str(key[0])) + tuple(key[1:]), message, twin)

    def report_all(self, path: Path_, error: SuiteError) -> None:
        for p in error.problems:
            self.report(path, p.message)

    # -- time -----------------------------------------------------------------------------------

    def steps(self, value: int | str, path: Path_, minimum: int) -> int | None:
        try:
            return to_steps(value, float(self.model.opt.timestep), minimum=minimum)
        except ValueError as e:
            self.report(path, str(e))
            return None

    def schedule(self, name: str, key: str, value: Any, minimum: int) -> Schedule:
        if value is None:
            return None
        path = self.origin(name, key)
        if isinstance(value, UniformDraw):
            low = self.steps(value.low, path + ("uniform", 0), minimum)
            high = self.steps(value.high, path + ("uniform", 1), minimum)
            if low is None or high is None:
                return None
            if low > high:
                self.report(path, f"uniform bounds must satisfy lo <= hi; they are {low} and {high} steps: swap them")
                return None
            return low if low == high else UniformSteps(low, high)
        if isinstance(value, ChoiceDraw):
            values = [self.steps(v, path + ("choice", i), minimum) for i, v in enumerate(value.values)]
            if any(v is None for v in values):
                return None
            return ChoiceSteps(tuple(v for v in values if v is not None), value.p)
        return self.steps(value, path, minimum)

    # -- options ---------------------------------------------------------------------------------

    def options(self) -> None:
        """`options` against the model: the keyframe exists, the control interval is whole physics steps."""
        options = self.suite.config.options
        if options.keyframe is not None:
            try:
                keyframe_id(self.model, options.keyframe)
            except SuiteError as e:
                self.report_all(("options", "keyframe"), e)
        if options.control_interval is not None:
            self.steps(options.control_interval, ("options", "control_interval"), 1)

    # -- one sensor -----------------------------------------------------------------------------

    def bind(self, name: str, cfg: SensorConfig) -> Observable | None:
        before = len(self.problems)
        timing = dict(update_interval=self.schedule(name, "interval", cfg.interval, 1),
                      delay=self.schedule(name, "delay", cfg.delay, 0),
                      buffer_size=cfg.buffer, aggregator=cfg.aggregator)
        builders = {GENERIC_KIND: self.generic, HEIGHTSCAN_KIND: self.heightscan,
                    **dict.fromkeys(IMAGE_KINDS, self.camera)}
        if cfg.kind in builders and cfg.constant is not None:
            self.report(("sensors", name, "constant"), constant_problem(f"a sensor of kind {cfg.kind!r}"))
        made = builders.get(cfg.kind, self.feature)(name, cfg, timing)
        shape, dtype = (made[1], made[2]) if made is not None else (None, None)
        found = sensor_problems(cfg, shape, self.suite.config.options.strip_singleton_buffer_dim)
        if self.batch and cfg.enabled is not False:  # (a camera's or callable's need no binding)
            found += batch_problems(cfg, dtype, self.field(cfg) if made is not None else None, self.model)
        for key, message in found:
            self.report(self.origin(name, str(key[0])) + key[1:], message)
        if made is None or len(self.problems) > before:
            return None
        observable = made[0]
        observable.enabled = cfg.enabled is not False
        if cfg.noise and shape is not None:
            stages = self.at_rate(name, cfg, observable.update_interval)
            if stages is None:
                return None
            stages = stages if self.import_callables else tuple(s for s in stages if s.type != "custom")
            try:
                observable.noise = build_noise(stages, shape, dtype, float(self.model.opt.timestep))
            except SuiteError as e:
                base = self.origin(name, "noise")
                for p in e.problems:
                    rest = tuple(int(s) if s.isdigit() else s for s in p.loc.split(".")[1:] if s)
                    self.report(base + rest, p.message)
                return None
        return observable

    def folder(self, name: str) -> str | None:
        """The folder of the file that defines sensor `name` (`generic` and `custom` callables import from
        there first), or None for a suite given as text."""
        pos = self.suite.doc.pos(("sensors", name))
        file = pos.file if pos else self.suite.file
        return str(Path(file).resolve().parent) if file and Path(file).is_file() else None

    def field(self, cfg: SensorConfig) -> str | None:
        """The mjData / mjModel field a bound feature reads (None for cameras and callables)."""
        if cfg.kind in IMAGE_KINDS or cfg.kind == GENERIC_KIND or cfg.element is None:
            return None
        first = cfg.element if isinstance(cfg.element, str) else cfg.element[0]
        # None: a MuJoCo sensor or a height scan
        spec = kinds_of(read_type(split_selector(first)[0], cfg.kind)).get(cfg.kind)
        return spec.field if spec is not None else None

    def within(self, name: str, cfg: SensorConfig) -> bool:
        """Whether every body `within` names exists; problems point at the list entry at fault."""
        problems = within_problems(self.model, cfg.within)
        self.report_at(name, problems)
        return not problems

    def at_rate(self, name: str, cfg: SensorConfig, interval: Schedule) -> tuple[Any, ...] | None:
        """The noise stages with a `density` turned into a std per sample at the sensor's nominal rate."""
        stages = tuple(cfg.noise or ())
        dense = [i for i, s in enumerate(stages) if getattr(s, "density", None) is not None]
        if not dense:
            return stages
        if not isinstance(interval, int) and interval is not None:
            for i in dense:
                self.report(self.origin(name, "noise") + (i, "density"), "a noise density needs a fixed interval "
                            "(the std per sample follows the sample rate); give std instead, or a fixed interval")
            return None
        rate = 1.0 / ((interval or 1) * float(self.model.opt.timestep))
        return tuple(s.at_rate(rate) if isinstance(s, GaussianStage) else s for s in stages)

    def selection(self, name: str, cfg: SensorConfig) -> bool:
        """Whether `element` (and `within`) resolve; problems point at the list entry at fault."""
        resolved = resolve(self.model, cast("str | tuple[str, ...]", cfg.element), cfg.within, kind=cfg.kind)
        self.report_at(name, resolved.problems)
        return resolved.selection is not None

    def report_at(self, name: str, problems: list[tuple[tuple[str | int, ...], Problem]]) -> None:
        """Report selection problems at their keys (and list entries) below sensor `name`."""
        for where, problem in problems:
            self.report(("sensors", name) + where, problem.message)

    def element_type(self, name: str, cfg: SensorConfig) -> str | None:
        if cfg.element is None:  # the loader reports a missing (or rejected) element, once
            return None
        first = cfg.element if isinstance(cfg.element, str) else (cfg.element or ("",))[0]
        path = ("sensors", name, "element") + (() if isinstance(cfg.element, str) else (0,))
        try:
            return split_selector(first)[0]
        except SuiteError as e:
            self.report_all(path, e)
            return None

    def feature(self, name: str, cfg: SensorConfig, timing: dict[str, Any]) -> tuple[Observable, Any, Any] | None:
        type_name = self.element_type(name, cfg)
        if type_name is None:
            self.within(name, cfg)  # (still a mistake of its own)
            return None
        type_name = read_type(type_name, cfg.kind)  # actuators on a joint attribute: the joints they drive
        if native_row(cfg.kind, type_name) is not None:
            if cfg.constant:
                self.report(("sensors", name, "constant"), constant_problem(
                    f"a sensor of kind {cfg.kind!r} (MuJoCo's {cfg.kind} sensor, read from the simulation)"))
            source = self.suite.twins.get(name, name)  # a twin reads its source's MuJoCo sensors
            return bind_native(self.model, source, cfg, timing, self.report, self.refused, _index(cfg.index))
        kinds = kinds_of(type_name)
        for key in ("frame", "with_", "data", "reduce", "num", "cutoff"):
            if getattr(cfg, key) is not None and cfg.kind in kinds:
                article = "an" if type_name[0] in "aeiou" else "a"
                self.report(("sensors", name, key.rstrip("_")), f"{key.rstrip('_')!r} is an option of MuJoCo's "
                            f"{cfg.kind} sensor, but on {article} {type_name} {cfg.kind!r} is its attribute "
                            f"{kinds[cfg.kind].field} (the element type decides): remove it", key=True)
                return None
        kind_ok = self.kind(name, cfg, type_name)
        if not self.selection(name, cfg) or not kind_ok:
            return None
        index = _index(cfg.index)
        selectors = cast("str | tuple[str, ...]", cfg.element)
        try:
            _, _, flat, dtype = feature_index(self.model, cfg.kind, selectors, cfg.within, index)
        except SuiteError as e:
            self.report_all(("sensors", name, self._culprit(cfg.kind, selectors, cfg.within, index)), e)
            return None
        element = cfg.element if isinstance(cfg.element, str) else list(cast("tuple[str, ...]", cfg.element))
        feature = Feature(cfg.kind, element, index=index, within=cfg.within, **timing)
        return feature, flat.shape, dtype

    def kind(self, name: str, cfg: SensorConfig, type_name: str) -> bool:
        """Whether `kind` is one the element type offers, and state unless the sensor asks for a constant."""
        native = [k for k, row in NATIVE.items() if type_name in row.objects]
        found = kind_problems(type_name, cfg.kind, bool(cfg.constant), native)
        for key, message in found:
            self.report(self.origin(name, "constant") if key == ("constant",) else ("sensors", name, "kind"), message)
        return not found

    def _culprit(self, kind: str, selectors: str | tuple[str, ...], within: str | tuple[str, ...] | None,
                 index: Any) -> str:
        """Which key a failed feature read is reported on: `index`, unless the elements fail without it."""
        if index is None:
            return "element"
        try:
            feature_index(self.model, kind, selectors, within)
        except SuiteError:
            return "element"
        return "index"

    def camera(self, name: str, cfg: SensorConfig, timing: dict[str, Any]) -> tuple[Observable, Any, Any] | None:
        here = ("sensors", name)
        before = len(self.problems)
        type_name = self.element_type(name, cfg)
        if type_name is None:
            return None
        if type_name != "camera" or not isinstance(cfg.element, str) or set("*?[") & set(cfg.element):
            self.report(here + ("element",), f"a sensor of kind {cfg.kind!r} reads one camera, 'camera:<name>'; "
                        f"got {cfg.element!r}")
            return None
        if not self.selection(name, cfg):
            return None
        assert cfg.camera is not None  # filled in by the loader for image kinds
        own = default_size(self.model, select(self.model, cfg.element).ids[0])  # its MJCF resolution, or 320x240
        width, height = cfg.camera.width or own[0], cfg.camera.height or own[1]
        vis = self.model.vis.global_
        for key, size, limit, attr in (("width", width, vis.offwidth, "offwidth"),
                                       ("height", height, vis.offheight, "offheight")):
            given = getattr(cfg.camera, key) is not None
            where = self.origin(name, "camera") + (key,) if given else ("sensors", name, "element")
            what = f"a {key} of {size}" if given else f"the camera's resolution {key} of {size}"
            if size > MAX_SIDE:
                self.report(where, f"{what} is larger than OpenGL framebuffers allow ({MAX_SIDE} pixels a side in "
                            "Mesa and on most GPUs); ask for a smaller image")
            elif size > limit:
                fix = f"use at most {limit}" if given else f"set camera: {{{key}: {limit}}} (or less)"
                self.report(where, f"{what} exceeds the model's offscreen buffer ({limit}); {fix} or add "
                            f"<visual><global {attr}=\"{size}\"/></visual> to the model")
        flags = scene_flags()
        for flag in cfg.camera.scene:
            if flag not in flags:
                self.report(self.origin(name, "camera") + ("scene", flag),
                            f"unknown scene flag {flag!r}{did_you_mean(flag, flags)}; flags: {', '.join(flags)}",
                            key=True)
        if len(self.problems) > before:
            return None
        mode = cast('Literal["rgb", "depth", "segmentation"]', cfg.kind)  # one of IMAGE_KINDS here
        camera = Camera(cfg.element, height=height, width=width, mode=mode,
                        scene_option=dict(cfg.camera.scene) or None, **timing)
        channels, dtype, _, _ = MODES[cfg.kind]
        return camera, (height, width, channels), dtype

    def heightscan(self, name: str, cfg: SensorConfig, timing: dict[str, Any]) -> tuple[Observable, Any, Any] | None:
        from .heightscan import HeightScan

        type_name = self.element_type(name, cfg)
        if type_name is None:
            return None
        if type_name not in ("body", "site") or not isinstance(cfg.element, str) or set("*?[") & set(cfg.element):
            self.report(("sensors", name, "element"), f"a height scan is cast from one frame, 'body:<name>' or "
                        f"'site:<name>'; got {cfg.element!r}")
            return None
        if not self.selection(name, cfg):
            return None
        assert cfg.scan is not None  # filled in by the loader
        scan = HeightScan(cfg.element, cfg.scan, **timing)
        return scan, scan.shape, np.dtype(np.float64)

    def generic(self, name: str, cfg: SensorConfig, timing: dict[str, Any]) -> tuple[Observable, Any, Any] | None:
        if cfg.callable is None:  # the loader reports a missing (or rejected) callable, once
            return None
        path = ("sensors", name, "callable")
        pos = self.suite.doc.pos(path)
        loc = ".".join(path)
        origin = pos.problem("", loc) if pos else Problem("", loc, self.suite.file)
        if cfg.batched:
            return self.batched(name, cfg, timing, origin)
        if not self.import_callables:
            return Generic(_not_imported(cfg.callable), origin=origin, **timing), None, None
        fn = self.import_callable(cfg.callable, path)
        if fn is None:
            return None
        shape = dtype = None
        if (cfg.noise or cfg.aggregator) and self.call_callables:  # they need the value's shape: one call, fresh state
            physics = Physics(self.model)
            mujoco.mj_forward(physics.model, physics.data)
            try:
                probe = np.asarray(fn(physics))
            except Exception as e:  # noqa: BLE001 - user code: any failure is the user's problem to see
                self.report(("sensors", name, "callable"), f"calling {cfg.callable} raised "
                            f"{type(e).__name__}: {e}")
                return None
            shape, dtype = probe.shape, probe.dtype
        return Generic(fn, origin=origin, **timing), shape, dtype

    def batched(self, name: str, cfg: SensorConfig, timing: dict[str, Any],
                origin: Problem) -> tuple[Observable, Any, Any] | None:
        """A generic callable of every world at once: the Warp engine's (it calls it, for its shape, and builds
        its noise when it is built); the CPU engines refuse it."""
        assert cfg.callable is not None
        if not self.warp:
            self.report(("sensors", name, "batched"), batch_refusal("batched generic"))
            return None
        path = ("sensors", name, "callable")
        fn = self.import_callable(cfg.callable, path) if self.import_callables else _not_imported(cfg.callable)
        stages = self.at_rate(name, cfg, timing["update_interval"]) if cfg.noise else ()
        if fn is None or stages is None:
            return None
        stages = stages if self.import_callables else tuple(s for s in stages if s.type != "custom")
        return BatchedGeneric(fn, noise_stages=stages, origin=origin, locate=self.locator(name), **timing), None, None

    def import_callable(self, text: str, path: Path_) -> Callable[..., Any] | None:
        module_name, _, attr = text.partition(":")
        try:
            target: Any = importlib.import_module(module_name)
        except Exception as e:  # noqa: BLE001 - an import of user code may fail in any way
            self.report(path, f"cannot import module {module_name!r} for {text!r}: {type(e).__name__}: {e}")
            return None
        for part in attr.split("."):
            if not hasattr(target, part):
                names = [n for n in dir(target) if not n.startswith("_")]
                self.report(path, f"module {module_name!r} has no {attr!r}{did_you_mean(part, names)}")
                return None
            target = getattr(target, part)
        if not callable(target):
            self.report(path, f"{text!r} is a {type(target).__name__}, not a function")
            return None
        return target


def _entries(value: str | tuple[str, ...] | None, path: Path_) -> list[tuple[str, Path_]]:
    """A selector, or each entry of a list of them, with the path of its node."""
    if value is None:
        return []
    if isinstance(value, str):
        return [(value, path)]
    return [(v, path + (i,)) for i, v in enumerate(value)]


@contextlib.contextmanager
def _suite_folder_first(folder: str | None) -> Iterator[None]:
    """Imports made inside look in `folder` first, then sys.path (a module imported once stays imported)."""
    if folder is None or (sys.path and sys.path[0] == folder):
        yield
        return
    sys.path.insert(0, folder)
    try:
        yield
    finally:
        if folder in sys.path:
            sys.path.remove(folder)


def _not_imported(text: str) -> Callable[..., Any]:
    def never_imported(*args: Any) -> Any:
        raise RuntimeError(f"{text} was not imported: build the suite with import_callables=True to run it")
    return never_imported


def _index(value: Any) -> Any:
    """A config index as numpy takes it: '0:3' -> slice(0, 3), ':, 2' -> (slice(None), 2)."""
    if value is None or isinstance(value, int):
        return value
    if isinstance(value, tuple):
        return list(value)
    parts: list[Any] = []
    for text in value.split(","):
        text = text.strip()
        if text == "...":
            parts.append(Ellipsis)
        elif ":" in text:
            parts.append(slice(*(int(x) if x.strip() else None for x in text.split(":"))))
        else:
            parts.append(int(text))
    return parts[0] if len(parts) == 1 else tuple(parts)


def bind(suite: LoadedSuite, model: mujoco.MjModel, *, import_callables: bool, call_callables: bool = True,
         batch: bool = False, refused: Mapping[str, str] | None = None,
         warp: bool = False) -> tuple[dict[str, Observable], list[Problem]]:
    """Observables for every sensor of `suite` (file order) and every problem found on the way; with
    `batch`, also what BatchEnvironment cannot run; with `warp`, for the Warp engine (which runs batched
    generic callables: `BatchedGeneric`, refused elsewhere at their `batched` key).

    With `call_callables` (building, and checking with the callables imported), a generic sensor whose noise or
    aggregator needs its value's shape is called once, on a fresh state, for it; without (checking without
    importing), no user callable is called.
    `refused`: the problem of each native sensor left out of the compiled model (`sensorcfg.native`)."""
    binder = _Binder(suite, model, import_callables, call_callables, batch, warp, dict(refused or {}))
    timestep = timestep_problem(float(model.opt.timestep))
    if timestep is not None:  # nothing is timed without it: one problem, at the model's line
        binder.report(("model",), timestep)
        return {}, binder.problems
    binder.options()
    observables: dict[str, Observable] = {}
    for name, cfg in suite.sensors.items():
        if name in suite.twins:  # its source's problems are reported once, at the source's lines
            if suite.twins[name] in observables:  # what fails now is the twin's own (see `report`)
                binder.twin = (name, suite.twins[name])
                made = binder.bind(name, cfg)
                binder.twin = None
                if made is not None:
                    observables[name] = made
            continue
        try:
            with _suite_folder_first(binder.folder(name)):
                observable = binder.bind(name, cfg)
        except SuiteError as e:  # a check an observable makes itself, that binding did not anticipate
            binder.report_all(("sensors", name), e)
            continue
        if observable is not None:
            observables[name] = observable
    return observables, binder.problems
