"""Differential tests: sensorcfg's Updater and observables against dm_control's, on one trajectory.

Each configuration runs dm_control's `Updater` and ours side by side, each on its own `mjcf.Physics` of
the same model, reset and driven identically (random controls, set through a binding in half of the
configurations, as composer walkers do): reset, then control steps of prepare / n x (step, update) /
get_observation. MuJoCo is deterministic, so the trajectories stay bit-identical unless an updater
changes its simulation. Every observation (values, type, shape, dtype, container type and key order)
and every spec must be identical at every control step. Configurations are drawn from a seeded
generator: interval 1-8, delay 0-8, buffer 1-6 (each a constant, a dm_control Variation drawing from the
episode's random_state, a zero-argument callable with its own generator, or one with an optional
random_state), every aggregator and none, both Updater flags, 1-10 physics steps per control step,
several observables at once, corruptors (random, dtype-changing), over four models (one with '/' in
its names).

`test_feature_parity`: dm_control's MJCFFeature on its side, sensorcfg.Feature on ours.
`test_drop_in_parity`: dm_control's own observables (MJCFFeature, Generic) fed to both updaters, with
corruptors drawing from the episode's random_state: the streams only agree if both updaters take the
same samples, in the same order, and draw intervals and delays in the same order.
Two documented deviations are pinned by their own tests (pad aliasing, bounds of built-in aggregators).
"""

from __future__ import annotations

import collections
import random
from typing import Any

import numpy as np
import pytest
from conftest import MODELS
from dm_env import specs

import sensorcfg

CONTROL_STEPS = 30
FEATURE_CONFIGS = 150  # per model
DROP_IN_CONFIGS = 75  # per model
MODEL_NAMES = ("arm", "quadruped", "chain", "composed")

# Kinds read per element type (dm_control `bind` names); each is tried on the models that have it.
KINDS = {
    "joint": ("qpos", "qvel", "qacc", "qfrc_actuator", "qfrc_passive", "range", "armature", "damping"),
    "body": ("xpos", "xquat", "xmat", "xipos", "cvel", "subtree_com", "cinert", "mass", "inertia"),
    "site": ("xpos", "xmat"),
    "geom": ("xpos", "xmat", "size"),
    "camera": ("xpos", "xmat"),
    "sensor": ("sensordata",),
    "actuator": ("ctrl", "act", "force", "length", "velocity", "gear", "ctrlrange"),
    "tendon": ("length", "velocity"),
}
AGGREGATOR_NAMES = (None, "min", "max", "mean", "median", "sum", "spread")


def spread(buffered: np.ndarray) -> np.ndarray:
    """A custom aggregator (no `preserves_bounds`): range over the buffer axis."""
    return np.ptp(buffered, axis=0)


# -- models ---------------------------------------------------------------------------------------


def build_model(oracle: Any, name: str) -> Any:
    """The dm_control MJCF root of a test model; 'composed' attaches two pendulums as 'left/', 'right/'."""
    mjcf = oracle.mjcf
    if name != "composed":
        return mjcf.from_path(str(MODELS / f"{name}.xml"))
    root = mjcf.from_path(str(MODELS / "chain.xml"))
    for prefix in ("left", "right"):
        child = mjcf.from_path(str(MODELS / "pendulum.xml"))
        child.model = prefix
        root.attach(child)
    return root


class Model:
    """A dm_control physics and the (type, kind, elements) a feature can read on it."""

    def __init__(self, oracle: Any, name: str):
        self.name = name
        self.root = build_model(oracle, name)
        self.physics = oracle.mjcf.Physics.from_mjcf_model(self.root)
        self.twin = oracle.mjcf.Physics.from_mjcf_model(self.root)  # ours runs on its own, identical copy
        self.actuators = self.root.find_all("actuator")
        self.elements = {}
        for type_name in KINDS:
            found = [e for e in self.root.find_all(type_name) if e.full_identifier]
            if found:
                self.elements[type_name] = found
        self.choices = [(t, k) for t, kinds in KINDS.items() if t in self.elements for k in kinds
                        if not (k == "act" and self.physics.model.na == 0)]

    def reset(self) -> None:
        self.physics.reset(keyframe_id=0)
        self.twin.reset(keyframe_id=0)

    def set_controls(self, controls: np.ndarray, via_bind: bool) -> None:
        """Set both physics' controls: through a binding (as composer walkers do, which marks a dm_control
        physics dirty: its next read of a derived quantity runs mj_forward first) or directly."""
        for physics in (self.physics, self.twin):
            if via_bind:
                physics.bind(self.actuators).ctrl = controls
            else:
                physics.data.ctrl[:] = controls


