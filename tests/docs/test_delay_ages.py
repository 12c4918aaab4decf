"""What the docs say of the age of a read under drawn delays, measured: with interval 1 and `delay: {uniform:
[1, 3]}`, a read shows the sample that arrived last, which is 4 steps old (older than the largest delay) in
2 reads of 81 (docs/semantics.md; `sensorcfg spec` says it under its table)."""

from __future__ import annotations

import collections

import mujoco
import numpy as np

import sensorcfg
from sensorcfg.cli.spec import DRAWN_DELAYS

from conftest import ROOT

DT = 0.001
SLIDER = (f"<mujoco><option timestep='{DT}' gravity='0 0 0'/><worldbody><body><joint name='x' type='slide'/>"
          "<geom size='.1'/></body></worldbody></mujoco>")  # at 1 m/s, its qpos is the time of its sample


def test_under_delays_drawn_from_1_to_3_two_reads_in_81_are_4_steps_old() -> None:
    model = mujoco.MjModel.from_xml_string(SLIDER)
    suite = sensorcfg.loads("sensors:\n  x: {kind: qpos, element: 'joint:x', delay: {uniform: [1, 3]}}\n")
    ages: collections.Counter[int] = collections.Counter()
    for seed in range(8):
        env = sensorcfg.Environment(model, suite, seed=seed,
                                    initialize_episode=lambda physics, _: physics.data.qvel.__setitem__(0, 1.0))
        env.reset()
        for step in range(1, 3001):
            taken = float(env.step(np.zeros(0)).observation["x"].reshape(-1)[0])
            if step > 4:  # past the reset sample's padding
                ages[round(step - taken / DT)] += 1
    reads = sum(ages.values())
    assert sorted(ages) == [1, 2, 3, 4]
    assert abs(ages[4] / reads - 2 / 81) < 0.004, ages  # 5 standard deviations of 23,968 reads
    assert "2 reads in 81 (about 2.5%" in (ROOT / "docs" / "semantics.md").read_text(encoding="utf-8")
    assert DRAWN_DELAYS.endswith("with interval 1 and delay {uniform: [1, 3]}, 2.5% of reads are 4 steps old")
