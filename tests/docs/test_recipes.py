"""The recipes of docs/recipes.md name a Menagerie robot, fit it, and read what their comments say.

CI has no Menagerie: each recipe runs on a stand-in of ours with the robot's names and structure
(`tests/models/go2_like.xml`, `g1_like.xml`); with MENAGERIE_ROOT set to a checkout, the same checks run on
the robots themselves. The conventions the recipes write next to their values are pinned here: a foot that
presses on the floor reads a positive normal force and one in the air 0; projected gravity is [0, 0, -1]
upright and R^T [0, 0, -1] when the base turns; and why the recipes do not use `netforce` for feet.
"""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from conftest import MODELS, ROOT, assert_batch_equals_single

# recipe -> (the Menagerie scene its `model:` line names, our stand-in with the same names)
RECIPES = {"quadruped": ("menagerie://unitree_go2/scene.xml", "go2_like.xml"),
           "humanoid": ("menagerie://unitree_g1/scene.xml", "g1_like.xml")}


def _recipe(recipe: str) -> tuple[str, sensorcfg.Suite]:
    """The recipe's `model:` and the recipe without it (Menagerie is not needed to load it)."""
    text = (ROOT / "docs" / "recipes" / f"{recipe}.yaml").read_text()
    line = next(line for line in text.splitlines() if line.startswith("model: "))
    return line.removeprefix("model: "), sensorcfg.loads(text.replace(line, ""), file=f"{recipe}.yaml")


def _robots() -> list[tuple[str, str]]:
    """(recipe, model file): the stand-ins, and the Menagerie robots where MENAGERIE_ROOT has them."""
    out = [(recipe, str(MODELS / like)) for recipe, (_, like) in RECIPES.items()]
    root = os.environ.get("MENAGERIE_ROOT")
    for recipe, (url, _) in RECIPES.items():
        if root and (Path(root) / url.removeprefix("menagerie://")).is_file():
            out.append((recipe, str(Path(root) / url.removeprefix("menagerie://"))))
    return out


def test_each_recipe_names_the_robot_its_stand_in_stands_for() -> None:
    for recipe, (url, like) in RECIPES.items():
        assert _recipe(recipe)[0] == url
        robot = url.removeprefix("menagerie://").split("/")[0].removeprefix("unitree_")
        assert like == f"{robot}_like.xml"
        assert url.removeprefix("menagerie://") in (MODELS / like).read_text()  # its comment says which file


@pytest.mark.parametrize("recipe, model", _robots(), ids=lambda v: Path(v).name)
def test_recipe_validates_and_runs(recipe: str, model: str) -> None:
    suite = _recipe(recipe)[1]
    assert suite.check(model) == []
    env = sensorcfg.Environment(model, suite, seed=0)
    env.reset()
    for _ in range(5):
        obs = env.step(np.zeros(env.action_spec().shape)).observation
    assert set(obs) >= set(suite.sensors)
    assert all(np.all(np.isfinite(v)) for v in obs.values())


@pytest.mark.skipif(int(mujoco.__version__.split(".")[0]) < 4, reason="mujoco.batch needs MuJoCo 4")
@pytest.mark.parametrize("recipe", RECIPES)
def test_recipe_runs_batched_bit_identical_to_single(recipe: str) -> None:
    assert_batch_equals_single(str(MODELS / RECIPES[recipe][1]), _recipe(recipe)[1], nsim=2, seed=3, steps=8)


def _env(recipe: str, model: str | None = None) -> sensorcfg.Environment:
    suite = _recipe(recipe)[1]
    return sensorcfg.Environment(model or str(MODELS / RECIPES[recipe][1]), suite, seed=0)


def _normal_forces(env: sensorcfg.Environment, feet: list[list[int]]) -> np.ndarray:
    """Per foot (a list of geom ids), the normal forces of its contacts with the floor, as MuJoCo computes them."""
    model, data = env.physics.model, env.physics.data
    floor = model.geom("floor").id
    out = []
    for geoms in feet:
        forces = []
        for i, c in enumerate(data.contact):
            if floor in c.geom and set(c.geom) & set(geoms):
                wrench = np.zeros(6)
                mujoco.mj_contactForce(model, data, i, wrench)
                forces.append(wrench[0])
        out.append(sorted(forces, reverse=True))
    return np.array([f + [0.0] * (4 - len(f)) for f in out], dtype=object)


