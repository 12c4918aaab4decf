"""Random sensor suites for the differential fuzzers: `runtime/test_engine_fuzz.py` (the CPU engines) and
`warp/test_warp_fuzz.py` (the Warp engine against them).

`KINDS` holds the sensors both draw on the bundled robot (`WARP_KINDS`: those the Warp fuzzer draws, in its
order); `Draws` draws a suite's parts (parameters, schedules, noise stages and chains, sensors) as the CPU fuzzer
does, and the Warp fuzzer's subclass (`test_warp_fuzz.WarpDraws`) overrides the odds and recipes it draws
otherwise; `suite_text` writes a suite. A test imports them by name (`from fuzz_suites import KINDS`: tests/ is
importable as for `conftest`). A seed names its suites: a change here (to a draw, the order of draws or a table's
order) changes the suite every seed draws.
"""

from __future__ import annotations

import json
from typing import Any, NamedTuple

import numpy as np


class Kind(NamedTuple):
    """A sensor a fuzzer draws: its kind, element and extra keys, whether its values are 3-vectors (misalign
    turns them), and `warp`: its place in `WARP_KINDS` (None: the Warp fuzzer does not draw it)."""

    kind: str
    element: Any
    extra: dict[str, Any]
    vector: bool
    warp: int | None = None


# the draws pick a kind by its place: reordering either fuzzer's kinds changes its suites
KINDS: list[Kind] = [
    Kind("qpos", ["joint:shoulder", "joint:elbow"], {}, False, 0),
    Kind("qpos", "joint:wrist", {}, False, 1),
    Kind("qvel", "joint:elbow", {}, False, 2),
    Kind("qvel", "joint:wrist", {}, True, 3),
    Kind("qacc", ["joint:shoulder", "joint:finger_slide"], {}, False, 4),
    Kind("qfrc_actuator", ["joint:shoulder", "joint:elbow"], {}, False),
    Kind("xpos", "site:hand_site", {}, True, 5),
    Kind("xpos", ["site:hand_site", "site:imu"], {}, True, 6),
    Kind("xpos", "body:hand", {}, True, 7),
    Kind("xquat", "body:hand", {}, False, 8),
    Kind("xmat", "body:forearm", {}, False, 9),  # (9,): no 3-vector axis
    Kind("cvel", "body:forearm", {}, False),  # (6,): no 3-vector axis
    Kind("cacc", "body:hand", {}, False),  # computed on demand
    Kind("cfrc_int", "body:forearm", {}, False),  # computed on demand
    Kind("sensordata", "sensor:imu_gyro", {}, True),
    Kind("sensordata", "sensor:imu_accel", {}, True, 10),
    Kind("sensordata", ["sensor:shoulder_pos", "sensor:elbow_pos"], {}, False),
    Kind("force", "actuator:*", {}, True, 11),
    Kind("ctrl", ["actuator:shoulder_motor", "actuator:elbow_motor"], {}, False, 12),
    Kind("gyro", "site:imu", {}, True, 13),
    Kind("accelerometer", "site:hand_site", {}, True, 22),
    Kind("velocimeter", "site:imu", {}, True, 21),
    Kind("framepos", "site:fingertip", {"frame": "body:base"}, True, 14),
    Kind("framequat", "body:hand", {}, False, 23),
    Kind("jointpos", "joint:elbow", {}, False, 15),
    Kind("gravity", "site:imu", {}, True, 16),
    Kind("subtreecom", "body:upper_arm", {}, True, 17),
    Kind("subtreelinvel", "body:upper_arm", {}, True, 24),
    Kind("xpos", "body:hand", {"index": 2}, False, 18),
    Kind("xpos", ["site:hand_site", "site:imu", "site:fingertip"], {"index": "0:2"}, True, 19),
    Kind("qvel", "joint:*", {"within": "body:upper_arm", "index": [0, 2]}, False, 20),
]
_WARP = {k.warp: k for k in KINDS if k.warp is not None}
WARP_KINDS: list[Kind] = [_WARP[place] for place in range(len(_WARP))]  # (a KeyError: a place repeated or left out)

ADDITIVE = ("gaussian", "uniform", "outlier", "random_walk", "bias")  # adjacent additive stages fuse into one sum
STAGES = ("gaussian", "uniform", "outlier", "bias", "scale", "random_walk", "quantize", "clip", "lowpass",
          "dropout")


def suite_text(sensors: dict[str, Any], options: dict[str, Any], defaults: dict[str, Any] | None = None) -> str:
    """A suite's YAML text (JSON, which YAML reads): its options (in the order given) and sensors, and
    `defaults` where given."""
    suite: dict[str, Any] = {"version": 1, "options": options, "sensors": sensors}
    if defaults is not None:
        suite["defaults"] = defaults
    return json.dumps(suite, indent=1)