@pytest.fixture(scope="module")
def models(oracle: Any) -> dict[str, Model]:
    return {name: Model(oracle, name) for name in MODEL_NAMES}


def selector(type_name: str, elements: Any) -> Any:
    """sensorcfg's selector for MJCF elements: 'type:full/name', or a list of them."""
    if isinstance(elements, list):
        return [f"{type_name}:{e.full_identifier}" for e in elements]
    return f"{type_name}:{elements.full_identifier}"


# -- schedules: constants, Variations and zero-argument callables ------------------------------------


class OwnDraws:
    """A zero-argument callable with its own generator (dm_control calls it without random_state)."""

    def __init__(self, seed: int, low: int, high: int):
        self._rng = np.random.RandomState(seed)
        self._low, self._high = low, high

    def __call__(self) -> int:
        return int(self._rng.randint(self._low, self._high + 1))


class OptionalRandomState:
    """Takes an optional random_state, like dm_control's test sequences: dm_control never passes one to a
    callable that is not a Variation, so it draws from its own generator (and so must ours)."""

    def __init__(self, seed: int, low: int, high: int):
        self._own = np.random.RandomState(seed)
        self._low, self._high = low, high

    def __call__(self, random_state: Any = None) -> int:
        return int((random_state or self._own).randint(self._low, self._high + 1))


def make_random_state_draw(oracle: Any, low: int, high: int) -> Any:
    """A custom Variation: dm_control (and sensorcfg) call it with the episode's random_state."""

    class RandomStateDraw(oracle.variation.Variation):
        def __call__(self, initial_value=None, current_value=None, random_state=None):
            return random_state.randint(low, high + 1)

    return RandomStateDraw()


def draw_schedule(rng: random.Random, oracle: Any, low: int, high: int) -> Any:
    """A factory (called once per side) for an interval or delay setting."""
    style = rng.choice(("int", "int", "int", "int", "uniform", "custom", "own", "optional"))
    if style == "int":
        value = rng.randint(low, high)
        return lambda: value
    if style == "uniform":
        variation = oracle.distributions.UniformInteger(low, high + 1)
        return lambda: variation
    if style == "custom":
        variation = make_random_state_draw(oracle, low, high)
        return lambda: variation
    seed = rng.randrange(2**31)
    if style == "optional":
        return lambda: OptionalRandomState(seed, low, high)
    return lambda: OwnDraws(seed, low, high)


# -- comparison -------------------------------------------------------------------------------------


def assert_same_structure(ours: Any, theirs: Any, compare: Any, where: str) -> None:
    assert type(ours) is type(theirs), f"{where}: container {type(ours)} != {type(theirs)}"
    if isinstance(theirs, (list, tuple)):
        assert len(ours) == len(theirs), where
        for i, (a, b) in enumerate(zip(ours, theirs)):
            assert_same_structure(a, b, compare, f"{where}[{i}]")
        return
    assert list(ours) == list(theirs), f"{where}: keys {list(ours)} != {list(theirs)}"
    for key in theirs:
        compare(ours[key], theirs[key], f"{where}[{key!r}]")


def assert_same_value(ours: Any, theirs: Any, where: str) -> None:
    assert type(ours) is type(theirs), f"{where}: {type(ours).__name__} != {type(theirs).__name__}"
    a, b = np.asarray(ours), np.asarray(theirs)
    assert a.shape == b.shape, f"{where}: shape {a.shape} != {b.shape}"
    assert a.dtype == b.dtype, f"{where}: dtype {a.dtype} != {b.dtype}"
    assert np.array_equal(a, b), f"{where}: values differ\nours:   {a.tolist()!r}\ntheirs: {b.tolist()!r}"


def assert_same_spec(ours: Any, theirs: Any, where: str) -> None:
    assert type(ours) is type(theirs), f"{where}: spec type {type(ours)} != {type(theirs)}"
    assert (ours.shape, ours.dtype, ours.name) == (theirs.shape, theirs.dtype, theirs.name), (
        f"{where}: {ours!r} != {theirs!r}")
    if isinstance(theirs, specs.BoundedArray):
        assert np.array_equal(ours.minimum, theirs.minimum) and np.array_equal(ours.maximum, theirs.maximum)


