"""``--critic-select K`` (``critic_selected`` in ``relmogen/agents/addons/critic_select.py``): of the
actor's mean and K - 1 fixed samples around it, the action the critics value highest."""

import numpy as np
import pytest
import torch as th
from stable_baselines3 import SAC

from relmogen.agents.addons.critic_select import critic_selected


@pytest.fixture(scope="module")
def model():
    return SAC("MlpPolicy", "Pendulum-v1", policy_kwargs={"net_arch": [16, 16]}, seed=0, device="cpu")


def min_q(model, obs: np.ndarray, action: np.ndarray) -> float:
    obs_tensor, _ = model.policy.obs_to_tensor(obs)
    scaled = th.as_tensor(model.policy.scale_action(action[None]), dtype=th.float32)
    with th.no_grad():
        return float(th.min(th.cat(model.policy.critic(obs_tensor, scaled), dim=1)))


def test_the_choice_is_a_deterministic_function_of_the_observation_valued_at_least_as_the_mean(model):
    act = critic_selected(model, 32, seed=3)
    for obs in np.random.default_rng(0).uniform(-1, 1, size=(5, 3)).astype(np.float32):
        chosen = act(obs)
        np.testing.assert_array_equal(chosen, act(obs))
        assert model.action_space.contains(chosen.astype(np.float32))
        mean = model.predict(obs, deterministic=True)[0]
        assert min_q(model, obs, chosen) >= min_q(model, obs, mean) - 1e-5


def test_two_candidates_with_the_same_seed_choose_alike_and_one_candidate_is_refused(model):
    obs = np.array([0.3, -0.2, 0.5], dtype=np.float32)
    np.testing.assert_array_equal(critic_selected(model, 2, seed=1)(obs), critic_selected(model, 2, seed=1)(obs))
    with pytest.raises(ValueError, match="candidates >= 2"):
        critic_selected(model, 1)
