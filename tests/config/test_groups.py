"""Observation groups: members in a stated, stable column order, checked at their lines, laid out by shape."""

from __future__ import annotations

import numpy as np
import pytest

import sensorcfg
from sensorcfg.groups import layout

SENSORS = """sensors:
  a: {kind: qpos, element: "joint:*", twin: a_clean}
  b: {kind: qvel, element: "joint:*"}
  cam: {kind: rgb, element: "camera:#0"}
  off: {kind: qvel, element: "joint:*", enabled: false}
"""


def test_members_follow_the_list_and_globs_the_suite_order() -> None:
    suite = sensorcfg.loads(SENSORS + "groups:\n  policy: [b, 'a*']\n  critic: [a, '*']\n")
    assert dict(suite.groups) == {"policy": ("b", "a", "a_clean"),  # a glob: suite order, twin after its sensor
                                  "critic": ("a", "a_clean", "b")}  # images and disabled sensors left out


@pytest.mark.parametrize("entry, message", [
    pytest.param("nope", "the suite has no observation named 'nope'; the suite's observations are: a, a_clean, b, cam, off",
                 id="unknown"),
    pytest.param("bb", "the suite has no observation named 'bb' (did you mean 'b'?)", id="did-you-mean"),
    pytest.param("off", "sensor 'off' is disabled (enabled: false): enable it, or leave it out of the group",
                 id="disabled"),
    pytest.param("cam", "sensor 'cam' is a camera image (rgb); a group concatenates vectors: read images from the "
                 "observation dict, or leave it out of the group", id="image"),
    pytest.param("a", "'a' is already in group 'g' (each observation lies at one place of a group): remove this entry",
                 id="twice"),
    pytest.param("'x*'", "'x*' matches no observation that is not already in group 'g'; the suite's observations "
                 "are: a, a_clean, b, cam, off", id="glob-matches-nothing"),
])
def test_a_wrong_entry_is_a_mistake_at_its_line(entry: str, message: str) -> None:
    text = SENSORS + f"groups:\n  g: [a, {entry}]\n"
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(text, file="s.yaml")
    assert [p.format() for p in info.value.problems] == [f"s.yaml:7:10: error: groups.g.1: {message}"]


def test_an_empty_group_is_a_mistake_at_its_key() -> None:
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(SENSORS + "groups:\n  g: []\n", file="s.yaml")
    assert [p.format() for p in info.value.problems] == [
        "s.yaml:7:3: error: groups.g: group 'g' is empty: list the observations it concatenates"]


def test_a_sensor_with_its_own_problem_is_not_reported_again_by_its_group() -> None:
    with pytest.raises(sensorcfg.SuiteError) as info:
        sensorcfg.loads(SENSORS + "  bad: {kind: qpos, buffer: -1}\ngroups:\n  g: [a, bad]\n", file="s.yaml")
    assert all(p.loc.startswith("sensors.bad") for p in info.value.problems)


def test_columns_are_consecutive_and_flattened_in_c_order() -> None:
    groups = layout({"g": ("x", "y")}, {"x": (2, 3), "y": ()})
    g = groups["g"]
    assert [(c.name, c.start, c.stop, c.shape) for c in g.columns] == [("x", 0, 6, (2, 3)), ("y", 6, 7, ())]
    assert g.width == 7
    obs = {"x": np.arange(6.0).reshape(2, 3), "y": np.array(7.0)}
    np.testing.assert_array_equal(g.concatenate(obs), [0, 1, 2, 3, 4, 5, 7])
    batch = {"x": np.arange(12.0).reshape(2, 2, 3), "y": np.array([100.0, 200.0])}
    np.testing.assert_array_equal(g.concatenate(batch, batch_dims=1),
                                  [[0, 1, 2, 3, 4, 5, 100], [6, 7, 8, 9, 10, 11, 200]])
    assert g.concatenate({"x": np.zeros((2, 3), np.float32), "y": np.float32(0)}).dtype == np.float32


def test_the_schema_lists_groups() -> None:
    from sensorcfg.config import json_schema

    assert "groups" in json_schema()["properties"]