def run_side_by_side(oracle: Any, model: Model, theirs: Any, ours: Any, n: int, strip: bool, pad: bool,
                     seed: int, where: str, control_steps: int = CONTROL_STEPS) -> tuple[Any, Any]:
    """Run both updaters over one trajectory each, comparing at reset and after every control step.

    Each updater has its own physics, reset and driven identically: MuJoCo is deterministic, so the two
    trajectories stay bit-identical unless an updater changes its simulation (dm_control's reads run
    mj_forward on a dirty physics, which also seeds the next step's constraint solver).
    """
    their_updater = oracle.updater.Updater(theirs, n, strip, pad)
    our_updater = sensorcfg.Updater(ours, n, strip, pad)
    physics, twin = model.physics, model.twin
    model.reset()
    via_bind = seed % 2 == 0
    model.set_controls(np.full(physics.model.nu, 0.5), via_bind)
    their_updater.reset(physics, np.random.RandomState(seed))
    our_updater.reset(twin, np.random.RandomState(seed))
    assert_same_structure(our_updater.observation_spec(), their_updater.observation_spec(), assert_same_spec,
                          f"{where} spec")
    assert_same_structure(our_updater.get_observation(), their_updater.get_observation(), assert_same_value,
                          f"{where} reset")
    controls = np.random.RandomState(seed + 1)
    for step in range(control_steps):
        model.set_controls(controls.uniform(-1, 1, physics.model.nu), via_bind)
        their_updater.prepare_for_next_control_step()
        our_updater.prepare_for_next_control_step()
        for _ in range(n):
            physics.step()
            twin.step()
            their_updater.update()
            our_updater.update()
        assert_same_structure(our_updater.get_observation(), their_updater.get_observation(), assert_same_value,
                              f"{where} control step {step + 1}")
        assert_same_structure(our_updater.observation_spec(), their_updater.observation_spec(), assert_same_spec,
                              f"{where} spec at control step {step + 1}")
    return our_updater, their_updater


def arrange(rng: random.Random, items: list[tuple[str, Any]], structure: str) -> Any:
    """Put named observables in a dict, an OrderedDict, or a list / tuple of dicts."""
    if structure == "dict":
        return dict(items)
    if structure == "ordered":
        return collections.OrderedDict(items)
    cut = rng.randint(0, len(items))
    parts = [dict(items[:cut]), collections.OrderedDict(items[cut:])]
    return parts if structure == "list" else tuple(parts)


# -- feature parity ---------------------------------------------------------------------------------


def feature_config(rng: random.Random, oracle: Any, model: Model) -> dict[str, Any]:
    """One random configuration: settings for both updaters and factories for each observable."""
    n = rng.randint(1, 10)
    strip, pad = rng.random() < 0.5, rng.random() < 0.5
    physics = model.physics
    observables = []
    for i in range(rng.randint(2, 6)):
        type_name, kind = rng.choice(model.choices)
        candidates = model.elements[type_name]
        form = rng.choice(("single", "single", "one", "several"))
        if form == "single":
            elements = rng.choice(candidates)
        elif form == "one":
            elements = [rng.choice(candidates)]
        else:
            elements = rng.sample(candidates, rng.randint(1, min(3, len(candidates))))
        value = np.asarray(getattr(physics.bind(elements), kind))
        index = None
        if value.ndim and value.shape[0] >= 2 and rng.random() < 0.3:
            index = rng.choice((0, -1, slice(0, 2), [1, 0]))
        shape = value[index].shape if index is not None else value.shape
        buffer_size = rng.randint(1, 6)
        aggregator = rng.choice(AGGREGATOR_NAMES)
        if strip and buffer_size == 1 and (not shape or shape[0] == 0):
            aggregator = None  # a stripped scalar (or empty value) has no axis to reduce: both raise
        observables.append(dict(
            name=f"{kind}_{i}", kind=kind, type=type_name, elements=elements, index=index,
            interval=draw_schedule(rng, oracle, 1, 8), delay=draw_schedule(rng, oracle, 0, 8),
            buffer_size=buffer_size, aggregator=spread if aggregator == "spread" else aggregator,
            enabled=rng.random() < 0.9))
    return dict(n=n, strip=strip, pad=pad, observables=observables,
                structure=rng.choice(("dict", "ordered", "list", "tuple")))


def single(value: Any, random_state: Any = None) -> Any:
    """A corruptor that changes the dtype: the observation's spec follows it."""
    return np.array(np.asarray(value, dtype=np.float32) * 2)  # an array: see copied()


