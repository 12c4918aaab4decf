"""A sensor suite inside mjlab (https://github.com/mujocolab/mjlab, 1.6): a scene sensor and observation terms.

    from sensorcfg.mjlab import attach
    attach(env_cfg, "go1.yaml", {"actor": "policy", "critic": "critic"}, keep=("actions", "command"))

`SuiteSensorCfg` / `SuiteSensor` (`sensor.py`) run the suite with the Warp engine's sensor layer over mjlab's
worlds; `SuiteGroup` (`terms.py`) is the observation term of one of its groups; `attach` edits an environment
config to use them. docs/training.md says how, and what is exact. Importable only where mjlab is installed
(the `mjlab` extra: `pip install '.[mjlab]'` in the clone).
"""

from __future__ import annotations

try:
    import mjlab  # noqa: F401
except ImportError as e:  # (the message a user sees for `import sensorcfg.mjlab` without mjlab)
    raise ImportError(f"sensorcfg.mjlab needs mjlab: install the mjlab extra (pip install '.[mjlab]' in the clone) "
                      f"or mjlab 1.6 ({e})") from e

from .sensor import SuiteSensor, SuiteSensorCfg
from .terms import SuiteGroup, attach

__all__ = ["SuiteGroup", "SuiteSensor", "SuiteSensorCfg", "attach"]