@pytest.mark.parametrize("recipe", RECIPES)
def test_feet_pressing_on_the_floor_read_positive_forces_and_feet_in_the_air_zero(recipe: str) -> None:
    env = _env(recipe)
    model = env.physics.model
    standing = env.reset().observation["feet_contact_force"]
    assert np.all(np.max(np.reshape(standing, (len(standing), -1)), axis=1) > 1.0), standing  # every foot presses
    # the recipe's value is MuJoCo's normal force of each contact (mj_contactForce), never negative
    if recipe == "quadruped":
        feet = [[model.geom(g).id] for g in ("FL", "FR", "RL", "RR")]
        np.testing.assert_allclose(standing, [f[0] for f in _normal_forces(env, feet)], rtol=1e-12)
    else:
        feet = [[g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body(b).id]
                for b in ("left_ankle_roll_link", "right_ankle_roll_link")]
        np.testing.assert_allclose(standing, np.array(_normal_forces(env, feet).tolist(), float), rtol=1e-12)
    # lifted 1 m: the feet stay in the air for the whole control step
    env.physics.data.qpos[2] += 1.0
    env.physics.data.qvel[:] = 0
    mujoco.mj_forward(model, env.physics.data)
    flying = env.step(np.zeros(env.action_spec().shape)).observation["feet_contact_force"]
    assert np.all(flying == 0), flying


def test_netforce_is_the_force_on_the_with_object_so_a_pressing_foot_reads_negative_z() -> None:
    """Why the recipes read the normal force: `reduce: netforce` gives the world-frame force on the `with:`
    object. A foot pressing on the floor pushes the floor down; with the sides swapped it reads the floor's
    push on the foot (+z)."""
    suite = sensorcfg.loads("""\
options: {keyframe: home, strip_singleton_buffer_dim: true}
sensors:
  on_floor: {kind: contact, element: geom:FL, with: geom:floor, data: [force], reduce: netforce}
  on_foot: {kind: contact, element: geom:floor, with: geom:FL, data: [force], reduce: netforce}
  normal: {kind: contact, element: geom:FL, with: geom:floor, data: [force], reduce: maxforce, index: 0}
""")
    obs = sensorcfg.Environment(str(MODELS / "go2_like.xml"), suite, seed=0).reset().observation
    assert obs["normal"] > 1.0
    assert obs["on_floor"][2] < -1.0 and obs["on_foot"][2] > 1.0
    np.testing.assert_allclose(obs["on_floor"], -obs["on_foot"], rtol=1e-12)


def test_found_counts_a_contact_within_the_margin_that_carries_no_force(tmp_path: Path) -> None:
    """Why the recipes do not read `found` as "the foot presses": a foot 5 mm above the floor, within its
    1 cm margin and rising, is a contact MuJoCo lists (found 1) with no force."""
    model = tmp_path / "margin.xml"
    model.write_text('<mujoco><worldbody><geom name="floor" type="plane" size="1 1 .1"/>'
                     '<body pos="0 0 .055"><freejoint/><geom name="foot" type="sphere" size=".05" margin=".01"/>'
                     '</body></worldbody></mujoco>')
    suite = sensorcfg.loads("options: {strip_singleton_buffer_dim: true}\nsensors:\n"
                            "  c: {kind: contact, element: geom:foot, with: geom:floor, data: [found, force], "
                            "reduce: maxforce}\n")
    env = sensorcfg.Environment(str(model), suite, seed=0)
    env.reset()
    env.physics.data.qvel[2] = 1.0
    mujoco.mj_forward(env.physics.model, env.physics.data)
    found, normal = suite.build(env.physics.model)["c"].observation_callable(env.physics)()[:2]
    assert (found, normal) == (1.0, 0.0)


@pytest.mark.parametrize("recipe, site", [("quadruped", "imu"), ("humanoid", "imu_in_pelvis")])
def test_projected_gravity_is_minus_z_upright_and_turns_with_the_base(recipe: str, site: str) -> None:
    env = _env(recipe)
    clean = "projected_gravity_clean" if recipe == "quadruped" else None
    obs = env.reset().observation
    if clean:
        np.testing.assert_allclose(obs[clean], [0, 0, -1], atol=1e-12)  # Go2's home pose is level
    data = env.physics.data
    angle = np.deg2rad(30)  # pitch the base nose down (about its +y axis): gravity gains +x
    data.qpos[3:7] = [np.cos(angle / 2), 0, np.sin(angle / 2), 0]
    data.qpos[2] += 1.0
    data.qvel[:] = 0
    mujoco.mj_forward(env.physics.model, data)
    suite = sensorcfg.loads(f"options: {{strip_singleton_buffer_dim: true}}\nsensors:\n"
                            f"  g: {{kind: gravity, element: site:{site}}}\n")
    model = suite.compile(str(MODELS / RECIPES[recipe][1]))
    mine = mujoco.MjData(model)
    mine.qpos[:] = data.qpos
    mujoco.mj_forward(model, mine)
    value = suite.build(model)["g"].observation_callable(sensorcfg.physics.Physics(model, mine))()
    rot = mine.site(site).xmat.reshape(3, 3)
    np.testing.assert_allclose(value, rot.T @ [0, 0, -1], atol=1e-12)
    assert value[0] > 0.45 and value[2] < -0.8
    step = env.step(np.zeros(env.action_spec().shape)).observation
    if clean:  # the twin is sampled at the read: the site's orientation then
        np.testing.assert_allclose(step[clean], data.site(site).xmat.reshape(3, 3).T @ [0, 0, -1], atol=1e-12)


