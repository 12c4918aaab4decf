"""`model: menagerie://<robot>/<file>` resolves through the mujoco-menagerie package, honouring MENAGERIE_ROOT.

The test environments have neither Menagerie nor the package (and no network): a robot folder of our own
under a temporary MENAGERIE_ROOT stands in for a checkout when the package is installed, and a missing
package must be a positioned problem that names it. The legged examples run on stand-ins with their robots'
names and structure (`tests/models/h1_like.xml`, `anymal_c_like.xml`), where the signs their comments state
are checked; with MENAGERIE_ROOT naming a checkout, every example runs on its robot.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import SuiteError

from conftest import MODELS, ROOT

MODEL = MODELS / "menagerie_like.xml"
SUITE = "model: menagerie://anybotics_anymal_c/scene.xml\nsensors:\n  q: {kind: qpos, element: 'joint:*'}\n"


def test_a_missing_package_is_a_problem_at_the_model_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "mujoco_menagerie", None)  # import fails as if not installed
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    with pytest.raises(SuiteError) as e:
        sensorcfg.loads(SUITE, file="s.yaml")
    assert [p.format() for p in e.value.problems] == [
        "s.yaml:1:8: error: model: a menagerie:// model is found through the 'mujoco-menagerie' package, which is "
        "not installed: pip install mujoco-menagerie (or, from a sensorcfg clone, pip install '.[menagerie]'); set "
        "MENAGERIE_ROOT to a Menagerie "
        "checkout to use it instead of the package's download cache"]


@pytest.mark.parametrize(("made", "missing"), [
    pytest.param((), "; MENAGERIE_ROOT ({root}) has no folder 'anybotics_anymal_c' either: point it at a Menagerie "
                 "checkout", id="no-robot-folder"),
    pytest.param(("anybotics_anymal_c",), "; {root}/anybotics_anymal_c has no file 'scene.xml' either",
                 id="no-file"),
])
def test_a_missing_package_with_menagerie_root_set_says_what_is_missing(
        made: tuple[str, ...], missing: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """MENAGERIE_ROOT is read by the package, so with it set the fix is the package (and what the checkout
    lacks of the robot), not setting MENAGERIE_ROOT."""
    monkeypatch.setitem(sys.modules, "mujoco_menagerie", None)
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    for folder in made:
        (tmp_path / folder).mkdir()
    with pytest.raises(SuiteError) as e:
        sensorcfg.loads(SUITE, file="s.yaml")
    assert [p.format() for p in e.value.problems] == [
        "s.yaml:1:8: error: model: a menagerie:// model is found through the 'mujoco-menagerie' package, which reads "
        "MENAGERIE_ROOT but is not installed: pip install mujoco-menagerie (or, from a sensorcfg clone, pip install "
        "'.[menagerie]')" + missing.format(root=tmp_path)]


def test_a_missing_package_with_the_robot_under_menagerie_root_names_only_the_package(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "mujoco_menagerie", None)
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    (tmp_path / "anybotics_anymal_c").mkdir()
    shutil.copy(MODEL, tmp_path / "anybotics_anymal_c" / "scene.xml")
    with pytest.raises(SuiteError) as e:
        sensorcfg.loads(SUITE, file="s.yaml")
    assert [p.message for p in e.value.problems] == [
        f"a menagerie:// model is found through the 'mujoco-menagerie' package, which reads MENAGERIE_ROOT "
        f"({tmp_path}, where anybotics_anymal_c/scene.xml is) but is not installed: pip install mujoco-menagerie "
        "(or, from a sensorcfg clone, pip install '.[menagerie]')"]


@pytest.mark.parametrize("model", ["menagerie://anybotics_anymal_c", "menagerie:///scene.xml"])
def test_a_menagerie_model_names_a_robot_folder_and_a_file(model: str, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(SuiteError, match=r"names no file; write 'menagerie://<robot folder>/<file>', for example "
                       r"'menagerie://unitree_go2/scene.xml'"):
        sensorcfg.loads(SUITE.replace("menagerie://anybotics_anymal_c/scene.xml", model))


@pytest.fixture
def menagerie_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    pytest.importorskip("mujoco_menagerie", reason="the optional extra 'menagerie' is not installed here")
    robot = tmp_path / "anybotics_anymal_c"
    robot.mkdir()
    shutil.copy(MODEL, robot / "scene.xml")
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    return tmp_path


def test_the_package_resolves_the_robot_under_menagerie_root(menagerie_root: Path) -> None:
    suite = sensorcfg.loads(SUITE)
    assert suite.model == str(menagerie_root / "anybotics_anymal_c" / "scene.xml")
    assert suite.check() == []


def test_package_errors_are_problems_at_the_model_line(menagerie_root: Path) -> None:
    with pytest.raises(SuiteError, match=r"s.yaml:1:8: error: model: mujoco-menagerie cannot provide "
                       r"'menagerie://anybotics_anymal/scene.xml': Unknown robot 'anybotics_anymal'. Did you mean "
                       r"'anybotics_anymal_c'\?"):
        sensorcfg.loads(SUITE.replace("anymal_c", "anymal"), file="s.yaml")
    with pytest.raises(SuiteError, match=r"'anybotics_anymal_c' has no file 'scene_x.xml'"):
        sensorcfg.loads(SUITE.replace("scene.xml", "scene_x.xml"), file="s.yaml")


SUITES = sorted((ROOT / "examples" / "menagerie").glob("*.yaml"))


def test_there_is_a_menagerie_suite_per_robot_class() -> None:
    assert [p.stem.split("_")[0] for p in SUITES] == ["arm", "hand", "humanoid", "quadruped"]


@pytest.mark.parametrize("path", SUITES, ids=[p.stem for p in SUITES])
def test_menagerie_suites_name_a_robot_and_pass_the_schema(path: Path) -> None:
    """Without Menagerie here, the suites are checked up to their model: syntax, schema, units."""
    text = path.read_text()
    model_line = next(line for line in text.splitlines() if line.startswith("model: "))
    assert model_line.startswith("model: menagerie://")
    suite = sensorcfg.loads(text.replace(model_line, ""), file=path.name)
    assert suite.sensors and suite.model is None


@pytest.mark.parametrize("path", SUITES, ids=[p.stem for p in SUITES])
def test_menagerie_suites_fit_their_robots_where_a_checkout_is_here(path: Path) -> None:
    """With MENAGERIE_ROOT naming a Menagerie checkout, each suite validates and runs on the robot its
    `model:` line names (names, keyframes, element types), read straight from the checkout."""
    text = path.read_text()
    model_line = next(line for line in text.splitlines() if line.startswith("model: "))
    root = os.environ.get("MENAGERIE_ROOT")
    robot = Path(root or ".") / model_line.removeprefix("model: menagerie://")
    if not root or not robot.is_file():
        pytest.skip("MENAGERIE_ROOT does not name a Menagerie checkout with this robot")
    suite = sensorcfg.loads(text.replace(model_line, ""), file=path.name)
    assert suite.check(str(robot)) == []
    env = sensorcfg.Environment(str(robot), suite, seed=0)
    env.reset()
    for _ in range(5):
        obs = env.step(np.zeros(env.action_spec().shape)).observation
    assert all(np.all(np.isfinite(v)) for v in obs.values())


# example -> our stand-in with the names and structure of the robot its `model:` line names
STAND_INS = {"humanoid_unitree_h1": "h1_like.xml", "quadruped_anymal_c": "anymal_c_like.xml"}


def _on_stand_in(stem: str) -> sensorcfg.Environment:
    path = next(p for p in SUITES if p.stem == stem)
    text = path.read_text()
    model_line = next(line for line in text.splitlines() if line.startswith("model: "))
    robot = model_line.removeprefix("model: menagerie://").split("/")[0].removeprefix("unitree_")
    stand_in = STAND_INS[stem]
    assert stand_in.startswith(robot.removeprefix("anybotics_"))
    suite = sensorcfg.loads(text.replace(model_line, ""), file=path.name)
    assert suite.check(str(MODEL.parent / stand_in)) == []
    return sensorcfg.Environment(str(MODEL.parent / stand_in), suite, seed=0)


@pytest.mark.parametrize("stem", STAND_INS)
def test_legged_examples_read_feet_forces_up_while_standing_and_zero_in_the_air(stem: str) -> None:
    env = _on_stand_in(stem)
    obs = env.reset().observation
    assert obs["feet_force"].shape == ((2,) if stem == "humanoid_unitree_h1" else (4,))
    assert np.all(obs["feet_force"] > 1.0), obs["feet_force"]  # cfrc_ext's z: the floor pushes the feet up
    env.physics.data.qpos[2] += 1.0
    env.physics.data.qvel[:] = 0
    mujoco.mj_forward(env.physics.model, env.physics.data)
    flying = env.step(np.zeros(env.action_spec().shape)).observation["feet_force"]
    assert np.all(flying == 0), flying


def test_the_h1_example_reads_gravity_down_in_the_imu_frame() -> None:
    env = _on_stand_in("humanoid_unitree_h1")
    obs = env.reset().observation
    np.testing.assert_allclose(obs["projected_gravity"], [0, 0, -1], atol=1e-12)  # `home` stands upright
    assert obs["joint_pos"].shape == (19,)


def test_a_menagerie_model_stays_in_its_robot_folder(menagerie_root: Path) -> None:
    (menagerie_root / "secret.xml").write_text("<mujoco/>")
    (menagerie_root / "anybotics_anymal_c" / "link.xml").symlink_to(menagerie_root / "secret.xml")
    folder = menagerie_root / "anybotics_anymal_c"
    for inner in ("../secret.xml", "link.xml", "../../../../etc/passwd"):
        model = f"menagerie://anybotics_anymal_c/{inner}"
        with pytest.raises(SuiteError) as e:
            sensorcfg.loads(SUITE.replace("menagerie://anybotics_anymal_c/scene.xml", model), file="s.yaml")
        assert [p.format() for p in e.value.problems] == [
            f"s.yaml:1:8: error: model: {model!r} leaves the folder of the Menagerie robot 'anybotics_anymal_c' "
            f"({folder}); a menagerie:// model is a file inside it, named without '..' and not through a symlink "
            "out of it"]


def test_menagerie_names_the_model_of_every_entry_point(menagerie_root: Path, tmp_path: Path) -> None:
    """`--model`, `make_env(model=...)`, Environment, BatchEnvironment and Suite.check/compile take a menagerie:// name as a suite's
    `model:` line does: one resolver."""
    import mujoco

    name = "menagerie://anybotics_anymal_c/scene.xml"
    path = str(menagerie_root / "anybotics_anymal_c" / "scene.xml")
    suite_file = tmp_path / "s.yaml"
    suite_file.write_text(SUITE.replace(f"model: {name}\n", ""))
    env = sensorcfg.make_env(suite_file, model=name)
    assert env.physics.model.nq == mujoco.MjModel.from_xml_path(path).nq
    assert sensorcfg.Environment(name, sensorcfg.load(suite_file)).reset().observation["q"].shape
    assert sensorcfg.load(suite_file).check(name) == []
    assert sensorcfg.load(suite_file).compile(name).nq == env.physics.model.nq
    if int(mujoco.__version__.split(".")[0]) >= 4:
        batch = sensorcfg.BatchEnvironment(name, str(suite_file), 2)
        assert batch.reset().observation["q"].shape[0] == 2
    from sensorcfg.cli import main

    assert main(["validate", str(suite_file), "--model", name]) == 0
    assert main(["spec", str(suite_file), "--model", name]) == 0


def test_package_mujoco_menagerie_points_at_the_menagerie_scheme() -> None:
    with pytest.raises(SuiteError) as e:
        sensorcfg.loads(SUITE.replace("menagerie://", "package://mujoco_menagerie/"), file="s.yaml")
    assert [p.format() for p in e.value.problems] == [
        "s.yaml:1:8: error: model: Menagerie robots are named menagerie://<robot folder>/<file>, not through a "
        "package; write 'menagerie://anybotics_anymal_c/scene.xml'"]


def test_a_failed_download_suggests_menagerie_root(monkeypatch: pytest.MonkeyPatch) -> None:
    menagerie = pytest.importorskip("mujoco_menagerie", reason="the optional extra 'menagerie' is not installed here")

    def offline(self: object, cache: object = None, progress: object = None) -> Path:
        raise menagerie.DownloadError("https://example.invalid/anymal.tar.xz: <urlopen error [Errno -2] Name or "
                                      "service not known>")

    monkeypatch.setattr(menagerie.Robot, "path", offline)
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    with pytest.raises(SuiteError) as e:
        sensorcfg.loads(SUITE, file="s.yaml")
    assert [p.format() for p in e.value.problems] == [
        "s.yaml:1:8: error: model: mujoco-menagerie cannot provide 'menagerie://anybotics_anymal_c/scene.xml': "
        "https://example.invalid/anymal.tar.xz: <urlopen error [Errno -2] Name or service not known>; without a "
        "network, set MENAGERIE_ROOT to a Menagerie checkout (git clone "
        "https://github.com/google-deepmind/mujoco_menagerie)"]


def test_a_model_given_replaces_the_suite_model_line_unresolved(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """`--model` and an environment's `model` run the suite on the model given: its own `model:` line (here a
    Menagerie robot that cannot be downloaded) is not resolved, so the recipes run offline on a stand-in."""
    menagerie = pytest.importorskip("mujoco_menagerie", reason="the optional extra 'menagerie' is not installed here")

    def offline(self: object, cache: object = None, progress: object = None) -> Path:
        raise menagerie.DownloadError("no network")

    monkeypatch.setattr(menagerie.Robot, "path", offline)
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    suite = tmp_path / "s.yaml"
    suite.write_text(SUITE)
    with pytest.raises(SuiteError, match="cannot provide"):
        sensorcfg.load(suite)  # the line alone still says what is wrong
    from sensorcfg.cli import main

    for command in (["validate"], ["spec"], ["run", "--steps", "1"]):
        assert main([command[0], str(suite), "--model", str(MODEL), *command[1:]]) == 0, capsys.readouterr()
    env = sensorcfg.make_env(suite, model=str(MODEL))
    assert env.reset().observation["q"].shape == (1, mujoco.MjModel.from_xml_path(str(MODEL)).nq)  # a buffer of 1
