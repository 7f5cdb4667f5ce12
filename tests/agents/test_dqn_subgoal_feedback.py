"""relmogen-d with ``env.subgoal_feedback``: the feedback channels of ``local_map`` reach the Q-map
network's map branch, the replay and an update (``relmogen/envs/subgoal_controls.py``)."""

import numpy as np
import pytest
import torch as th
from dqn_helpers import SIZE, SMALL_NET
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import RelmogenDQN
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import env_kwargs

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def feedback_env():
    return RelmogenEnv(task="PointNav", control="subgoal-d", image_size=SIZE, episode_steps=5, subgoal_feedback=True)


def test_relmogen_d_builds_on_the_feedback_channels_and_updates_on_them():
    model = RelmogenDQN(env=DummyVecEnv([feedback_env]), buffer_size=64, batch_size=4, learning_starts=4,
                        train_freq=1, gradient_steps=1, policy_kwargs=SMALL_NET, seed=0)
    assert model.observation_space["local_map"].shape == (4, SIZE, SIZE)  # occupancy, marks, base and arm feedback
    assert model.q_net.net.map_branch[0].in_channels == 4
    model.learn(10)
    assert model._n_updates == 6 and np.isfinite(model.logger.name_to_value["train/loss"])
    buffer = model.replay_buffer
    feedback = buffer.observations["local_map"][:buffer.pos, 0, 2:]
    starts = np.r_[0, np.flatnonzero(buffer.dones[:buffer.pos - 1, 0]) + 1]  # rows that begin an episode
    assert not feedback[starts].any()  # cleared at reset
    later = np.setdiff1d(np.arange(buffer.pos), starts)
    assert all(feedback[row].any() for row in later)  # every later step shows its previous subgoal
    batch = {key: th.as_tensor(value[:buffer.pos, 0]) for key, value in buffer.observations.items()}
    cleared = dict(batch, local_map=batch["local_map"].clone())
    cleared["local_map"][:, 2:] = 0
    with th.no_grad():
        assert not th.allclose(model.q_net(batch)[later], model.q_net(cleared)[later])  # the network reads it
    model.env.close()


def test_the_config_key_reaches_the_relmogen_d_environment():
    config = resolve_config("PointNav", "relmogen-d", preset="tiny", overrides=["env.subgoal_feedback=true"])
    kwargs = env_kwargs(config, arm_collision=False)
    assert kwargs["subgoal_feedback"] is True
    env = RelmogenEnv(**kwargs)
    assert env.observation_space["local_map"].shape == (SIZE, SIZE, 4)
    env.close()
    assert "subgoal_feedback" not in env_kwargs(resolve_config("PointNav", "relmogen-d", preset="tiny"), False)


def test_feedback_refuses_the_shift_augmentation_that_would_leave_it_behind():
    with pytest.raises(ValueError, match="shift_cells"):
        resolve_config("PointNav", "relmogen-d", preset="tiny",
                       overrides=["env.subgoal_feedback=true", "algo.shift_cells=2"])
    resolve_config("PointNav", "relmogen-d", preset="tiny", overrides=["algo.shift_cells=2"])