# The recipes' observations of the joints, each to line up with the actions (actuator i's joint at i).
PAIRED = {"quadruped": ("joint_pos", "joint_vel"), "humanoid": ("joint_pos", "joint_vel")}


def _pairs(model: mujoco.MjModel) -> list[tuple[str, str]]:
    """(actuator, the joint its transmission drives), in actuator order."""
    return [(model.actuator(i).name, model.joint(int(model.actuator_trnid[i, 0])).name) for i in range(model.nu)]


@pytest.mark.parametrize("recipe, model", _robots(), ids=lambda v: Path(v).name)
def test_recipe_joint_observations_line_up_with_the_actions(recipe: str, model: str) -> None:
    """Found by trying it: the Go2 recipe listed the legs FR, FL, RR, RL as "Go2's actuator order", which
    Menagerie's Go2 stopped being in February 2025, so `joint_pos[0:3]` was the FR leg while `last_action[0:3]`
    drove FL. Each value i of a joint observation is the joint actuator i drives (MuJoCo's `actuator_trnid`)."""
    text = (ROOT / "docs" / "recipes" / f"{recipe}.yaml").read_text()
    text = "\n".join(line for line in text.splitlines() if not line.startswith(("model: ", "    noise: ")))
    suite = sensorcfg.loads(text, file=f"{recipe}.yaml")
    compiled = suite.compile(model)
    key = next(i for i in range(compiled.nkey) if compiled.key(i).name == suite.options.keyframe)
    compiled.key_qpos[key, 7:] = np.linspace(-0.5, 0.5, compiled.nq - 7)  # every joint its own value
    compiled.key_qvel[key, 6:] = np.linspace(1.0, 2.0, compiled.nv - 6)
    obs = sensorcfg.Environment(compiled, suite, seed=0).reset().observation
    joints = compiled.actuator_trnid[:, 0]
    assert set(compiled.actuator_trntype.tolist()) == {int(mujoco.mjtTrn.mjTRN_JOINT)}
    expected = {"qpos": compiled.key_qpos[key][compiled.jnt_qposadr[joints]],
                "qvel": compiled.key_qvel[key][compiled.jnt_dofadr[joints]]}
    for name in PAIRED[recipe]:
        np.testing.assert_array_equal(obs[name], expected[suite.sensors[name].kind], err_msg=name)
    if "last_action" in suite.sensors:
        assert suite.sensors["last_action"].element == "actuator:*"


def test_stand_ins_drive_the_joints_the_robots_actuators_drive() -> None:
    """The stand-ins' actuators are today's Menagerie's (Go2 since its 2025-02-16 change: actuators in joint
    order, FL FR RL RR; G1: its joints' order); where MENAGERIE_ROOT has the robots, checked against them."""
    for recipe, (url, like) in RECIPES.items():
        stand_in = mujoco.MjModel.from_xml_path(str(MODELS / like))
        hinges = [stand_in.joint(j).name for j in range(stand_in.njnt) if stand_in.jnt_type[j] != 0]
        assert [joint for _, joint in _pairs(stand_in)] == hinges, like
        assert all(actuator == joint.removesuffix("_joint") or actuator == joint for actuator, joint in _pairs(stand_in))
        robot = Path(os.environ.get("MENAGERIE_ROOT", "/nonexistent")) / url.removeprefix("menagerie://")
        if robot.is_file():
            assert _pairs(stand_in) == _pairs(mujoco.MjModel.from_xml_path(str(robot))), like


def test_recipes_page_shows_the_files() -> None:
    page = (ROOT / "docs" / "recipes.md").read_text()
    for recipe in RECIPES:
        text = (ROOT / "docs" / "recipes" / f"{recipe}.yaml").read_text()
        body = text[text.index("version: 1"):]
        assert body in page, f"docs/recipes.md does not show docs/recipes/{recipe}.yaml as it is"