class Draws:
    """The parts of a random suite drawn from `rng`, as the CPU engines' fuzzer draws them. The class attributes
    are the odds and features in which another fuzzer's draws differ (a subclass sets its own)."""

    drawn: float = 0.25  # how often a noise parameter is drawn per episode (`{uniform: [a, b]}`)
    stages: tuple[str, ...] = STAGES  # the noise stage types, in the order the draws pick them by
    # a schedule (`schedule`): its range three times as long `long` of the time; then, by a uniform number, below
    # `constant` a constant number of steps, below `timed` a duration (or, `rate` of the time where it can be one,
    # a rate), below 0.8 `{uniform}`, else a `{choice}` of steps reaching `beyond` past the range
    long: float = 0.0
    constant: float = 0.4
    timed: float = 0.55
    rate: float = 0.4
    beyond: int = 1
    # a sensor (`sensor`): how often it has an interval, a delay, a buffer of 1-4 (else 1-8) and, noisy, a clean
    # twin (`maybe`: 1 always and 0 never, without a draw), and the aggregators picked from
    interval: float = 0.85
    delay: float = 0.8
    short_buffer: float = 1.0
    twin: float = 0.0
    aggregators: tuple[str | None, ...] = (None, None, "mean", "sum", "max", "min", "median")
    # noise stages (`stage`): whether a duration or rate is written with its unit ("50ms", "20Hz"), a gaussian on
    # a constant interval is a density now and then, a bias has a mean now and then, and a lowpass on a drawn
    # interval may have its cutoff drawn per episode
    units: bool = True
    density: bool = True
    bias_mean: bool = True
    drawn_cutoff: bool = True

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def maybe(self, p: float) -> bool:
        """True with probability `p`: always at 1 and never at 0, drawing nothing then."""
        return p >= 1 or (p > 0 and self.rng.random() < p)

    def number(self, low: float, high: float, drawn: float | None = None) -> Any:
        """A parameter in [low, high], drawn per episode (`{uniform: [a, b]}`) with probability `drawn`
        (`self.drawn` by default)."""
        rng = self.rng
        if rng.random() < (self.drawn if drawn is None else drawn):
            a, b = sorted(rng.uniform(low, high, 2).round(4).tolist())
            return {"uniform": [a, b]}
        return round(float(rng.uniform(low, high)), 4)

    def schedule(self, low: int, high: int, rate: bool = False) -> Any:
        """A constant number of physics steps in [low, high] (as steps, a duration or, with `rate`, a rate), or
        drawn per sample."""
        rng = self.rng
        if self.maybe(self.long):  # long ones now and then
            high = 3 * high
        r = rng.random()
        if r < self.constant:
            return int(rng.integers(low, high + 1))
        if r < self.timed:  # the robot's timestep is 2 ms
            steps = int(rng.integers(low, high + 1))
            hertz = rate and steps and 500 % steps == 0 and rng.random() < self.rate
            return f"{500 // steps}Hz" if hertz else f"{2 * steps}ms"
        if r < 0.8:
            a = int(rng.integers(low, high + 1))
            return {"uniform": [a, int(rng.integers(a, high + 2))]}
        values = sorted({int(v) for v in rng.integers(low, high + 1 + self.beyond, int(rng.integers(1, 4)))})
        out: dict[str, Any] = {"choice": values}
        if len(values) > 1 and rng.random() < 0.5:
            p = rng.dirichlet(np.ones(len(values))).round(3)
            p[-1] = round(1.0 - float(p[:-1].sum()), 3)
            if (p > 0).all():
                out["p"] = p.tolist()
        return out

    def stage(self, kind: str, fixed: bool) -> dict[str, Any]:
        """One noise stage of type `kind` with random parameters (some drawn per episode); `fixed`: the sensor's
        interval is constant (a noise density needs one)."""
        rng, n = self.rng, self.number
        if kind == "gaussian":
            out: dict[str, Any] = ({"std": n(0.001, 0.05)} if not (self.density and fixed) or rng.random() < 0.8
                                   else {"density": n(0.0005, 0.002)})
            if rng.random() < 0.3:
                out["mean"] = n(-0.01, 0.01)
        elif kind == "uniform":  # the two ends' ranges never cross
            out = {"low": n(-0.05, -0.01), "high": n(0.01, 0.05)}
        elif kind == "bias":
            out = {"std": n(0.01, 0.2)} if rng.random() < 0.6 else {"low": n(-0.2, -0.1), "high": n(0.1, 0.2)}
            if self.bias_mean and "std" in out and rng.random() < 0.3:
                out["mean"] = n(-0.05, 0.05)
        elif kind == "scale":
            out = {"low": n(0.8, 0.95), "high": n(1.05, 1.2)} if rng.random() < 0.5 else \
                {"mean": n(0.95, 1.05), "std": n(0.0, 0.05)}
        elif kind == "random_walk":
            out = {"std": n(0.001, 0.05)}
            if rng.random() < 0.6:
                out["correlation_time"] = (f"{int(rng.integers(5, 200))}ms" if self.units and rng.random() < 0.5
                                           else n(0.005, 0.2))
        elif kind == "quantize":
            out = {"step": n(0.0005, 0.01)}
        elif kind == "clip":
            out = {"min": n(-1.0, -0.2), "max": n(0.2, 1.0)}
            if rng.random() < 0.3:
                out.pop(str(rng.choice(["min", "max"])))
        elif kind == "dropout":
            out = {"p": n(0.05, 0.6), "mode": str(rng.choice(["hold", "zero", "nan"]))}
            if rng.random() < 0.4:
                out["per"] = "value"
        elif kind == "outlier":
            out = {"p": n(0.02, 0.3), "scale": n(0.1, 2.0)}
        elif kind == "lowpass":
            out = {"cutoff": f"{int(rng.integers(2, 80))}Hz" if self.units and rng.random() < 0.5 else
                   n(2.0, 80.0, None if fixed or self.drawn_cutoff else 0.0)}
        else:
            raise AssertionError(kind)
        return {"type": kind, **out}

    def noise(self, vector: bool, fixed: bool) -> list[dict[str, Any]]:
        """1-4 stages, now and then a run of 2-3 adjacent additive ones (fused into one sum), and on 3-vectors a
        misalign or two somewhere in the chain (`misaligned`)."""
        rng = self.rng
        if rng.random() < 0.25:
            kinds = [str(k) for k in rng.choice(ADDITIVE, int(rng.integers(2, 4)))]
            kinds.insert(int(rng.integers(len(kinds) + 1)), str(rng.choice(self.stages)))
        else:
            kinds = [str(k) for k in rng.choice(self.stages, int(rng.integers(1, 5)))]
        return self.misaligned([self.stage(k, fixed) for k in kinds], vector)

    def misaligned(self, stages: list[dict[str, Any]], vector: bool) -> list[dict[str, Any]]:
        """`stages` with, on 3-vectors half of the time, 1-2 misaligns (`misalign`) inserted anywhere."""
        for _ in range(int(self.rng.integers(1, 3)) if vector and self.rng.random() < 0.5 else 0):
            turn = self.misalign()
            stages.insert(int(self.rng.integers(len(stages) + 1)), turn)
        return stages

    def misalign(self) -> dict[str, Any]:
        """A misalign stage: an angle (in degrees or radians), a cross-axis matrix, or both."""
        rng = self.rng
        turn: dict[str, Any] = {"type": "misalign"}
        if rng.random() < 0.8:
            turn["std"] = f"{round(float(rng.uniform(0.5, 5.0)), 2)}deg" if rng.random() < 0.5 else \
                round(float(rng.uniform(0.01, 0.1)), 3)
        if rng.random() < 0.4:
            turn["matrix"] = self.cross_axis()
        if len(turn) == 1:
            turn["std"] = 0.05
        return turn

    def cross_axis(self) -> list[list[float]]:
        """A misalign's cross-axis matrix: the identity, slightly off."""
        return (np.eye(3) + self.rng.normal(0, 0.02, (3, 3))).round(3).tolist()

    def sensor(self, name: str, kinds: list[Kind], strip: bool) -> dict[str, Any]:
        """The entry of sensor `name`, of one of `kinds`: its schedule, buffer, aggregator, noise (3 times in 4)
        and clean twin; `strip`: the suite's strip_singleton_buffer_dim."""
        rng = self.rng
        kind = kinds[int(rng.integers(len(kinds)))]
        entry: dict[str, Any] = {"kind": kind.kind, "element": kind.element, **kind.extra}
        if self.maybe(self.interval):
            entry["interval"] = self.schedule(1, 4, rate=True)
        if self.maybe(self.delay):
            entry["delay"] = self.schedule(0, 5)
        buffer = int(rng.integers(1, 5 if self.maybe(self.short_buffer) else 9))
        if buffer > 1 or rng.random() < 0.2:
            entry["buffer"] = buffer
        aggregator = self.aggregators[int(rng.integers(len(self.aggregators)))]
        if aggregator and not (strip and buffer == 1):  # (no buffer axis to reduce: refused)
            entry["aggregator"] = aggregator
        if rng.random() < 0.75:
            entry["noise"] = self.noise(kind.vector, not isinstance(entry.get("interval"), dict))
            if self.maybe(self.twin):
                entry["twin"] = f"{name}_clean"
        return entry

    def sensors(self, kinds: list[Kind], strip: bool) -> dict[str, Any]:
        """2-6 sensors (`sensor`) named s0, s1, ..."""
        return {f"s{j}": self.sensor(f"s{j}", kinds, strip) for j in range(int(self.rng.integers(2, 7)))}
