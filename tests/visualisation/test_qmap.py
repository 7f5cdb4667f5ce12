"""``relmogen viz qmap``: the state it draws, the greedy choice it marks, the files it writes."""

import imageio.v2 as imageio
import numpy as np
import pytest
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import RelmogenDQN
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import YAW_BINS
from relmogen.visualisation.qmap import q_map_figures, q_map_state

SIZE = 64


@pytest.fixture(scope="module")
def model_and_env():
    threads = th.get_num_threads()
    th.set_num_threads(1)
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=SIZE, episode_steps=4)
    model = RelmogenDQN(env=DummyVecEnv([lambda: RelmogenEnv(task="ButtonDoorNav", control="subgoal-d",
                                                             image_size=SIZE, episode_steps=4)]),
                        buffer_size=16, batch_size=4, learning_starts=0, seed=0,
                        policy_kwargs={"widths": (8, 16, 16, 32), "head_width": 32})
    yield model, env
    env.close()
    model.env.close()
    th.set_num_threads(threads)


def test_marked_choice_is_the_best_allowed_q_value(model_and_env):
    model, env = model_and_env
    obs, _ = env.reset(seed=1)
    state = q_map_state(model, env, obs, step=0)
    part, bin_, i, j = state.choice
    base = np.where(state.masks[0][None], state.q_maps[:YAW_BINS], -np.inf)
    arm = np.where(state.masks[1][None], state.q_maps[YAW_BINS:], -np.inf)
    best = max(base.max(), arm.max())
    chosen = state.q_maps[bin_ if part == "base" else YAW_BINS + bin_, i, j]
    assert chosen == pytest.approx(best, abs=1e-5)
    assert state.masks[0 if part == "base" else 1, i, j]
    assert state.rgb.shape == (SIZE, SIZE, 3) and state.local_map.shape[:2] == (SIZE, SIZE)


def test_figures_are_written_every_stride_steps(model_and_env, tmp_path):
    model, env = model_and_env
    paths = q_map_figures(model, env, tmp_path, states=3, seed=0, stride=2)
    assert len(paths) == 3 and all(p.is_file() for p in paths)
    assert "step00" in paths[0].name and "step02" in paths[1].name
    image = imageio.imread(paths[0])
    assert image.ndim == 3 and image.shape[1] > image.shape[0] > 300  # three panels side by side
    assert image[..., :3].std() > 10  # not a blank canvas


def test_bad_arguments_are_refused(model_and_env, tmp_path):
    model, env = model_and_env
    with pytest.raises(ValueError, match="positive"):
        q_map_figures(model, env, tmp_path, states=0)
