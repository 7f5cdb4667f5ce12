"""Stable-Baselines3 takes the environments as they are: no wrapper of ours in between."""

import gymnasium as gym
import pytest
from stable_baselines3 import SAC
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import SubprocVecEnv

import relmogen  # noqa: F401


@pytest.mark.parametrize("env_id", ["relmogen/PointNav-v0", "relmogen/TabletopReachM-v0"])
def test_sac_multi_input_policy_runs_200_steps(env_id):
    env = gym.make(env_id, control="joint", image_size=64)  # NatureCNN needs >= 36 px
    # 20 updates after 180 steps: the updates, not the steps, are most of the time
    model = SAC("MultiInputPolicy", env, buffer_size=300, learning_starts=180, batch_size=16,
                policy_kwargs=dict(net_arch=[32, 32]), seed=0, device="cpu")
    model.learn(total_timesteps=200)
    assert model.num_timesteps == 200
    env.close()


def test_subproc_vec_env_with_two_workers():
    # "module:id" makes freshly spawned workers import relmogen (which registers the ids)
    venv = make_vec_env("relmogen:relmogen/PointNav-v0", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv,
                        env_kwargs=dict(control="joint", image_size=32),
                        vec_env_kwargs=dict(start_method="spawn"))
    obs = venv.reset()
    assert obs["rgb"].shape == (2, 32, 32, 3)
    for _ in range(5):
        obs, rewards, dones, infos = venv.step([venv.action_space.sample() for _ in range(2)])
    assert rewards.shape == (2,)
    venv.close()
