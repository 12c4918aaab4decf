"""One sensor suite over many simulations: MuJoCo 4's `mujoco.batch` with the Updater's semantics.

`BatchEnvironment` (needs MuJoCo 4; importing this package does not) steps nsim simulations per control
step with one `rollout`; `BatchUpdater` is the vectorised updater beneath it; `sim_seed(seed, i)` is
simulation i's seed, so `Environment(model, suite, seed=sim_seed(seed, i))` reproduces it.
"""

from . import level as _level  # noqa: F401  registers the batched forms of the noise level's stages
from . import misalign as _misalign  # noqa: F401  registers the batched form of the misalign noise stage
from . import redrawn as _redrawn  # noqa: F401  registers the batched form of stages drawn per episode
from .environment import BatchEnvironment, BatchTimeStep, sim_seed
from .updater import BatchUpdater

__all__ = ["BatchEnvironment", "BatchTimeStep", "BatchUpdater", "sim_seed"]
