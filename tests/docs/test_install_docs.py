"""No doc, example or message tells a user to install sensorcfg from the package index: it is not there
(`pip install sensorcfg` finds nothing, or somebody else's package). From a clone it is `pip install .`,
with extras `pip install '.[plot]'`; elsewhere, from its repository by URL."""

from __future__ import annotations

import re

import pytest

from conftest import ROOT

# `pip install sensorcfg`, `pip install 'sensorcfg[menagerie]'`, `pip install -U sensorcfg`, but not a
# requirement with a URL (`"sensorcfg @ git+https://..."`)
FROM_INDEX = re.compile(r"pip3? install(?:\s+-{1,2}[\w-]+)*\s+[\"']?sensorcfg(?![\w-])(?:\[[^\]]*\])?[\"']?(?!\s*@)")
TEXTS = sorted({*ROOT.glob("*.md"), *ROOT.glob("docs/**/*.md"), *ROOT.glob("configs/**/*"),
                *ROOT.glob("examples/**/*"), *ROOT.glob("sensorcfg/**/*.py"), ROOT / "pyproject.toml",
                *ROOT.glob("noxfile.py")})


@pytest.mark.parametrize("text", [
    "pip install sensorcfg", "pip install 'sensorcfg[menagerie]'", "pip install \"sensorcfg[plot,gym]\"",
    "pip install -U sensorcfg", "pip install sensorcfg[gym]", "pip3 install sensorcfg && sensorcfg validate",
])
def test_the_pattern_finds_an_install_from_the_index(text: str) -> None:
    assert FROM_INDEX.search(text)


@pytest.mark.parametrize("text", [
    "pip install '.[menagerie]'", "pip install mujoco-menagerie", "pip install \"sensorcfg @ git+https://x/y\"",
    "pip install sensorcfg-tools", "pip install matplotlib (or, from a sensorcfg clone, pip install '.[plot]')",
])
def test_the_pattern_lets_the_right_installs_through(text: str) -> None:
    assert not FROM_INDEX.search(text)


def test_no_doc_suggests_installing_sensorcfg_from_the_index() -> None:
    found = []
    for path in TEXTS:
        if not path.is_file() or path.suffix not in (".md", ".py", ".toml", ".yaml", ".yml", ".txt", ""):
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if FROM_INDEX.search(line):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)