def noisy(value: Any, random_state: Any) -> Any:
    """A corruptor drawing from the episode's random_state, as dm_control's noise corruptors do."""
    return np.array(value + random_state.normal(size=np.shape(value)))  # an array: see copied()


def copied(value: Any, random_state: Any = None) -> Any:
    """Detach a dm_control binding's value from the live physics (see test_pad_aliasing_deviation)."""
    return np.array(value)


def build_features(oracle: Any, config: dict[str, Any], ours: bool, rng: random.Random) -> Any:
    items = []
    for spec in config["observables"]:
        settings = dict(update_interval=spec["interval"](), delay=spec["delay"](), buffer_size=spec["buffer_size"],
                        aggregator=spec["aggregator"], index=spec["index"],
                        corruptor={"_1": noisy, "_2": single}.get(spec["name"][-2:]))
        if not ours and settings["corruptor"] is None:
            settings["corruptor"] = copied
        if ours:
            observable = sensorcfg.Feature(spec["kind"], selector(spec["type"], spec["elements"]), **settings)
        else:
            observable = oracle.observable.MJCFFeature(spec["kind"], spec["elements"], **settings)
        observable.enabled = spec["enabled"]
        items.append((spec["name"], observable))
    return arrange(rng, items, config["structure"])


@pytest.mark.parametrize("model_name", MODEL_NAMES)
def test_feature_parity(oracle: Any, models: dict[str, Model], model_name: str) -> None:
    model = models[model_name]
    configs = random.Random(f"feature-{model_name}")
    for k in range(FEATURE_CONFIGS):
        config = feature_config(configs, oracle, model)
        seed = configs.randrange(2**31)
        arrangement = configs.randrange(2**31)
        theirs = build_features(oracle, config, False, random.Random(arrangement))
        ours = build_features(oracle, config, True, random.Random(arrangement))
        where = f"{model_name} config {k} (n={config['n']}, strip={config['strip']}, pad={config['pad']})"
        run_side_by_side(oracle, model, theirs, ours, config["n"], config["strip"], config["pad"], seed, where)


# -- drop-in parity: dm_control's observables in our Updater -------------------------------------


class Counted:
    """A Generic's raw callable that counts the samples an updater takes."""

    def __init__(self, width: int, scale: float):
        self.width, self.scale, self.calls = width, scale, 0

    def __call__(self, physics: Any) -> np.ndarray:
        self.calls += 1
        return physics.data.qpos[: self.width] * self.scale + physics.data.time


def drop_in_config(rng: random.Random, oracle: Any, model: Model) -> dict[str, Any]:
    config = feature_config(rng, oracle, model)
    for spec in config["observables"]:
        spec["generic"] = rng.random() < 0.5
        spec["width"] = rng.randint(1, 4)
        spec["noisy"] = rng.random() < 0.5
    return config


def build_dm_observables(oracle: Any, config: dict[str, Any], rng: random.Random) -> tuple[Any, list[Counted]]:
    items, counters = [], []
    for spec in config["observables"]:
        settings = dict(update_interval=spec["interval"](), delay=spec["delay"](), buffer_size=spec["buffer_size"],
                        aggregator=spec["aggregator"], corruptor=noisy if spec["noisy"] else copied)
        if spec["generic"]:
            counter = Counted(spec["width"], 1.5)
            counters.append(counter)
            observable = oracle.observable.Generic(counter, **settings)
        else:
            observable = oracle.observable.MJCFFeature(spec["kind"], spec["elements"], index=spec["index"],
                                                       **settings)
        observable.enabled = spec["enabled"]
        items.append((spec["name"], observable))
    return arrange(rng, items, config["structure"]), counters


@pytest.mark.parametrize("model_name", MODEL_NAMES)
def test_drop_in_parity(oracle: Any, models: dict[str, Model], model_name: str) -> None:
    model = models[model_name]
    configs = random.Random(f"drop-in-{model_name}")
    for k in range(DROP_IN_CONFIGS):
        config = drop_in_config(configs, oracle, model)
        if config["strip"]:  # a stripped scalar Generic has no axis to aggregate over
            for spec in config["observables"]:
                if spec["buffer_size"] == 1 and spec["generic"]:
                    spec["aggregator"] = None
        seed = configs.randrange(2**31)
        arrangement = configs.randrange(2**31)
        theirs, their_counts = build_dm_observables(oracle, config, random.Random(arrangement))
        ours, our_counts = build_dm_observables(oracle, config, random.Random(arrangement))
        where = f"{model_name} drop-in config {k} (n={config['n']}, strip={config['strip']}, pad={config['pad']})"
        run_side_by_side(oracle, model, theirs, ours, config["n"], config["strip"], config["pad"], seed, where)
        assert [c.calls for c in our_counts] == [c.calls for c in their_counts], f"{where}: samples taken"


