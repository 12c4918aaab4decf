"""Kinds separate simulation state from model constants, and never offer MuJoCo's internal fields."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg.native import NATIVE
from sensorcfg.kinds import CONSTANT, INTERNAL, STATE, kinds_of, offered_kinds, state_twin

from conftest import MODELS


def native_on(type_name: str) -> list[str]:
    """The MuJoCo sensor kinds an element type takes (listed after its own kinds in a message)."""
    return [kind for kind, row in NATIVE.items() if type_name in row.objects]


MODEL = MODELS / "menagerie_like.xml"


def _problems(sensor: str) -> list[str]:
    suite = sensorcfg.loads(f"sensors:\n  s: {sensor}\n", file="s.yaml")
    return [p.format() for p in suite.check(str(MODEL))]


@pytest.mark.parametrize("sensor, message", [
    pytest.param("{kind: quat, element: body:base}",
                 "s.yaml:2:13: error: sensors.s.kind: a body's 'quat' is a model constant (body_quat), not simulation "
                 "state; for the simulated value read 'xquat', or add 'constant: true' to read the constant",
                 id="quat-suggests-xquat"),
    pytest.param("{kind: pos, element: body:base}",
                 "s.yaml:2:13: error: sensors.s.kind: a body's 'pos' is a model constant (body_pos), not simulation "
                 "state; for the simulated value read 'xpos', or add 'constant: true' to read the constant",
                 id="pos-suggests-xpos"),
    pytest.param("{kind: mass, element: body:base}",
                 "s.yaml:2:13: error: sensors.s.kind: a body's 'mass' is a model constant (body_mass), not simulation "
                 "state; add 'constant: true' to read the constant", id="mass"),
    pytest.param("{kind: range, element: joint:fl_hip}",
                 "s.yaml:2:13: error: sensors.s.kind: a joint's 'range' is a model constant (jnt_range), not "
                 "simulation state; add 'constant: true' to read the constant", id="range"),
    pytest.param("{kind: qposadr, element: joint:fl_hip}",
                 "s.yaml:2:13: error: sensors.s.kind: a joint has no kind 'qposadr' (jnt_qposadr is MuJoCo's internal "
                 "bookkeeping, not a value to sense) (did you mean 'qpos'?); joint kinds: cdof, cdof_dot, qacc, "
                 "qacc_smooth, qfrc_actuator, qfrc_adhesion, qfrc_applied, qfrc_bias, qfrc_constraint, qfrc_damper, "
                 "qfrc_fluid, qfrc_gravcomp, qfrc_inverse, qfrc_passive, qfrc_smooth, qfrc_spring, qpos, qvel, "
                 "xanchor, xaxis; MuJoCo sensors on a joint: " + ", ".join(native_on("joint")), id="qposadr-internal"),
    pytest.param("{kind: xpos, element: body:base, constant: true}",
                 "s.yaml:2:49: error: sensors.s.constant: 'xpos' changes with the simulation; 'constant: true' is for "
                 "model constants: remove it", id="constant-on-state"),
    pytest.param("{kind: pso, element: body:base}",
                 "s.yaml:2:13: error: sensors.s.kind: a body has no kind 'pso' (did you mean 'pos', a model constant "
                 "read with 'constant: true'?); body kinds: " + ", ".join(offered_kinds("body", STATE))
                 + "; MuJoCo sensors on a body: " + ", ".join(native_on("body")),
                 id="constant-hint-last"),  # (the list depends on the MuJoCo release: 3.17 has no xiquat)
])
def test_constants_and_internals_are_mistakes_at_the_kind(sensor: str, message: str) -> None:
    assert _problems(sensor) == [message]


def test_constant_true_reads_the_model_value() -> None:
    model = mujoco.MjModel.from_xml_path(str(MODEL))
    suite = sensorcfg.loads("sensors:\n  m: {kind: mass, element: body:base, constant: true}\n")
    env = sensorcfg.Environment(model, suite)
    assert env.reset().observation["m"] == model.body("base").mass[0]


def test_suggestions_prefer_state_and_never_offer_internals() -> None:
    assert sensorcfg.loads("sensors:\n  s: {kind: xpso, element: body:base}\n").check(str(MODEL))[0].message.startswith(
        "a body has no kind 'xpso' (did you mean 'xpos'")
    for type_name in ("body", "joint", "actuator", "tendon", "sensor", "geom", "site"):
        listed = offered_kinds(type_name, STATE) + offered_kinds(type_name, CONSTANT)
        for kind in listed:
            assert not kind.endswith(("adr", "num")) and not kind.startswith(("name_", "efm_")), kind
        assert set(offered_kinds(type_name, INTERNAL)) | set(listed) == set(kinds_of(type_name))
    assert "qLDiagInv" in offered_kinds("joint", INTERNAL) and "efm_K_rowadr" in offered_kinds("joint", INTERNAL)
    assert (state_twin("body", "quat"), state_twin("joint", "qpos0"), state_twin("body", "mass")) == ("xquat", "qpos", None)


def test_every_state_kind_changes_with_the_simulation() -> None:
    """The table's claim, checked: each STATE kind of a moving body or joint changes over an episode (those
    that are inputs or solver outputs at rest are the listed exceptions)."""
    model = mujoco.MjModel.from_xml_path(str(MODEL))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("raised").id)
    physics = sensorcfg.Physics(model, data)
    unchanged_inputs = {"mocap_pos", "mocap_quat", "xfrc_applied", "qfrc_applied", "awake", "qfrc_adhesion",
                        "qfrc_fluid", "qfrc_gravcomp", "qfrc_inverse", "qfrc_spring", "xaxis", "cdof"}
    for type_name, element in (("body", "body:fl_calf"), ("joint", "joint:fl_knee")):
        kinds = [k for k in offered_kinds(type_name, STATE) if k not in unchanged_inputs]
        features = {k: sensorcfg.Feature(k, element) for k in kinds}
        before = {k: np.array(f(physics), copy=True) for k, f in features.items()}
        data.ctrl[:] = 0.8
        mujoco.mj_step(model, data, 200)
        changed = {k for k, f in features.items() if not np.array_equal(f(physics), before[k])}
        assert changed == set(kinds), set(kinds) - changed
