"""The run's timing record (what `--plot` draws) against what the observations themselves show.

Each test sensor returns its own sampling step, so the recorded observations say exactly which sample each
read delivered. The timing the CLI reconstructs (closed form for fixed schedules, a replay of the recorded
draws for drawn ones) must agree with them and with the Updater's sample counts.
"""

from __future__ import annotations

import io

import numpy as np
import pytest

import sensorcfg
from sensorcfg.cli import timing
from sensorcfg.cli.report import Progress
from sensorcfg.cli.run import Settings, make_env, simulate
from sensorcfg.draws import ChoiceSteps, UniformSteps

MODEL = """<mujoco><option timestep="0.001"/><worldbody><body><freejoint/><geom size=".1"/></body></worldbody>
</mujoco>"""
N = 5  # physics steps per control step


class _Suite:
    """Just enough of a Suite for make_env: options, a control interval, and prebuilt observables."""

    class options:  # noqa: N801 - mimics Suite.options
        strip_singleton_buffer_dim = False
        pad_with_initial_value = False

    def __init__(self, observables):
        self.observables = observables

    def updater_kwargs(self, model):
        return {"physics_steps_per_control_step": N}

    def build(self, model):
        return self.observables

    def _adds_to_model(self, batch=False):  # the model runs as its file says
        return False

    def notes(self, model=None):  # no advice to print
        return []


def step_of(physics) -> np.ndarray:
    return np.array([round(physics.data.time / 0.001) + 1.0])  # +1: padding zeros stay distinguishable


def sensors() -> dict[str, sensorcfg.Observable]:
    obs = {
        "fixed": sensorcfg.Generic(step_of, update_interval=3, delay=4, buffer_size=2),
        "every": sensorcfg.Generic(step_of, update_interval=1, buffer_size=1),
        "jitter": sensorcfg.Generic(step_of, update_interval=UniformSteps(1, 4), delay=UniformSteps(0, 6), buffer_size=3),
        "choice": sensorcfg.Generic(step_of, update_interval=7, delay=ChoiceSteps((2, 9), (0.5, 0.5)), buffer_size=1),
    }
    for o in obs.values():
        o.enabled = True
    return obs


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "m.xml"
    path.write_text(MODEL)
    return str(path)


@pytest.mark.parametrize("seed", [0, 1, 7])
def test_timing_agrees_with_the_observations(model_file, seed):
    observables = sensors()
    env, obs = make_env(_Suite(observables), model_file, Settings(steps=60, seed=seed), record_timing=True)
    rec = simulate(env, Settings(steps=60, seed=seed), keep=True)
    times = timing.timings(obs, rec.steps_done * N, N)
    for name, t in times.items():
        assert np.all(t.delivered >= t.sampled)
        sampled = dict(zip(t.sampled.tolist(), t.delivered.tolist()))
        seen = {int(v) - 1 for v in np.unique(rec.observations[name]) if v > 0}
        # Every sample an observation shows is in the record, delivered after the read before the first
        # one that shows it (else that read would have shown it) and by that read.
        first_read: dict[int, int] = {}
        for read, window in enumerate(rec.observations[name]):
            for v in np.asarray(window).reshape(-1):
                if v > 0:
                    first_read.setdefault(int(v) - 1, read)
        for s, read in first_read.items():
            assert s in sampled, (name, s)
            assert (read - 1) * N < sampled[s] <= read * N, (name, s, read, sampled[s])
        visible = {s for s, v in zip(t.sampled.tolist(), t.visible.tolist()) if v}
        assert seen <= visible, name
    # Drawn schedules: the replay saw exactly the samples the Updater took (minus those still in flight).
    taken = env.updater.samples_taken()
    for name in ("jitter", "choice"):
        assert len(times[name].sampled) <= taken[name] <= len(times[name].sampled) + 3
    assert taken["every"] == rec.steps_done + 1  # one per read plus the reset sample: the rest are skipped
    assert int(times["every"].visible.sum()) == rec.steps_done + 1  # the reset read shows sample 0


def test_fixed_visibility_is_what_the_updater_takes(model_file):
    observables = sensors()
    env, obs = make_env(_Suite(observables), model_file, Settings(steps=40), record_timing=True)
    rec = simulate(env, Settings(steps=40), keep=False)
    times = timing.timings(obs, rec.steps_done * N, N)
    taken = env.updater.samples_taken()
    # The reset sample is always taken; after it, exactly the visible ones.
    for name in ("fixed", "every"):
        t = times[name]
        assert taken[name] == 1 + int(t.visible[t.sampled > 0].sum()), name


def test_progress_bar_only_on_a_terminal():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    quiet = io.StringIO()
    bar = Progress(10, "run", stream=quiet)
    bar.start -= 10
    bar.update(5)
    bar.close()
    assert quiet.getvalue() == ""
    tty = Tty()
    bar = Progress(10, "run", stream=tty)
    bar.start -= 10
    bar.last -= 10
    bar.update(5)
    assert "[###############---------------] 5/10" in tty.getvalue()
    bar.close()
    assert tty.getvalue().endswith("\r")
