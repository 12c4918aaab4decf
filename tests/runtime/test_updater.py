"""The Updater without an oracle: closed-form schedules, structure, specs, flags, skipping, memory, bad input.

A Generic observable that returns the physics step count (plus 100, so padding zeros stand out) makes
every observation predictable: with interval I, delay D and buffer B, a read at step R holds samples
k - B + 1 .. k with k = floor((R - D) / I), sample j having been taken at step j * I (negative j: padding).
"""

from __future__ import annotations

import collections
import itertools
import tracemalloc
from typing import Any

import numpy as np
import pytest
from conftest import MODELS
from dm_env import specs

import sensorcfg
from sensorcfg import ArgumentError
from sensorcfg.draws import UniformSteps

OFFSET = 100


class Clock:
    """A stand-in physics: the Updater hands it to Generic callables untouched."""

    def __init__(self) -> None:
        self.t = 0


def clock_observable(**settings: Any) -> sensorcfg.Generic:
    observable = sensorcfg.Generic(lambda clock: np.array([clock.t + OFFSET, -clock.t]), **settings)
    observable.enabled = True
    return observable


def expected_window(read_step: int, interval: int, delay: int, buffer_size: int, pad: bool) -> np.ndarray:
    newest = (read_step - delay) // interval
    rows = []
    for j in range(newest - buffer_size + 1, newest + 1):
        if j >= 0:
            rows.append([j * interval + OFFSET, -j * interval])
        else:
            rows.append([OFFSET, 0] if pad else [0, 0])
    return np.array(rows)


def run(updater: sensorcfg.Updater, clock: Clock, control_steps: int, seed: int = 0):
    """Yield (physics step, observation) after reset and after each control step."""
    updater.reset(clock, np.random.RandomState(seed))
    yield 0, updater.get_observation()
    n = updater.physics_steps_per_control_step
    for _ in range(control_steps):
        updater.prepare_for_next_control_step()
        for _ in range(n):
            clock.t += 1
            updater.update()
        yield clock.t, updater.get_observation()


GRID = list(itertools.product(range(1, 9), range(0, 9), range(1, 7)))  # interval, delay, buffer


