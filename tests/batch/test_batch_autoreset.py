"""`BatchEnvironment(autoreset="same_step")`: the step that ends an episode returns the next episode's first
observation (with the ended one's LAST, reward and discount), truncations told from terminations, and the new
episodes the same as in next-step mode: the same draws, so the same observations given the same actions."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import sensorcfg
from sensorcfg import assets
from sensorcfg.batch.environment import BatchEnvironment
from sensorcfg.loop.episode import truncated
from test_batch import needs_batch

ROBOT = str(assets.path("robot.xml"))
SUBSTEPS = 2
LIMIT = 4  # control steps per episode
STOP = 2  # simulation 1 terminates at this control step of each of its episodes

# noise drawn per sample, per episode (bias), a random walk and drawn schedules: each new episode's keys show
SUITE = f"""
options: {{control_interval: {2 * SUBSTEPS}ms}}
sensors:
  q:
    kind: qpos
    element: ["joint:shoulder", "joint:elbow"]
    noise: [{{type: bias, std: 0.1}}, {{type: gaussian, std: 0.01}}, {{type: random_walk, std: 0.01}}]
  v:
    kind: qvel
    element: "joint:elbow"
    interval: {{uniform: [1, 3]}}
    delay: {{choice: [0, 2]}}
    buffer: 3
    noise: [{{type: gaussian, std: 0.05}}]
  hand: {{kind: xpos, element: "site:hand_site", delay: 4ms, buffer: 2, aggregator: mean}}
"""


def actions_for(sim: int, episode: int, step: int, nu: int) -> np.ndarray:
    """The controls simulation `sim` applies at control step `step` of its episode `episode` (either mode)."""
    return np.random.default_rng([sim, episode, step]).uniform(-1, 1, nu) * np.array([1, 1, 0.02])[:nu]


def host(array: Any) -> np.ndarray:
    """A numpy array from either engine's (a Warp array copied to the host)."""
    return array if isinstance(array, np.ndarray) else array.numpy()


def record(env: Any, steps: int) -> list[list[dict[str, Any]]]:
    """Each simulation's episodes under `env` (either engine): the observations of each (its first, then each
    MID step's; the last one of an episode that ended is not kept: same-step mode never shows it) and how it
    ended."""
    same_step = env.autoreset == "same_step"
    nsim, nu = env.action_spec().shape
    step = env.reset()
    episodes: list[list[dict[str, Any]]] = [[{"observations": [], "end": None}] for _ in range(nsim)]

    def keep(i: int, observation: dict[str, np.ndarray]) -> None:
        episodes[i][-1]["observations"].append({k: v[i].copy() for k, v in observation.items()})

    for i in range(nsim):
        keep(i, {k: host(v) for k, v in step.observation.items()})
    for _ in range(steps):
        actions = np.stack([actions_for(i, len(episodes[i]) - 1, len(episodes[i][-1]["observations"]) - 1, nu)
                            for i in range(nsim)])
        step = env.step(actions)
        observation = {k: host(v) for k, v in step.observation.items()}
        kinds, discount = host(step.step_type), host(step.discount)
        by_time, by_termination = host(step.truncated()), host(step.terminated())
        for i in range(nsim):
            if kinds[i] == 2:
                episodes[i][-1]["end"] = "truncated" if by_time[i] else "terminated"
                assert by_time[i] == (discount[i] == 1.0) and by_termination[i] != by_time[i]
            else:
                assert not by_time[i] and not by_termination[i]
            if kinds[i] == 0 or (kinds[i] == 2 and same_step):
                episodes[i].append({"observations": [], "end": None})
            if kinds[i] != 2 or same_step:
                keep(i, observation)
    return episodes


def assert_same_episodes(same: list[list[dict[str, Any]]], later: list[list[dict[str, Any]]]) -> None:
    """Episode by episode, every observation of every simulation of a same-step run (`same`) is the next-step
    run's (`later`) bit for bit, and each episode ended alike."""
    for i, (ours, theirs) in enumerate(zip(same, later)):
        complete = [e for e in ours if e["end"] is not None]
        assert len(complete) >= 3, i  # (episodes 2 and 3 start at a same-step reset)
        for e, episode in enumerate(complete):
            assert episode["end"] == theirs[e]["end"], (i, e)
            assert len(episode["observations"]) == len(theirs[e]["observations"]), (i, e)
            for t, (a, b) in enumerate(zip(episode["observations"], theirs[e]["observations"])):
                for name in a:
                    assert a[name].tobytes() == b[name].tobytes(), (i, e, t, name)
        first = ours[1]["observations"][0]["q"]
        assert not np.array_equal(first, ours[0]["observations"][0]["q"])  # a new episode's own noise


def batch(autoreset: str, nsim: int = 3) -> BatchEnvironment:
    """A batch of the suite whose simulation 1 terminates at control step `STOP` of each of its episodes."""
    env: BatchEnvironment | None = None

    def termination(batch: Any) -> np.ndarray:
        assert env is not None
        return (np.arange(nsim) == 1) & (env.control_steps == STOP)

    env = BatchEnvironment(ROBOT, sensorcfg.loads(SUITE), nsim, seed=7, time_limit=LIMIT * SUBSTEPS * 0.002,
                           termination_fn=termination, autoreset=autoreset, nthread=1)
    return env


@needs_batch
def test_same_step_episodes_are_the_next_step_episodes() -> None:
    """Episode by episode, every observation of every simulation is the same in both modes (bit for bit):
    the new episode's first observation, returned by the step that ended the old one, is what the next step
    returns in next-step mode; the noise's and schedules' keys are drawn as they are there."""
    assert_same_episodes(record(batch("same_step"), 14), record(batch("next_step"), 20))


@needs_batch
def test_the_ending_step_returns_the_next_episode_and_time_outs_are_truncations_only() -> None:
    env = batch("same_step")
    episodes = record(env, 6)
    assert [e["end"] for e in episodes[0][:1]] == ["truncated"]  # at the time limit: discount 1
    assert [e["end"] for e in episodes[1][:2]] == ["terminated", "terminated"]  # termination_fn: discount 0
    assert [len(e["observations"]) for e in episodes[0][:1]] == [LIMIT]  # reset + MID steps, LAST not shown
    step = env.step(np.zeros((3, env.action_spec().shape[1])))
    # simulation 1 terminated at the step before (6 = 2 x STOP + 2): this is step 1 of its new episode
    assert env.control_steps.tolist() == [3, 1, 3] and step.step_type.tolist() == [1, 1, 1]
    assert truncated(np.array([2, 2, 1, 0]), np.array([1.0, 0.0, 1.0, 1.0])).tolist() == [True, False, False, False]


@needs_batch
def test_autoreset_is_one_of_two() -> None:
    with pytest.raises(sensorcfg.ArgumentError, match="autoreset must be one of 'next_step', 'same_step'"):
        BatchEnvironment(ROBOT, sensorcfg.loads(SUITE), 1, autoreset="same")
