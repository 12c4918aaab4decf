"""The recipes of docs/recipes.md validate and run on small models of ours with the same names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sensorcfg

ROOT = Path(__file__).resolve().parent.parent
MODELS = Path(__file__).parent / "models"


@pytest.mark.parametrize("recipe, model", [("quadruped", "terrain.xml"), ("humanoid", "biped.xml")])
def test_recipe_validates_and_runs(recipe: str, model: str) -> None:
    path = ROOT / "docs" / "recipes" / f"{recipe}.yaml"
    suite = sensorcfg.load(path)
    assert suite.check(str(MODELS / model)) == []
    env = sensorcfg.Environment(str(MODELS / model), suite, seed=0)
    env.reset()
    for _ in range(5):
        obs = env.step(np.zeros(env.action_spec().shape)).observation
    assert set(obs) == set(suite.sensors)
    assert all(np.all(np.isfinite(v)) for v in obs.values())


def test_recipes_page_shows_the_files() -> None:
    page = (ROOT / "docs" / "recipes.md").read_text()
    for recipe in ("quadruped", "humanoid"):
        text = (ROOT / "docs" / "recipes" / f"{recipe}.yaml").read_text()
        body = text[text.index("version: 1"):]
        assert body in page, f"docs/recipes.md does not show docs/recipes/{recipe}.yaml as it is"