@pytest.mark.parametrize("n", range(1, 11))
def test_closed_form_schedule(n: int) -> None:
    """Every (interval 1-8, delay 0-8, buffer 1-6), both pads, over 240 physics steps."""
    for pad in (False, True):
        clock = Clock()
        observables = {f"{i}/{d}/{b}": clock_observable(update_interval=i, delay=d, buffer_size=b)
                       for i, d, b in GRID}
        updater = sensorcfg.Updater(observables, n, pad_with_initial_value=pad)
        for step, obs in run(updater, clock, 240 // n):
            for i, d, b in GRID:
                got, expected = obs[f"{i}/{d}/{b}"], expected_window(step, i, d, b, pad)
                assert np.array_equal(got, expected), (
                    f"n={n} pad={pad} step={step} interval={i} delay={d} buffer={b}: "
                    f"{got.tolist()} != {expected.tolist()}")


@pytest.mark.parametrize("name,reduce", [pytest.param(name, reduce, id=name) for name, reduce in (
    ("min", lambda w: w.min(0)), ("max", lambda w: w.max(0)), ("mean", lambda w: w.mean(0)),
    ("median", lambda w: np.median(w, 0)), ("sum", lambda w: w.sum(0)))])
def test_closed_form_aggregated(name: str, reduce: Any) -> None:
    clock = Clock()
    settings = [(3, 2, 4), (1, 0, 5), (2, 7, 3), (5, 1, 2)]
    observables = {f"o{k}": clock_observable(update_interval=i, delay=d, buffer_size=b, aggregator=name)
                   for k, (i, d, b) in enumerate(settings)}
    for step, obs in run(sensorcfg.Updater(observables, 4), clock, 100):
        for k, (i, d, b) in enumerate(settings):
            np.testing.assert_array_equal(obs[f"o{k}"], reduce(expected_window(step, i, d, b, False)))


FEATURES = [("qpos", "joint:root"), ("xpos", "body:*"), ("sensordata", ["sensor:accel", "sensor:gyro"]),
            ("qvel", "joint:wrist"), ("act", "actuator:extend_int"), ("mass", "body:hand")]
AGGREGATORS = {None: None, "min": np.min, "max": np.max, "mean": np.mean, "median": np.median, "sum": np.sum}


@pytest.mark.parametrize("n", [1, 3, 5, 10])
def test_closed_form_features(n: int) -> None:
    """Features (the fast path reads them together) against a per-step history of the same reads."""
    import mujoco

    physics = sensorcfg.Physics.from_xml_path(str(MODELS / "arm.xml"))
    mujoco.mj_resetDataKeyframe(physics.model, physics.data, 0)
    mujoco.mj_forward(physics.model, physics.data)
    rng = np.random.RandomState(n)
    settings = []
    for k in range(24):
        kind, element = FEATURES[k % len(FEATURES)]
        settings.append((f"f{k}", kind, element, rng.randint(1, 9), rng.randint(0, 9), rng.randint(1, 7),
                         list(AGGREGATORS)[rng.randint(len(AGGREGATORS))]))
    observables = {}
    for name, kind, element, i, d, b, agg in settings:
        observables[name] = sensorcfg.Feature(kind, element, update_interval=i, delay=d, buffer_size=b, aggregator=agg)
        observables[name].enabled = True
    readers = {name: sensorcfg.Feature(kind, element).observation_callable(physics)
               for name, kind, element, *_ in settings}
    history = {name: [read()] for name, read in readers.items()}
    updater = sensorcfg.Updater(observables, n, pad_with_initial_value=bool(n % 2))
    updater.reset(physics, np.random.RandomState(0))
    for control_step in range(1, 201 // n + 1):
        physics.data.ctrl[:] = rng.uniform(-1, 1, physics.model.nu)
        updater.prepare_for_next_control_step()
        for _ in range(n):
            physics.step()
            updater.update()
            for name, read in readers.items():
                history[name].append(read())
        step = control_step * n
        obs = updater.get_observation()
        for name, kind, element, i, d, b, agg in settings:
            newest = (step - d) // i
            pad = history[name][0] if n % 2 else np.zeros_like(history[name][0])
            window = np.array([history[name][j * i] if j >= 0 else pad for j in range(newest - b + 1, newest + 1)])
            expected = window if agg is None else AGGREGATORS[agg](window, axis=0)
            assert obs[name].shape == expected.shape and np.array_equal(obs[name], expected), (
                f"{name} {kind} of {element} interval={i} delay={d} buffer={b} aggregator={agg} at step {step}")


def test_strip_singleton_buffer_dim() -> None:
    clock = Clock()
    observables = {"one": clock_observable(buffer_size=1), "two": clock_observable(buffer_size=2),
                   "default": clock_observable()}
    updater = sensorcfg.Updater(observables, 3, strip_singleton_buffer_dim=True)
    for step, obs in run(updater, clock, 5):
        np.testing.assert_array_equal(obs["one"], [step + OFFSET, -step])
        np.testing.assert_array_equal(obs["default"], [step + OFFSET, -step])
        assert obs["two"].shape == (2, 2)
    spec = updater.observation_spec()
    assert (spec["one"].shape, spec["two"].shape, spec["default"].shape) == ((2,), (2, 2), (2,))


def test_pad_with_initial_value() -> None:
    clock = Clock()
    observables = {"late": clock_observable(update_interval=2, delay=7, buffer_size=3)}
    padded = {step: obs["late"] for step, obs in run(sensorcfg.Updater(observables, 2, pad_with_initial_value=True),
                                                       clock, 4)}
    np.testing.assert_array_equal(padded[2], [[OFFSET, 0]] * 3)  # nothing delivered yet: the reset sample
    np.testing.assert_array_equal(padded[8], [[OFFSET, 0], [OFFSET, 0], [OFFSET, 0]])  # sample 0 arrived at 7
    clock = Clock()
    zeros = {step: obs["late"] for step, obs in run(sensorcfg.Updater(observables, 2), clock, 4)}
    np.testing.assert_array_equal(zeros[2], [[0, 0]] * 3)
    np.testing.assert_array_equal(zeros[8], [[0, 0], [0, 0], [OFFSET, 0]])


# -- structure and specs --------------------------------------------------------------------------


@pytest.mark.parametrize("structure", [
    pytest.param(lambda a, b: {"a": a, "b": b}, id="dict"),
    pytest.param(lambda a, b: collections.OrderedDict([("b", b), ("a", a)]), id="ordered"),
    pytest.param(lambda a, b: [{"a": a}, collections.OrderedDict([("b", b)])], id="list"),
    pytest.param(lambda a, b: ({"a": a}, {"b": b}), id="tuple"),
])
def test_structure_is_preserved(structure: Any) -> None:
    clock = Clock()
    disabled = clock_observable()
    disabled.enabled = False
    observables = structure(clock_observable(), clock_observable(buffer_size=2))
    first = observables if isinstance(observables, dict) else observables[0]
    first["off"] = disabled
    updater = sensorcfg.Updater(observables, 2)
    for _, obs in run(updater, clock, 3):
        for output in (obs, updater.observation_spec(), updater.samples_taken()):
            assert type(output) is type(observables)
            pairs = zip(output, observables) if isinstance(output, (list, tuple)) else [(output, observables)]
            for out_dict, in_dict in pairs:
                assert type(out_dict) is type(in_dict)
                assert list(out_dict) == [k for k in in_dict if k != "off"]


class Bounded(sensorcfg.Generic):
    """A Generic with a bounded spec."""

    @property
    def array_spec(self) -> specs.BoundedArray:
        return specs.BoundedArray(shape=(2,), dtype=np.float64, minimum=-1.0, maximum=1.0)


class MySpec(specs.Array):
    pass


class Custom(sensorcfg.Generic):
    @property
    def array_spec(self) -> MySpec:
        return MySpec(shape=(2,), dtype=np.float64)


def spread(buffered: np.ndarray) -> np.ndarray:
    return buffered.max(0) - buffered.min(0)


def clipped_mean(buffered: np.ndarray) -> np.ndarray:
    return np.clip(buffered.mean(0), -1, 1)


clipped_mean.preserves_bounds = True  # type: ignore[attr-defined]


@pytest.mark.parametrize("aggregator,bounded", [
    pytest.param(None, True, id="none"),
    pytest.param("min", True, id="min"),
    pytest.param("max", True, id="max"),
    pytest.param("mean", True, id="mean"),
    pytest.param("median", True, id="median"),
    pytest.param("sum", False, id="sum"),
    pytest.param(spread, False, id="custom"),
    pytest.param(clipped_mean, True, id="custom-preserves-bounds"),
])
def test_spec_bounds(aggregator: Any, bounded: bool) -> None:
    observable = Bounded(lambda _: np.array([0.5, -0.5]), buffer_size=3, aggregator=aggregator)
    observable.enabled = True
    updater = sensorcfg.Updater({"x": observable})
    updater.reset(None, None)
    spec = updater.observation_spec()["x"]
    assert spec.name == "x"
    assert spec.shape == ((3, 2) if aggregator is None else (2,))
    assert isinstance(spec, specs.BoundedArray) == bounded
    if bounded and aggregator == "mean":  # widened by the mean's worst rounding: 3 values, 3 eps
        slack = 3 * np.finfo(np.float64).eps
        assert (spec.minimum, spec.maximum) == (-1.0 - slack, 1.0 + slack)
    elif bounded:
        assert (spec.minimum, spec.maximum) == (-1.0, 1.0)
    assert np.shape(updater.get_observation()["x"]) == spec.shape


class AtMost(sensorcfg.Generic):
    """A Generic bounded above by the value it returns."""

    def __init__(self, value: float, **kwargs: Any):
        super().__init__(lambda _: np.array([value]), **kwargs)
        self.value = value

    @property
    def array_spec(self) -> specs.BoundedArray:
        return specs.BoundedArray(shape=(1,), dtype=np.float64, minimum=-self.value, maximum=self.value)


@pytest.mark.parametrize("value,buffer_size", [(0.1, 3), (0.7, 6), (1 / 3, 10)])
def test_a_mean_at_its_bound_is_within_its_spec(value: float, buffer_size: int) -> None:
    """The float mean of values at the bound can round past it (three 0.1s make 0.1 + 1 ulp)."""
    assert np.mean(np.full(buffer_size, value)) > value  # the rounding the spec must allow for
    observable = AtMost(value, buffer_size=buffer_size, aggregator="mean")
    observable.enabled = True
    updater = sensorcfg.Updater({"x": observable})
    updater.reset(None, None)
    for _ in range(buffer_size):
        updater.prepare_for_next_control_step()
        updater.update()
    spec = updater.observation_spec()["x"]
    spec.validate(updater.get_observation()["x"])


def test_spec_type_kept_without_aggregator() -> None:
    observable = Custom(lambda _: np.zeros(2), buffer_size=4)
    observable.enabled = True
    updater = sensorcfg.Updater({"x": observable})
    updater.reset(None, None)
    spec = updater.observation_spec()["x"]
    assert type(spec) is MySpec and spec.shape == (4, 2) and spec.name == "x"


def test_spec_inferred_from_a_sample() -> None:
    observable = sensorcfg.Generic(lambda _: np.arange(6, dtype=np.int32).reshape(2, 3), buffer_size=2,
                                   aggregator="mean")
    observable.enabled = True
    updater = sensorcfg.Updater({"x": observable})
    updater.reset(None, None)
    spec = updater.observation_spec()["x"]
    assert type(spec) is specs.Array and spec.shape == (2, 3) and spec.dtype == np.float64


# -- skipping and counters ------------------------------------------------------------------------


@pytest.mark.parametrize("interval,delay,buffer_size,n,per_control_step", [
    pytest.param(1, 0, 1, 10, 1, id="camera-like"),
    pytest.param(1, 0, 3, 10, 3, id="buffer-3"),
    pytest.param(1, 4, 1, 10, 1, id="delayed"),
    pytest.param(2, 0, 1, 10, 1, id="interval-2"),
    pytest.param(1, 0, 1, 1, 1, id="one-step-control"),
    pytest.param(3, 0, 100, 9, 3, id="big-buffer-takes-all"),
])
def test_unobservable_samples_are_not_taken(interval: int, delay: int, buffer_size: int, n: int,
                                            per_control_step: int) -> None:
    calls = []
    camera = sensorcfg.Generic(lambda _: calls.append(1) or np.zeros((4, 4, 3), np.uint8),
                               update_interval=interval, delay=delay, buffer_size=buffer_size)
    camera.enabled = True
    updater = sensorcfg.Updater({"camera": camera}, n)
    control_steps = 50
    for _ in run(updater, Clock(), control_steps):
        pass
    probe = 1  # a Generic has no spec: the Updater takes one sample at reset to learn shape and dtype
    assert updater.samples_taken()["camera"] == 1 + per_control_step * control_steps
    assert len(calls) == probe + 1 + per_control_step * control_steps


def test_drawn_schedules_skip_too() -> None:
    calls = []
    camera = sensorcfg.Generic(lambda _: calls.append(1) or 0.0, update_interval=lambda: 1, delay=lambda: 0)
    camera.enabled = True
    updater = sensorcfg.Updater({"camera": camera}, 10)
    for _ in run(updater, Clock(), 20):
        pass
    assert updater.samples_taken()["camera"] == 21 == len(calls) - 1


def test_memory_is_bounded_by_delay_not_episode_length() -> None:
    """No structure grows with the episode: large delays, fixed and drawn, buffered and not."""
    big = np.zeros(2000)
    observables = {
        "fixed": sensorcfg.Generic(lambda _: big + 1, update_interval=1, delay=200, buffer_size=3),
        "drawn": sensorcfg.Generic(lambda _: big + 2, update_interval=lambda: 1, delay=lambda: 150, buffer_size=2),
        "mixed": sensorcfg.Generic(lambda _: big + 3, update_interval=3, delay=lambda: 90),
    }
    for observable in observables.values():
        observable.enabled = True
    updater = sensorcfg.Updater(observables, 4)
    steps = run(updater, Clock(), 5000)
    for _ in itertools.islice(steps, 300):
        pass
    tracemalloc.start()
    try:
        for _ in itertools.islice(steps, 100):
            pass
        early = tracemalloc.get_traced_memory()[0]
        for _ in itertools.islice(steps, 3000):
            pass
        late = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert late - early < 100_000, f"memory grew by {late - early} bytes over 3000 control steps"


# -- bad input ------------------------------------------------------------------------------------


@pytest.mark.parametrize("settings,message", [
    pytest.param(dict(update_interval=-1), r"update_interval must be a positive integer .*, got -1", id="interval<0"),
    pytest.param(dict(update_interval=0), r"update_interval must be a positive integer .*, got 0", id="interval=0"),
    pytest.param(dict(update_interval=1.5), r"update_interval must be a positive integer .*, got 1\.5",
                 id="interval-float"),
    pytest.param(dict(delay=-2), r"delay must be a non-negative integer .*, got -2", id="delay<0"),
    pytest.param(dict(delay=0.5), r"delay must be a non-negative integer .*, got 0\.5", id="delay-float"),
    pytest.param(dict(buffer_size=0), r"buffer_size must be a positive integer, got 0", id="buffer=0"),
    pytest.param(dict(buffer_size=2.5), r"buffer_size must be a positive integer, got 2\.5", id="buffer-float"),
    pytest.param(dict(aggregator="mena"), r"unknown aggregator 'mena' \(did you mean 'mean' or 'median'\?\)",
                 id="aggregator"),
])
def test_bad_settings_fail_at_construction(settings: dict[str, Any], message: str) -> None:
    with pytest.raises(sensorcfg.SuiteError, match=r"Feature\('qpos', 'joint:root'\): " + message):
        sensorcfg.Feature("qpos", "joint:root", **settings)


def test_bad_settings_fail_when_set() -> None:
    feature = sensorcfg.Feature("qpos", "joint:root")
    with pytest.raises(sensorcfg.SuiteError, match=r"delay must be a non-negative integer .*, got -1"):
        feature.configure(delay=-1)
    with pytest.raises(AttributeError, match="no attribute 'dealy'"):
        feature.configure(dealy=1)


class Duck:
    """A dm_control-style observable: no validation of its own."""

    def __init__(self, **settings: Any):
        self.update_interval, self.delay, self.buffer_size = 1, None, None
        self.aggregator = self.corruptor = self.array_spec = None
        self.enabled = True
        self.__dict__.update(settings)

    def observation_callable(self, physics: Any, random_state: Any = None) -> Any:
        return lambda: 1.0


@pytest.mark.parametrize("settings,message", [
    pytest.param(dict(update_interval=-1), r"observable 'duck': update_interval must be a positive integer, got -1",
                 id="interval"),
    pytest.param(dict(delay="2"), r"observable 'duck': delay must be a non-negative integer, got '2'", id="delay"),
    pytest.param(dict(buffer_size=0.5), r"observable 'duck': buffer_size must be a positive integer, got 0\.5",
                 id="buffer"),
])
def test_bad_duck_typed_settings_fail_at_reset(settings: dict[str, Any], message: str) -> None:
    with pytest.raises(sensorcfg.SuiteError, match=message):
        sensorcfg.Updater({"duck": Duck(**settings)}).reset(None, None)


@pytest.mark.parametrize("settings,message", [
    pytest.param(dict(update_interval=lambda: 0),
                 r"observable '0/cam': its update_interval callable drew 0; it must draw integers >= 1",
                 id="interval-0"),
    pytest.param(dict(delay=lambda: -1), r"observable '0/cam': its delay callable drew -1; it must draw integers >= 0",
                 id="delay-negative"),
    pytest.param(dict(delay=lambda random_state: random_state.uniform(0.1, 0.9)),
                 r"observable '0/cam': its delay callable drew 0\.\d+; it must draw integers >= 0", id="delay-float"),
])
def test_bad_draws_fail_before_the_first_step(settings: dict[str, Any], message: str) -> None:
    observable = sensorcfg.Generic(lambda _: 1.0, **settings)
    observable.enabled = True
    updater = sensorcfg.Updater([{"cam": observable}], 2)
    with pytest.raises(sensorcfg.SuiteError, match=message):
        updater.reset(None, np.random.RandomState(0))
        updater.prepare_for_next_control_step()


@pytest.mark.parametrize("n", [0, -1, 2.5, True, "2"])
def test_bad_physics_steps_per_control_step(n: Any) -> None:
    with pytest.raises(ArgumentError, match=rf"physics_steps_per_control_step must be a positive integer, "
                                                   rf"got {n!r}"):
        sensorcfg.Updater({}, n)


def test_bad_structure() -> None:
    with pytest.raises(ArgumentError, match="must be a dict, or a list or tuple of dicts"):
        sensorcfg.Updater([clock_observable()])


def test_unknown_element_names_the_observable_at_reset() -> None:
    physics = sensorcfg.Physics.from_xml_path(str(MODELS / "arm.xml"))
    observable = sensorcfg.Feature("xpos", "body:bse")
    observable.enabled = True
    with pytest.raises(sensorcfg.SuiteError,
                       match=r"observable 'hand': the model has no body named 'bse' \(did you mean 'base'\?\)"):
        sensorcfg.Updater({"hand": observable}).reset(physics, None)


def test_kind_the_type_lacks() -> None:
    with pytest.raises(sensorcfg.SuiteError, match=r"Feature\('qvel', 'site:tip'\): a site has no kind 'qvel'"):
        sensorcfg.Feature("qvel", "site:tip")


@pytest.mark.parametrize("method", ["get_observation", "update", "prepare_for_next_control_step",
                                    "observation_spec", "samples_taken"])
def test_runtime_error_before_reset(method: str) -> None:
    with pytest.raises(RuntimeError, match=r"`reset` must be called before"):
        getattr(sensorcfg.Updater({"x": clock_observable()}), method)()


@pytest.mark.parametrize("observables", [[], (), {}, [{}], ({}, {})], ids=repr)
def test_an_updater_without_observables_returns_an_empty_observation(observables) -> None:
    # as dm_control's Updater: the structure given, with nothing in it
    updater = sensorcfg.Updater(observables, 2)
    updater.reset(Clock(), np.random.RandomState(0))
    updater.prepare_for_next_control_step()
    updater.update()
    assert updater.get_observation() == observables
    assert updater.observation_spec() == observables


@pytest.mark.parametrize("schedules", [
    pytest.param([(1, 0, 1), (3, 2, 2), (2, 5, 3)], id="fixed"),
    pytest.param([(1, 0, 1), (lambda: 2, lambda: 1, 2)], id="dm_control-random"),
    pytest.param([(2, 1, 1), (UniformSteps(1, 3), UniformSteps(0, 4), 3)], id="planned"),
])
@pytest.mark.parametrize("n", [1, 4])
def test_control_step_is_prepare_then_each_step_and_update(schedules: list[Any], n: int) -> None:
    """`Updater.control_step(physics_step)` (the Environment's loop, with the per-step work inlined) reads what
    prepare_for_next_control_step() and n x (step, update()) read."""
    def make() -> sensorcfg.Updater:
        return sensorcfg.Updater({f"c{k}": clock_observable(update_interval=i, delay=d, buffer_size=b)
                                  for k, (i, d, b) in enumerate(schedules)}, n)

    clock = Clock()
    expected = [obs for _, obs in run(make(), clock, 150)]
    clock = Clock()
    updater = make()
    updater.reset(clock, np.random.RandomState(0))
    seen = [updater.get_observation()]

    def physics_step() -> None:
        clock.t += 1

    for _ in range(150):
        updater.control_step(physics_step)
        seen.append(updater.get_observation())
    assert updater.step_count == 150 * n and clock.t == 150 * n
    for a, b in zip(seen, expected, strict=True):
        for name in a:
            np.testing.assert_array_equal(a[name], b[name])
