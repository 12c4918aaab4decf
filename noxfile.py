"""Test matrix: the two MuJoCo lines we support.

- `tests-mujoco4`: the newest MuJoCo 4.x, every test (the dm_control oracle is absent here: MuJoCo 4 cannot
  build a dm_control Physics, so parity tests skip in this session only).
- `oracle-mujoco3`: MuJoCo 3.17.0 with dm_control 1.0.50 as the parity oracle; a skipped parity test is a
  failure here (SENSORCFG_REQUIRE_ORACLE=1).
- `tests-warp`: the Warp engine (`sensorcfg[warp]`) on Warp's CPU device, with torch for its actions' tests,
  RSL-RL (`sensorcfg[rsl-rl]`: its VecEnv, PPO and torchrun on gloo) and the suite plan's tests; a missing Warp
  fails here (SENSORCFG_REQUIRE_WARP=1).
- `tests-mjlab`: the Warp engine on MuJoCo Warp 3.11 as mjlab 1.6 pins it (`sensorcfg[mjlab]`, torch CPU), its
  tests and the mjlab adapter's; a missing Warp or mjlab fails here (SENSORCFG_REQUIRE_WARP=1,
  SENSORCFG_REQUIRE_MJLAB=1).
- `typecheck`: mypy and ruff (both pinned) over the package; any error fails the session.

Both test sessions build the compiled noise kernel (setup.py; the machines have a C compiler) and set
SENSORCFG_REQUIRE_KERNEL=1, so that a kernel that failed to build fails its tests instead of skipping them.

pytest's exit code 5 ("no tests collected") fails the session like any other non-zero code.
"""

import os

import nox

nox.options.sessions = ["tests-mujoco4", "oracle-mujoco3", "tests-warp", "tests-mjlab", "typecheck"]
nox.options.reuse_existing_virtualenvs = True
nox.options.error_on_missing_interpreters = True

ENV = {"MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "PYTHONHASHSEED": "0", "SENSORCFG_REQUIRE_KERNEL": "1"}


def _pytest(session: nox.Session, *paths: str, **env: str) -> None:
    session.run("python", "-m", "pytest", "-q", "-p", "no:cacheprovider", *paths, *session.posargs,
                env={**ENV, **env}, success_codes=[0])


@nox.session(name="tests-mujoco4")
def tests_mujoco4(session: nox.Session) -> None:
    session.install("-e", ".[test,gym,plot,menagerie]", "mujoco>=4,<5")
    session.run("python", "-c", "import mujoco; print('mujoco', mujoco.__version__)")
    _pytest(session)


@nox.session(name="oracle-mujoco3")
def oracle_mujoco3(session: nox.Session) -> None:
    session.install("-e", ".[test,gym,plot,menagerie]", "mujoco==3.17.0", "dm-control==1.0.50")
    session.run("python", "-c", "import mujoco, dm_control; print('mujoco', mujoco.__version__)")
    _pytest(session, SENSORCFG_REQUIRE_ORACLE="1")


@nox.session(name="tests-warp")
def tests_warp(session: nox.Session) -> None:
    """The Warp engine on Warp's CPU device (the same kernels as on a GPU, compiled by LLVM; cached under
    ~/.cache/warp): its own tests and the suite plan's, with `sensorcfg[warp]` installed (required here),
    torch (CPU; pinned in the same install, so that RSL-RL's requirements cannot bring another), whose tensors
    the engine takes as actions (DLPack), and `sensorcfg[rsl-rl]` (the VecEnv's and examples/several_gpus.py's
    tests)."""
    session.install("-e", ".[test,warp,rsl-rl]", "mujoco>=4,<5", "torch==2.13.0")
    session.run("python", "-c", "import mujoco, mujoco_warp, warp; print('mujoco', mujoco.__version__, "
                "'mujoco_warp', mujoco_warp.__version__ if hasattr(mujoco_warp, '__version__') else '?', "
                "'warp', warp.__version__)")
    _pytest(session, "tests/warp", "tests/plan", SENSORCFG_REQUIRE_WARP="1")


# torch first, pinned: mjlab asks for torch>=2.7, which pip would otherwise take from the index (a CUDA build)
MJLAB_TORCH = "torch==2.13.0"


@nox.session(name="tests-mjlab")
def tests_mjlab(session: nox.Session) -> None:
    """mjlab 1.6 beside sensorcfg: the Warp engine on its MuJoCo Warp 3.11 (Warp's CPU device; what 3.11 lacks
    is refused at the suite's line, `warp/support.py`), and the mjlab adapter on mjlab's Go1 velocity task with
    2 worlds (replayed by Updaters; 2 iterations of mjlab's RSL-RL runner)."""
    session.install(MJLAB_TORCH)
    session.install("-e", ".[test,mjlab]", MJLAB_TORCH, "mjlab==1.6.0")
    session.run("python", "-c", "import mujoco, mujoco_warp, mjlab, torch; print('mujoco', mujoco.__version__, "
                "'mujoco_warp', getattr(mujoco_warp, '__version__', '?'), 'torch', torch.__version__)")
    _pytest(session, "tests/warp", "tests/mjlab", SENSORCFG_REQUIRE_WARP="1", SENSORCFG_REQUIRE_MJLAB="1")


# The libraries whose type stubs mypy reads, at the versions the package was last checked against, so that a
# new release of one of them cannot fail this session with no change here (the test sessions take the newest).
TYPED_WITH = ["mypy==2.4.1", "numpy==2.4.6", "pydantic==2.14.3", "mujoco==4.0.0", "gymnasium==1.4.0"]
# The linter, pinned for the same reason (its rules: pyproject.toml's [tool.ruff])
RUFF = "ruff==0.17.6"


@nox.session(name="typecheck")
def typecheck(session: nox.Session) -> None:
    session.install("-e", ".[test,gym]", *TYPED_WITH, RUFF)
    session.run("mypy", "sensorcfg", "--ignore-missing-imports")
    session.run("ruff", "check", "sensorcfg")
