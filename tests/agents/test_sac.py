"""SharedEncoderSAC: the temperature floor (``algo.ent_coef_min``), the target entropy, the
encoder's input scaling and DrQ's random shift."""

import math

import numpy as np
import pytest
import torch as th

from relmogen.agents.networks import random_shift
from relmogen.agents.sac import SharedEncoderSAC
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.models import build_model


def tiny_sgpr(*overrides: str) -> SharedEncoderSAC:
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1, overrides=list(overrides))
    model = build_model(config, make_training_env(config))
    model.get_env().close()
    return model


def drive_temperature_down(model: SharedEncoderSAC, steps: int) -> list[float]:
    """Entropy far above the target pushes the learned temperature down at every step."""
    for group in model.ent_coef_optimizer.param_groups:
        group["lr"] = 0.5
    high_entropy = th.full((8, 1), -100.0)
    logs = {"ent_coef": [], "ent_coef_loss": []}
    for _ in range(steps):
        model._entropy_step(high_entropy, logs)
    return logs["ent_coef"]


def test_the_temperature_never_goes_below_the_floor_and_the_parameter_is_clamped():
    model = tiny_sgpr("algo.ent_coef_init=0.1", "algo.ent_coef_min=0.05")
    assert model.ent_coef_min == 0.05
    temperatures = drive_temperature_down(model, 20)
    assert min(temperatures) >= 0.05 - 1e-9
    assert temperatures[-1] == pytest.approx(0.05)
    assert model.log_ent_coef.item() == pytest.approx(math.log(0.05))


def test_without_a_floor_the_temperature_falls_freely():
    model = tiny_sgpr("algo.ent_coef_init=0.1")
    assert model.ent_coef_min == 0.0
    assert drive_temperature_down(model, 20)[-1] < 0.01


def test_a_negative_floor_is_rejected():
    with pytest.raises(ValueError, match="ent_coef_min"):
        resolve_config("PointNav", "relmogen-r", preset="tiny", overrides=["algo.ent_coef_min=-1"])


def test_the_target_entropy_comes_from_the_config_and_defaults_to_sb3s():
    assert tiny_sgpr("algo.target_entropy=-4").target_entropy == -4.0
    assert tiny_sgpr().target_entropy == -8.0  # SB3's -dim(A)


def fill_replay(model: SharedEncoderSAC, transitions: int) -> None:
    env = model.get_env()
    obs = env.reset()
    for _ in range(transitions):
        action = np.array([env.action_space.sample()])
        next_obs, reward, done, infos = env.step(action)
        model.replay_buffer.add(obs, next_obs, action, reward, done, infos)
        obs = next_obs


def test_input_scaling_is_fitted_once_on_the_replay_and_shared_with_the_target_encoder():
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1)
    model = build_model(config, make_training_env(config))
    model._setup_learn(total_timesteps=1)
    fill_replay(model, 12)
    encoder, target = model.critic.features_extractor, model.critic_target.features_extractor
    assert model.actor.features_extractor is encoder and not encoder.input_scaling_fitted
    model.train(gradient_steps=1, batch_size=8)
    task = th.as_tensor(model.replay_buffer.observations["task_obs"][: model.replay_buffer.pos, 0])
    assert encoder.input_scaling_fitted and target.input_scaling_fitted
    assert th.allclose(encoder.task_scaling.mean, task.mean(dim=0), atol=1e-5)
    assert th.equal(encoder.task_scaling.mean, target.task_scaling.mean)
    constant = task.std(dim=0) < 1e-3  # the tucked arm's joints while subgoals run
    assert constant.any() and th.all(encoder.task_scaling.std[constant] == 1.0)
    scaled = encoder.task_scaling(task)
    assert th.allclose(scaled[:, ~constant].std(dim=0), th.ones(int((~constant).sum())), atol=0.15)
    fitted_mean = encoder.task_scaling.mean.clone()
    fill_replay(model, 4)
    model.train(gradient_steps=1, batch_size=8)
    assert th.equal(encoder.task_scaling.mean, fitted_mean)  # never refitted
    model.get_env().close()


def test_subgoal_feedback_joins_the_task_branch_and_its_scaling():
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1,
                            overrides=["env.subgoal_feedback=true"])
    model = build_model(config, make_training_env(config))
    model._setup_learn(total_timesteps=1)
    fill_replay(model, 12)
    encoder = model.critic.features_extractor
    task_dim = model.observation_space["task_obs"].shape[0]
    assert encoder.task_keys == ["task_obs", "last_subgoal"]
    assert encoder.task[0].in_features == task_dim + 9 and encoder.task_scaling.mean.shape == (task_dim + 9,)
    model.train(gradient_steps=1, batch_size=8)
    feedback = th.as_tensor(model.replay_buffer.observations["last_subgoal"][: model.replay_buffer.pos, 0])
    assert th.allclose(encoder.task_scaling.mean[task_dim:], feedback.mean(dim=0), atol=1e-5)
    model.get_env().close()


def test_weights_saved_before_the_scaling_existed_load_as_the_identity():
    encoder = tiny_sgpr().critic.features_extractor
    old = {key: value for key, value in encoder.state_dict().items() if "_scaling." not in key}
    encoder.load_state_dict(old)
    assert encoder.input_scaling_fitted and th.all(encoder.task_scaling.std == 1) and th.all(encoder.scan_scaling.mean == 0)


def test_random_shift_moves_each_image_by_at_most_the_pad_with_edge_values():
    images = th.arange(2 * 4 * 6 * 6, dtype=th.float32).reshape(2, 4, 6, 6)
    th.manual_seed(0)
    shifted = random_shift(images, 2)
    assert shifted.shape == images.shape
    for index in range(2):
        padded = th.nn.functional.pad(images[index:index + 1], (2, 2, 2, 2), mode="replicate")[0]
        crops = [padded[:, r:r + 6, c:c + 6] for r in range(5) for c in range(5)]
        assert any(th.equal(shifted[index], crop) for crop in crops)