def test_ours_in_dm_control_updater(oracle: Any, models: dict[str, Model]) -> None:
    """The other direction: sensorcfg observables inside dm_control's own Updater."""
    model = models["arm"]
    configs = random.Random("ours-in-dm-control")
    for k in range(40):
        config = feature_config(configs, oracle, model)
        seed, arrangement = configs.randrange(2**31), configs.randrange(2**31)
        theirs = build_features(oracle, config, False, random.Random(arrangement))
        ours = build_features(oracle, config, True, random.Random(arrangement))
        for observables in ours if isinstance(ours, (list, tuple)) else [ours]:
            for observable in observables.values():  # dm_control pads with the raw first value: see copied()
                observable.corruptor = observable.corruptor or copied
        n, strip, pad = config["n"], config["strip"], config["pad"]
        reference = oracle.updater.Updater(theirs, n, strip, pad)
        hosted = oracle.updater.Updater(ours, n, strip, pad)
        model.reset()
        reference.reset(model.physics, np.random.RandomState(seed))
        hosted.reset(model.physics, np.random.RandomState(seed))
        where = f"hosted config {k}"
        assert_same_structure(hosted.observation_spec(), reference.observation_spec(), assert_same_spec, where)
        for step in range(CONTROL_STEPS):
            reference.prepare_for_next_control_step()
            hosted.prepare_for_next_control_step()
            for _ in range(n):
                model.physics.step()
                reference.update()
                hosted.update()
            assert_same_structure(hosted.get_observation(), reference.get_observation(), assert_same_value,
                                  f"{where} control step {step + 1}")


def test_pathological_periods(oracle: Any, models: dict[str, Model]) -> None:
    """Intervals whose common period is too long to tabulate (each task checks its own phase)."""
    model = models["quadruped"]

    def build() -> tuple[dict[str, Any], list[Counted]]:
        observables, counters = {}, []
        for k, (interval, delay, buffer_size) in enumerate([(251, 3, 2), (257, 0, 1), (263, 300, 3), (1, 0, 1)]):
            counter = Counted(2, 1.0 + k)
            counters.append(counter)
            observables[f"g{k}"] = oracle.observable.Generic(counter, update_interval=interval, delay=delay,
                                                             buffer_size=buffer_size, corruptor=noisy)
            observables[f"g{k}"].enabled = True
        drawn = oracle.observable.Generic(Counted(1, 9.0), update_interval=oracle.distributions.UniformInteger(1, 4),
                                          delay=oracle.distributions.UniformInteger(0, 4), corruptor=noisy)
        drawn.enabled = True
        observables["drawn"] = drawn
        return observables, counters

    theirs, their_counts = build()
    ours, our_counts = build()
    run_side_by_side(oracle, model, theirs, ours, 7, False, True, 5, "pathological periods", control_steps=150)
    assert [c.calls for c in our_counts] == [c.calls for c in their_counts]


def test_pad_aliasing_deviation(oracle: Any, models: dict[str, Model]) -> None:
    """A documented, intentional deviation: dm_control pads with the live value, we with the first one.

    dm_control fills the buffer with the object the first read returned, uncopied. MJCFFeature returns
    the binding's cached array, which every later read of that binding refreshes in place, so the
    "initial value" padding shows the newest value instead. The parity tests detach values (copied())
    to compare everything else; here both behaviours are pinned.
    """
    model = models["arm"]
    root_joint = model.root.find("joint", "root")

    def observables(make: Any) -> dict[str, Any]:
        observable = make()
        observable.configure(update_interval=1, delay=8, buffer_size=3)
        observable.enabled = True
        return {"qpos": observable}

    theirs = oracle.updater.Updater(observables(lambda: oracle.observable.MJCFFeature("qpos", root_joint)), 2,
                                    pad_with_initial_value=True)
    ours = sensorcfg.Updater(observables(lambda: sensorcfg.Feature("qpos", "joint:root")), 2,
                             pad_with_initial_value=True)
    model.reset()
    initial = model.physics.data.qpos[:7].copy()
    theirs.reset(model.physics, np.random.RandomState(0))
    ours.reset(model.physics, np.random.RandomState(0))
    for updater in (theirs, ours):
        updater.prepare_for_next_control_step()
    for _ in range(2):
        model.physics.step()
        theirs.update()
        ours.update()
    live = model.physics.bind(root_joint).qpos.copy()  # refreshes dm_control's cached binding array
    np.testing.assert_array_equal(ours.get_observation()["qpos"], [initial] * 3)
    np.testing.assert_array_equal(theirs.get_observation()["qpos"], [live] * 3)  # nothing delivered yet


