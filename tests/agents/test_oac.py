"""OAC explores with the optimistic shift of Ciosek et al. (2019)."""

import numpy as np
import pytest
import torch as th

from relmogen.agents.sac import OAC, _q_from_features, optimistic_action
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.models import build_model


class ZeroNoise:
    def standard_normal(self, shape):
        return np.zeros(shape)


@pytest.fixture(scope="module")
def oac():
    config = resolve_config("PointNav", "oac", preset="tiny", episodes=1)
    model = build_model(config, make_training_env(config))
    assert isinstance(model, OAC)
    obs = model.get_env().reset()
    yield model, obs
    model.get_env().close()


def policy_mean_and_std(model, obs):
    tensor, _ = model.policy.obs_to_tensor(obs)
    with th.no_grad():
        features = model.actor.extract_features(tensor, model.actor.features_extractor)
        latent = model.actor.latent_pi(features)
        return model.actor.mu(latent), th.exp(th.clamp(model.actor.log_std(latent), -20, 2)), tensor


def upper_bound(model, tensor, pre_tanh, beta_ub):
    features = model.critic.extract_features(tensor, model.critic.features_extractor)
    q1, q2 = _q_from_features(model.critic, features, th.tanh(pre_tanh))[:2]
    return (q1 + q2) / 2 + beta_ub * th.abs(q1 - q2) / 2


def test_shift_has_the_kl_radius_delta_and_raises_the_upper_bound(oac):
    model, obs = oac
    delta, beta_ub = 0.5, 4.66
    action = optimistic_action(model.policy, obs, beta_ub, delta, ZeroNoise())
    mean, std, tensor = policy_mean_and_std(model, obs)
    shifted = th.atanh(th.as_tensor(action).clamp(-0.999999, 0.999999))
    shift = shifted - mean
    # ||shift||_{Sigma^-1} = sqrt(2 delta): the KL between N(mu, Sigma) and N(mu_E, Sigma) is delta
    mahalanobis = th.sqrt(th.sum(shift**2 / std**2, dim=1))
    assert mahalanobis.numpy() == pytest.approx(np.sqrt(2 * delta), rel=1e-3)
    with th.no_grad():
        small_step = mean + 1e-3 * shift / mahalanobis[:, None]
        assert (upper_bound(model, tensor, small_step, beta_ub) > upper_bound(model, tensor, mean, beta_ub)).all()


def test_without_a_trust_region_it_is_the_sac_mean_action(oac):
    model, obs = oac
    action = optimistic_action(model.policy, obs, 4.66, 0.0, ZeroNoise())
    deterministic, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(action, deterministic, atol=1e-5)


def test_exploration_differs_from_sac_sampling_after_learning_starts(oac):
    model, obs = oac
    model.num_timesteps = model.learning_starts + 1
    model._last_obs = obs
    action, buffer_action = model._sample_action(model.learning_starts, n_envs=1)
    deterministic, _ = model.predict(obs, deterministic=True)
    assert action.shape == deterministic.shape and not np.allclose(action, deterministic)
    assert np.all(np.abs(buffer_action) <= 1.0)
