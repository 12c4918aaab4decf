"""The public constructors say what they take, for editors' hover text: a Google-style `Args:` section naming
every parameter of the signature in order (a dataclass: `Attributes:` naming its fields), `Returns:` for a
function, and a `Raises:` section naming only exception types that exist. Read from the source (`ast`), so
the Warp engine's and the Gymnasium wrappers' are checked where Warp or Gymnasium is not installed."""

from __future__ import annotations

import ast
import builtins
import inspect
import re
from pathlib import Path

import pytest

import sensorcfg
import sensorcfg.errors

from conftest import ROOT

PACKAGE = ROOT / "sensorcfg"
# public modules besides the package's top level whose classes users construct
MODULES = ("warp/environment.py", "gym.py", "gym_vector.py")
SECTION = re.compile(r"^(Args|Attributes|Returns|Raises):$")


def _tree(file: Path) -> ast.Module:
    return ast.parse(file.read_text(encoding="utf-8"))


def _all(tree: ast.Module) -> list[str]:
    node = next(n for n in tree.body if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == "__all__")
    return [e.value for e in node.value.elts]  # type: ignore[attr-defined]


def _public() -> list[tuple[Path, str]]:
    """(source file, name) of every public class and function: `sensorcfg.__all__`'s and `MODULES`'."""
    found = []
    for name in sensorcfg.__all__:
        obj = getattr(sensorcfg, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            found.append((Path(inspect.getsourcefile(obj)), obj.__name__))
    for module in MODULES:
        found += [(PACKAGE / module, name) for name in _all(_tree(PACKAGE / module))]
    return found


def _definition(file: Path, name: str) -> ast.ClassDef | ast.FunctionDef | None:
    return next((n for n in _tree(file).body if isinstance(n, (ast.ClassDef, ast.FunctionDef)) and n.name == name),
                None)


def _sections(doc: str) -> dict[str, list[str]]:
    """A Google-style docstring's sections: the names its entries document (`name: text`, several names
    written `a, b: text`), by section."""
    sections: dict[str, list[str]] = {}
    current = None
    for line in inspect.cleandoc(doc).splitlines():
        if SECTION.match(line):
            current = sections.setdefault(line[:-1], [])
        elif current is not None and re.match(r"^    \S", line):
            current += [n.strip() for n in line.strip().partition(":")[0].split(",")]
        elif current is not None and line and not line.startswith("        "):
            current = None
    return sections


def _parameters(function: ast.FunctionDef) -> list[str]:
    args = function.args
    names = [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)]
    names += [f"*{args.vararg.arg}"] if args.vararg else []
    names += [f"**{args.kwarg.arg}"] if args.kwarg else []
    return [n for n in names if n != "self"]


def _documented() -> list[tuple[str, ast.FunctionDef | ast.ClassDef, list[str]]]:
    """(label, the definition whose docstring documents the constructor, the names it must document)."""
    out = []
    for file, name in _public():
        node = _definition(file, name)
        assert node is not None, f"{name} is not defined in {file}"
        if isinstance(node, ast.FunctionDef):
            out.append((name, node, _parameters(node)))
            continue
        init = next((n for n in node.body if isinstance(n, ast.FunctionDef) and n.name == "__init__"), None)
        if init is not None:
            out.append((f"{name}.__init__", init, _parameters(init)))
        elif any(getattr(d, "id", getattr(d, "attr", "")) == "dataclass" or
                 getattr(getattr(d, "func", None), "attr", "") == "dataclass" for d in node.decorator_list):
            out.append((name, node, [n.target.id for n in node.body if isinstance(n, ast.AnnAssign)]))
    return out


CONSTRUCTORS = _documented()


def test_the_constructors_checked_include_every_engine_and_wrapper() -> None:
    labels = {label for label, _, _ in CONSTRUCTORS}
    assert {"Environment.__init__", "BatchEnvironment.__init__", "WarpEnvironment.__init__", "GymEnv.__init__",
            "GymVectorEnv.__init__", "Feature.__init__", "Camera.__init__", "Generic.__init__", "Updater.__init__",
            "Suite.__init__", "Physics.__init__", "SuiteError.__init__", "Problem", "make_env", "load",
            "loads"} <= labels


@pytest.mark.parametrize("label, node, names", CONSTRUCTORS, ids=[c[0] for c in CONSTRUCTORS])
def test_a_public_constructor_documents_each_argument_in_order(label: str, node: ast.AST, names: list[str]) -> None:
    doc = ast.get_docstring(node)  # type: ignore[arg-type]
    assert doc, f"{label} has no docstring"
    sections = _sections(doc)
    key = "Attributes" if isinstance(node, ast.ClassDef) else "Args"
    assert sections.get(key, []) == names, f"{label}: its {key} section does not name {names}"
    if isinstance(node, ast.FunctionDef) and node.name != "__init__":
        assert "Returns" in sections, f"{label} says nothing under Returns"
    for error in sections.get("Raises", []):
        kind = getattr(sensorcfg.errors, error, getattr(builtins, error, None))
        assert isinstance(kind, type) and issubclass(kind, BaseException), f"{label} raises {error}, no exception"
