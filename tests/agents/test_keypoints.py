"""The keypoint image branch (agents/keypoints.py) and its encoder option."""

import pytest
import torch as th

from relmogen.agents.keypoints import SpatialSoftmax, keypoint_image_branch
from relmogen.agents.networks import SGPREncoder
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.models import build_model
from tests.agents.test_sac import fill_replay, tiny_sgpr


def test_a_peaked_channel_gives_the_position_of_its_peak_in_minus_one_to_one():
    softmax = SpatialSoftmax(height=3, width=5)
    features = th.full((2, 1, 3, 5), -100.0)
    features[0, 0, 0, 4] = 100.0  # top right
    features[1, 0, 2, 0] = 100.0  # bottom left
    assert th.allclose(softmax(features), th.tensor([[1.0, -1.0], [-1.0, 1.0]]), atol=1e-5)


def test_a_flat_channel_gives_the_image_centre():
    assert th.allclose(SpatialSoftmax(4, 6)(th.zeros(1, 3, 4, 6)), th.zeros(1, 6), atol=1e-6)


def test_the_branch_maps_images_to_two_coordinates_per_channel_then_the_output_width():
    conv, fc = keypoint_image_branch(4, 64, 64, out_dim=256, channels=16)
    keypoints = conv(th.rand(3, 4, 64, 64))
    assert keypoints.shape == (3, 32) and keypoints.abs().max() <= 1.0
    assert fc(keypoints).shape == (3, 256)


def test_the_encoder_option_builds_the_keypoint_branch_that_the_critic_trains():
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1,
                            overrides=["algo.image_encoder=keypoints"])
    model = build_model(config, make_training_env(config))
    model._setup_learn(total_timesteps=1)
    encoder = model.critic.features_extractor
    softmax = next(module for module in encoder.image_conv if isinstance(module, SpatialSoftmax))
    fill_replay(model, 16)
    before = softmax.log_temperature.item()
    model.train(gradient_steps=2, batch_size=8)
    model.get_env().close()
    assert softmax.log_temperature.item() != before


def test_an_unknown_image_encoder_is_refused():
    model = tiny_sgpr()
    with pytest.raises(ValueError, match="image_encoder must be one of"):
        SGPREncoder(model.observation_space, image_encoder="resnet")
