"""relmogen-d's Boltzmann exploration (``relmogen/agents/addons/boltzmann_exploration.py``)."""

import numpy as np
import pytest
import torch as th
from dqn_helpers import Q, assert_base_actions_free, few_free_cells, random_batch

from relmogen.agents.addons.boltzmann_exploration import boltzmann_sample
from relmogen.envs.subgoal_controls import YAW_BINS

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_samples_follow_the_softmax_of_the_allowed_actions():
    th.manual_seed(0)
    q_values = th.tensor([[0.0, np.log(3.0), 100.0, 0.0]]).repeat(4000, 1)
    allowed = th.tensor([[True, True, False, False]]).repeat(4000, 1)
    actions = boltzmann_sample(q_values, allowed, temperature=1.0)
    assert set(actions.tolist()) <= {0, 1}  # the disallowed 100 is never drawn
    assert np.mean(actions == 1) == pytest.approx(0.75, abs=0.03)  # e^log3 / (1 + e^log3)
    colder = boltzmann_sample(q_values, allowed, temperature=0.05)
    assert (colder == 1).all()


def test_a_temperature_must_be_positive():
    with pytest.raises(ValueError, match="positive"):
        boltzmann_sample(th.zeros(1, 2), th.ones(1, 2, dtype=th.bool), 0.0)


def test_exploring_by_temperature_keeps_the_masks_and_prefers_high_q_actions(model):
    n = 300
    obs = {key: value.numpy() for key, value in random_batch(model.observation_space, n).items()}
    masks = few_free_cells(n)
    head = model.q_net.net.head[-1]
    saved = head.bias.detach().clone()
    model.exploration_rate, model.exploration_temperature = 1.0, 0.5
    try:
        with th.no_grad():
            head.bias[:YAW_BINS] += 20.0  # every base action far above every arm action
        actions, _ = model.predict(obs, deterministic=False, masks=masks)
    finally:
        with th.no_grad():
            head.bias.copy_(saved)
        model.exploration_rate, model.exploration_temperature = 0.0, 0.0
    assert assert_base_actions_free(actions, masks) == n  # base cells only, and only free ones
    assert len(set((actions % (Q * Q)).tolist())) > 1  # still a draw, not the argmax
