"""Which channels the feature banks and the batch read as plain features: one rule (`plan.bound.plain_refusal`)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.plan import bind as plan_bind
from sensorcfg.plan.bind import check_plain
from sensorcfg.draws import UniformSteps
from sensorcfg.errors import SuiteError
from sensorcfg.plan.bound import plain_refusal
from sensorcfg.runtime import bank as bank_module
from sensorcfg.runtime.bank import qualifies
from sensorcfg.runtime.channels import make_channel
from sensorcfg.runtime.planned import joins

MODEL = mujoco.MjModel.from_xml_path(str(assets.path("robot.xml")))
DRAWN = UniformSteps(1, 3)


def channel(strip: bool = False, **settings):
    physics = sensorcfg.Physics(MODEL, mujoco.MjData(MODEL))
    obs = sensorcfg.Feature(settings.pop("kind", "qpos"), settings.pop("element", "joint:shoulder"), **settings)
    obs.enabled = True
    return obs, make_channel("s", obs, physics, np.random.RandomState(0), None, 2, strip, False)


@pytest.mark.parametrize("settings, strip, rule", [
    pytest.param({}, False, None, id="plain"),
    pytest.param({"buffer_size": 3, "aggregator": "mean"}, False, None, id="builtin"),
    pytest.param({"buffer_size": 3, "aggregator": lambda x: x.sum(0)}, False, "aggregator", id="custom"),
    pytest.param({"aggregator": "max"}, True, "aggregator", id="no-buffer-axis"),
])
def test_plain_refusal(settings, strip, rule) -> None:
    assert plain_refusal(channel(strip, **settings)[1]) == rule


def test_banks_and_batch_ask_one_rule(monkeypatch: pytest.MonkeyPatch) -> None:
    """A channel the rule refuses joins neither bank and is refused by the batch with the rule's message."""
    (obs, fixed), (_, drawn) = channel(), channel(update_interval=DRAWN)
    assert qualifies(fixed) and joins(drawn)
    for module in (bank_module, plan_bind):
        monkeypatch.setattr(module, "plain_refusal", lambda ch: "dtype")
    assert not qualifies(fixed) and not joins(drawn)
    with pytest.raises(SuiteError, match="float64"):
        check_plain("s", obs, fixed)
