"""Episode rollouts aggregate the task metrics and the motion generator's statistics."""

import itertools

import numpy as np
import pytest

from relmogen.envs.relmogen_env import RelmogenEnv, view_unchanged
from relmogen.experiments.rollout import aggregate, run_episodes


@pytest.fixture(scope="module")
def env():
    environment = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=32, episode_steps=4)
    yield environment
    environment.close()


def test_repeated_subgoals_are_counted_within_episodes(env):
    constant = aggregate(run_episodes(env, lambda obs: np.int64(0), episodes=2, quiet=True))
    assert constant["mean_steps"] == 4
    assert constant["repeated_subgoal_rate"] == pytest.approx(3 / 4)  # the first subgoal of an episode is new
    actions = itertools.cycle([0, 1])
    alternating = aggregate(run_episodes(env, lambda obs: np.int64(next(actions)), episodes=1, quiet=True))
    assert alternating["repeated_subgoal_rate"] == 0.0
    assert {"subgoal_success_rate", "base_fraction", "base_plan_rate"} <= constant.keys()
    assert 0.0 <= constant["unchanged_view_rate"] <= 1.0


def test_a_view_is_unchanged_when_the_image_and_local_map_are(env):
    obs, _ = env.reset(seed=0)
    flicker = dict(obs, depth=obs["depth"] + 0.01, task_obs=obs["task_obs"] + 1e-4)
    assert view_unchanged(obs, flicker)
    for key in ("rgb", "local_map"):
        moved = dict(obs, **{key: obs[key].copy()})
        moved[key].flat[0] ^= 1
        assert not view_unchanged(obs, moved)
