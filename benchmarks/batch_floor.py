"""The floor of a batched suite: what recording the suite's values costs over batched physics, when the
values are MjData fields recorded by `Batch.rollout` (what BatchEnvironment does) and when they are the
model's own MuJoCo sensors (computed in the batch's threads, recorded as one contiguous `sensordata`).

Setting: dm_control's suite/humanoid.xml, 5 physics steps per control step, random controls, nsim
simulations. "native" is the same model with a MuJoCo sensor for each value of the 20-observable suite of
benchmarks/_humanoid.py that MuJoCo has a sensor type for (18 of 20: joint positions, velocities and
actuator forces, frame positions, orientations and velocities, subtree com, actuator forces, and the
model's own sensors); MuJoCo has no sensor for `qacc` (joint_acc) or `cfrc_ext` (feet_cfrc), recorded as
fields next to it in the last rows. Each control step, every variant runs from the same simulation state
(saved and restored), in rotating order:

  physics                   the environment's Batch: `rollout` recording nothing (the environment's bound fields
                            are copied out after the call, as BatchEnvironment's are)
  null                      physics again on a second Batch of the bare model (instances differ in speed)
  fields (env)              the environment's rollout: the fields it records, plus one take of every value
                            its reads need (benchmarks/batch.py's "floor")
  native physics            the native model's Batch recording nothing: the sensors' compute
  native sensordata         + `sensordata` recorded after every substep, and one take of the suite's values
  native sensordata, last   `sensordata` bound instead (copied out once per call: only the last substep)
  native + qacc, cfrc_ext   sensordata, qacc and cfrc_ext after every substep, and one take
  hybrid physics            "hybrid": the model with sensors only for the suite's values of wide fields that a
                            sensor copies exactly (xquat of the torso, the head site's xmat, subtree_com),
                            recording nothing (binding what the environment binds)
  hybrid fields             the environment's fields without those three, sensordata included, and one take

Prints medians of environment steps per second and each variant's cost over `physics`.

    MUJOCO_GL=egl python benchmarks/batch_floor.py [--nsim 512] [--repeats 9] [--control-steps 40]

Needs MuJoCo 4 (mujoco.batch).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _humanoid import BODIES, HINGES, humanoid_xml, sensorcfg_observables  # noqa: E402
from mujoco.batch import Batch  # noqa: E402

from sensorcfg.batch import BatchEnvironment  # noqa: E402

N = 5
S = mujoco.mjtSensor
O = mujoco.mjtObj


def _spec(model_xml: str, assets: dict[str, bytes]) -> mujoco.MjSpec:
    folder = tempfile.mkdtemp()
    for name, content in assets.items():  # includes are read from files next to the model
        path = os.path.join(folder, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(content)
    with open(os.path.join(folder, "humanoid.xml"), "w") as f:
        f.write(model_xml)
    return mujoco.MjSpec.from_file(os.path.join(folder, "humanoid.xml"))


def native_model(model_xml: str, assets: dict[str, bytes]) -> mujoco.MjModel:
    """The humanoid with a MuJoCo sensor for each value of the suite that MuJoCo has a sensor type for."""
    spec = _spec(model_xml, assets)

    def add(kind: int, objtype: int, name: str) -> None:
        spec.add_sensor(type=kind, objtype=objtype, objname=name)

    for joint in HINGES:  # joint_pos, joint_vel, joint_torque (qfrc_actuator)
        for kind in (S.mjSENS_JOINTPOS, S.mjSENS_JOINTVEL, S.mjSENS_JOINTACTFRC):
            add(kind, O.mjOBJ_JOINT, joint)
        add(S.mjSENS_ACTUATORFRC, O.mjOBJ_ACTUATOR, joint)  # actuator_force (the actuators are named as joints)
    for body in BODIES:  # body_pos
        add(S.mjSENS_FRAMEPOS, O.mjOBJ_XBODY, body)
    add(S.mjSENS_FRAMEQUAT, O.mjOBJ_XBODY, "torso")  # torso_quat_hist
    add(S.mjSENS_SUBTREECOM, O.mjOBJ_BODY, "torso")  # torso_com
    add(S.mjSENS_FRAMELINVEL, O.mjOBJ_XBODY, "torso")  # torso_cvel (6 values)
    add(S.mjSENS_FRAMEANGVEL, O.mjOBJ_XBODY, "torso")
    for axis in (S.mjSENS_FRAMEXAXIS, S.mjSENS_FRAMEYAXIS, S.mjSENS_FRAMEZAXIS):  # head_orient, head_site (xmat)
        add(axis, O.mjOBJ_XBODY, "head")
        add(axis, O.mjOBJ_SITE, "head")
    for site in ("right_hand", "left_hand", "right_left_foot", "left_left_foot"):  # extremities
        add(S.mjSENS_FRAMEPOS, O.mjOBJ_SITE, site)
    for geom in ("torso", "head"):  # geom_pos
        add(S.mjSENS_FRAMEPOS, O.mjOBJ_GEOM, geom)
    return spec.compile()


def hybrid_model(model_xml: str, assets: dict[str, bytes]) -> mujoco.MjModel:
    """The humanoid with sensors only where the suite reads a few values of a wide field and a MuJoCo sensor
    copies exactly those values: the torso's xquat (framequat of its frame), the head site's xmat (its
    three axes) and the torso's subtree_com (subtreecom)."""
    spec = _spec(model_xml, assets)
    spec.add_sensor(type=S.mjSENS_FRAMEQUAT, objtype=O.mjOBJ_XBODY, objname="torso")
    for axis in (S.mjSENS_FRAMEXAXIS, S.mjSENS_FRAMEYAXIS, S.mjSENS_FRAMEZAXIS):
        spec.add_sensor(type=axis, objtype=O.mjOBJ_SITE, objname="head")
    spec.add_sensor(type=S.mjSENS_SUBTREECOM, objtype=O.mjOBJ_BODY, objname="torso")
    return spec.compile()


