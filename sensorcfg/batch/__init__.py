"""One sensor suite over many simulations: MuJoCo 4's `mujoco.batch` with the Updater's semantics.

`BatchEnvironment` (needs MuJoCo 4; importing this package does not) steps nsim simulations per control
step with one `rollout`; `BatchUpdater` is the vectorised updater beneath it; `sim_seed(seed, i)` is
simulation i's seed, so `Environment(model, suite, seed=sim_seed(seed, i))` reproduces it (the rule's home is
`sensorcfg.draws`, below every engine; re-exported here as public API).
"""

from ..draws import sim_seed
from .environment import BatchEnvironment, BatchTimeStep
from .updater import BatchUpdater

__all__ = ["BatchEnvironment", "BatchTimeStep", "BatchUpdater", "sim_seed"]
