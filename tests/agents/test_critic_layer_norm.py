"""``algo.critic_layer_norm`` (relmogen/agents/addons/critic_layer_norm.py): LayerNorm after each
hidden Linear of every Q network of the critic and its target, trained by the usual gradient step
and kept by a saved model; refused by the algorithms that do not read it."""

import pytest
import torch as th
from torch import nn

from relmogen.agents.addons.critic_layer_norm import with_layer_norm
from relmogen.agents.sac import SharedEncoderSAC
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.models import build_model

from tests.agents.test_sac import fill_replay


def tiny_sgpr(*overrides: str) -> SharedEncoderSAC:
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1, overrides=list(overrides))
    return build_model(config, make_training_env(config))


def q_networks(model: SharedEncoderSAC) -> list[nn.Sequential]:
    return [*model.critic.q_networks, *model.critic_target.q_networks]


@pytest.fixture(scope="module")
def normalised():
    model = tiny_sgpr("algo.critic_layer_norm=true")
    yield model
    model.get_env().close()


def test_each_hidden_linear_of_each_q_network_is_followed_by_a_layer_norm_and_the_output_is_not(normalised):
    assert normalised.policy.critic_layer_norm and len(q_networks(normalised)) == 4
    for q_net in q_networks(normalised):
        modules = list(q_net)
        linears = [i for i, module in enumerate(modules) if isinstance(module, nn.Linear)]
        assert len(linears) == len(normalised.policy.net_arch) + 1
        for i in linears[:-1]:
            assert isinstance(modules[i + 1], nn.LayerNorm) and modules[i + 1].normalized_shape == (
                modules[i].out_features,)
            assert isinstance(modules[i + 2], nn.ReLU)  # before the activation
        assert linears[-1] == len(modules) - 1 and modules[-1].out_features == 1
    # the registered submodules are the ones the gradient step calls (_q_from_features)
    assert [normalised.critic.qf0, normalised.critic.qf1] == normalised.critic.q_networks
    assert normalised.critic.state_dict().keys() == normalised.critic_target.state_dict().keys()


def test_by_default_there_is_no_layer_norm():
    model = tiny_sgpr()
    model.get_env().close()
    assert not model.policy.critic_layer_norm and "critic_layer_norm" not in model.policy_kwargs
    assert not any(isinstance(module, nn.LayerNorm) for module in model.policy.modules())


def test_with_layer_norm_keeps_the_layers_and_adds_none_after_the_output():
    q_net = nn.Sequential(nn.Linear(3, 4), nn.ReLU(), nn.Linear(4, 1))
    normalised = with_layer_norm(q_net)
    assert [type(module) for module in normalised] == [nn.Linear, nn.LayerNorm, nn.ReLU, nn.Linear]
    assert normalised[0] is q_net[0] and normalised[3] is q_net[2]


def test_gradient_steps_train_the_critics_layer_norms(normalised):
    normalised._setup_learn(total_timesteps=1)
    fill_replay(normalised, 12)
    norms = [module for module in normalised.critic.modules() if isinstance(module, nn.LayerNorm)]
    before = [norm.weight.detach().clone() for norm in norms]
    normalised.train(gradient_steps=2, batch_size=8)
    assert all(not th.equal(norm.weight, weight) for norm, weight in zip(norms, before))
    assert all(th.isfinite(norm.weight).all() for norm in norms)


def test_a_saved_model_reloads_with_its_layer_norms(normalised, tmp_path):
    normalised.save(tmp_path / "model.zip")
    loaded = SharedEncoderSAC.load(tmp_path / "model.zip", device="cpu")
    assert loaded.policy.critic_layer_norm
    for part in ("critic", "critic_target"):
        saved, reloaded = getattr(normalised, part).state_dict(), getattr(loaded, part).state_dict()
        assert reloaded.keys() == saved.keys()
        assert "qf0.1.weight" in reloaded  # qf0.0 Linear, qf0.1 LayerNorm
        assert all(th.equal(reloaded[key], saved[key]) for key in saved)


def test_relmogen_d_refuses_the_key():
    with pytest.raises(ValueError) as error:
        resolve_config("PointNav", "relmogen-d", preset="tiny", overrides=["algo.critic_layer_norm=true"])
    assert str(error.value) == ("--set algo.critic_layer_norm=true: algo.critic_layer_norm: relmogen-r, sac, oac, "
                                "hrl4in only, not relmogen-d")


def test_hrl4in_builds_both_levels_with_layer_norm():
    from relmogen.agents.hrl4in import build_hrl4in
    from relmogen.experiments.environments import make_training_env

    config = resolve_config("PointNav", "hrl4in", preset="tiny", episodes=1, overrides=["algo.critic_layer_norm=true"])
    env = make_training_env(config)
    try:
        model = build_hrl4in(config, env, "cpu")
        for level in (model.high, model.low):
            assert any(isinstance(module, th.nn.LayerNorm) for module in level.critic.modules())
    finally:
        env.close()


@pytest.mark.parametrize("algo", ["sac", "oac"])
def test_the_other_sac_family_algorithms_take_the_key(algo):
    config = resolve_config("PointNav", algo, preset="tiny", overrides=["algo.critic_layer_norm=true"])
    assert config.algo_params.critic_layer_norm