HYBRID_FIELDS = ("xquat", "site_xmat", "subtree_com")  # what the hybrid model's sensors stand for


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--nsim", type=int, nargs="+", default=[512])
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--control-steps", type=int, default=40)
    parser.add_argument("--nthread", type=int, default=0)
    args = parser.parse_args()
    xml, assets = humanoid_xml()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    native, hybrid = native_model(xml, assets), hybrid_model(xml, assets)
    print(f"humanoid, {N} physics steps per control step; mujoco {mujoco.__version__}, {os.cpu_count()} CPUs; "
          f"medians of {args.repeats} repeats x {args.control_steps} control steps; native: nsensordata "
          f"{native.nsensordata} (the model's own {model.nsensordata} included)")
    for nsim in args.nsim:
        run(model, native, hybrid, nsim, args)


def run(model: mujoco.MjModel, native: mujoco.MjModel, hybrid: mujoco.MjModel, nsim: int,
        args: argparse.Namespace) -> None:
    env = BatchEnvironment(model, sensorcfg_observables(), nsim, nthread=args.nthread,
                           physics_steps_per_control_step=N, seed=0)
    env.reset()
    updater = env.updater
    layout = updater.layout
    bare, nb, nb_bound = Batch(model, nsim, args.nthread), Batch(native, nsim, args.nthread), Batch(native, nsim, args.nthread)
    nb_bound.bind("sensordata")
    width = layout.width
    rng = np.random.default_rng(0)
    suite_index = rng.integers(0, native.nsensordata, (nsim, width)) + (np.arange(nsim) * N * native.nsensordata)[:, None]
    out_s = {"sensordata": np.empty((nsim, N, native.nsensordata))}
    out_3 = {f: np.empty((nsim, N, *getattr(mujoco.MjData(native), f).shape)) for f in ("sensordata", "qacc", "cfrc_ext")}
    hb = Batch(hybrid, nsim, args.nthread)
    (_, _, recorded_fields), = layout.segments
    for f in layout.bound[0]:
        hb.bind(f)
    hdata = mujoco.MjData(hybrid)
    out_h = {f: np.empty((nsim, N, *getattr(hdata, f).shape))
             for f in recorded_fields if f not in layout.bound[0] and f not in HYBRID_FIELDS}
    lo, hi = model.actuator_ctrlrange.T
    actions = rng.uniform(lo, hi, (args.control_steps, nsim, model.nu)) * 0.2

    def fields(a: np.ndarray) -> None:
        env._rollout(a, np.ones(nsim, bool), np.zeros(nsim, bool), {})
        if layout.fixed:
            updater.flat.take(layout.gathers(updater.global_step % updater.rows, updater.age), mode="clip")

    def recorded(batch: Batch, out: dict[str, np.ndarray]) -> Callable[[np.ndarray], None]:
        def step(a: np.ndarray) -> None:
            batch.rollout(N, control=a[:, None, :], record=list(out), out=out)
            out["sensordata"].reshape(-1).take(suite_index, mode="clip")
        return step

    def physics_of(batch: Batch) -> Callable[[np.ndarray], None]:
        return lambda a: batch.rollout(N, control=a[:, None, :], record=())

    variants: list[tuple[str, Batch, Callable[[np.ndarray], None]]] = [
        ("physics", env.batch, physics_of(env.batch)), ("null", bare, physics_of(bare)),
        ("fields (env)", env.batch, fields), ("native physics", nb, physics_of(nb)),
        ("native sensordata", nb, recorded(nb, out_s)), ("native sensordata, last", nb_bound, physics_of(nb_bound)),
        ("native + qacc, cfrc_ext", nb, recorded(nb, out_3)), ("hybrid physics", hb, physics_of(hb)),
        ("hybrid fields", hb, recorded(hb, out_h))]
    state = env.batch.state

    def repeat() -> dict[str, float]:
        wall = dict.fromkeys([name for name, _, _ in variants], 0.0)
        for i, a in enumerate(actions):
            start = state.copy()
            for name, batch, fn in variants[i % len(variants):] + variants[:i % len(variants)]:
                batch.state[:] = start
                t0 = time.perf_counter()
                fn(a)
                wall[name] += time.perf_counter() - t0
            state[:] = start
            physics_of(env.batch)(a)  # go on from this step (untimed)
        return {name: len(actions) * nsim / t for name, t in wall.items()}

    repeat()
    rows: dict[str, list[float]] = {}
    for _ in range(args.repeats):
        for name, value in repeat().items():
            rows.setdefault(name, []).append(value)
    med = {name: statistics.median(v) for name, v in rows.items()}
    print(f"nsim {nsim}: env steps/s (median) and cost over physics (physics / variant - 1)")
    for name, _, _ in variants:
        print(f"  {name:<26}{med[name]:>12,.0f}{100 * (med['physics'] / med[name] - 1):>+9.1f}%")


if __name__ == "__main__":
    main()
