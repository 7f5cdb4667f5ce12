"""SharedEncoderSAC: the temperature floor (``algo.ent_coef_min``)."""

import math

import pytest
import torch as th

from relmogen.agents.sac import SharedEncoderSAC
from relmogen.experiments.config import resolve_config
from relmogen.experiments.train import build_model, make_training_env


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
