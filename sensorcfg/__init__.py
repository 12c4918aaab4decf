"""sensorcfg: declarative robot sensing for MuJoCo, with dm_control's observation semantics."""

from ._gl import import_mujoco as _import_mujoco

_import_mujoco()  # (a GL backend that cannot load does not stop the import: `_gl.py`)

from ._version import __version__  # noqa: E402
from .env import Environment, dm_control_observables, make_env  # noqa: E402
from .errors import ArgumentError, Problem, SensorcfgError, SuiteError, UnsupportedError  # noqa: E402
from .observables import AGGREGATORS, Camera, Feature, Generic, Observable  # noqa: E402
from .physics import Physics  # noqa: E402
from .runtime.updater import Updater  # noqa: E402
from .suite import Suite, load, loads  # noqa: E402


def __getattr__(name: str) -> object:
    """`BatchEnvironment` loads on first use: most programs (and every CLI call) never need it."""
    if name == "BatchEnvironment":
        from .batch import BatchEnvironment

        return BatchEnvironment
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = [
    "AGGREGATORS",
    "ArgumentError",
    "BatchEnvironment",
    "Camera",
    "Environment",
    "Feature",
    "Generic",
    "Observable",
    "Physics",
    "Problem",
    "SensorcfgError",
    "Suite",
    "SuiteError",
    "UnsupportedError",
    "Updater",
    "__version__",
    "dm_control_observables",
    "load",
    "loads",
    "make_env",
]