def test_episodes_reuse_updaters(oracle: Any, models: dict[str, Model]) -> None:
    """Several episodes on the same pair of updaters (reset again, one random_state across episodes)."""
    for name, model in models.items():
        configs = random.Random(f"episodes-{name}")
        for k in range(20):
            config = feature_config(configs, oracle, model)
            seed, arrangement = configs.randrange(2**31), configs.randrange(2**31)
            theirs = oracle.updater.Updater(build_features(oracle, config, False, random.Random(arrangement)),
                                            config["n"], config["strip"], config["pad"])
            ours = sensorcfg.Updater(build_features(oracle, config, True, random.Random(arrangement)),
                                     config["n"], config["strip"], config["pad"])
            their_random, our_random = np.random.RandomState(seed), np.random.RandomState(seed)
            for episode in range(3):
                model.reset()
                model.physics.data.qvel[:] += episode
                theirs.reset(model.physics, their_random)
                ours.reset(model.physics, our_random)
                for step in range(8 + 5 * episode):
                    theirs.prepare_for_next_control_step()
                    ours.prepare_for_next_control_step()
                    for _ in range(config["n"]):
                        model.physics.step()
                        theirs.update()
                        ours.update()
                    assert_same_structure(ours.get_observation(), theirs.get_observation(), assert_same_value,
                                          f"{name} config {k} episode {episode} control step {step + 1}")


@pytest.mark.parametrize("model_name", ["arm", "quadruped"])
def test_long_buffers(oracle: Any, models: dict[str, Model], model_name: str) -> None:
    """Buffers of 8-40 samples, one-value and wider samples mixed under one aggregator and buffer size.

    numpy sums a buffer of one-value samples pairwise (its 1-D path) and wider ones row by row; both
    updaters must give dm_control's bits whichever way they batch the reductions.
    """
    model = models[model_name]
    configs = random.Random(f"long-{model_name}")
    for k in range(40):
        config = feature_config(configs, oracle, model)
        size, aggregator = configs.choice((8, 13, 40)), configs.choice(("sum", "mean", "median", "max"))
        for spec in config["observables"]:
            spec["buffer_size"], spec["aggregator"], spec["enabled"] = size, aggregator, True
            value = np.asarray(getattr(model.physics.bind(spec["elements"]), spec["kind"]))
            if configs.random() < 0.6 and value.ndim and value.shape[0]:
                spec["index"] = 0  # a one-value sample
        seed, arrangement = configs.randrange(2**31), configs.randrange(2**31)
        theirs = build_features(oracle, config, False, random.Random(arrangement))
        ours = build_features(oracle, config, True, random.Random(arrangement))
        run_side_by_side(oracle, model, theirs, ours, config["n"], config["strip"], config["pad"], seed,
                         f"{model_name} long-buffer config {k}", control_steps=20)


def test_builtin_aggregators_keep_bounds_deviation(oracle: Any) -> None:
    """A documented, intentional deviation: our Updater keeps the bounds of min/max/mean/median.

    dm_control's built-in aggregators carry a misspelled `bounds_reserving` while its Updater reads
    `preserves_bounds`, so dm_control drops the bounds even of a mean; we read both names. Sum drops
    them in both.
    """

    class Bounded(oracle.observable.Generic):
        @property
        def array_spec(self) -> specs.BoundedArray:
            return specs.BoundedArray(shape=(2,), dtype=np.float64, minimum=-1.0, maximum=1.0)

    for name in ("min", "max", "mean", "median", "sum"):
        observable = Bounded(lambda _: np.zeros(2), buffer_size=3, aggregator=name)
        observable.enabled = True
        theirs, ours = oracle.updater.Updater({"x": observable}), sensorcfg.Updater({"x": observable})
        theirs.reset(None, None)
        ours.reset(None, None)
        assert type(theirs.observation_spec()["x"]) is specs.Array
        assert type(ours.observation_spec()["x"]) is (specs.Array if name == "sum" else specs.BoundedArray)
