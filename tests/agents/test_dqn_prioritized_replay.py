"""relmogen-d's prioritized replay (``relmogen/agents/addons/prioritized_replay.py``)."""

import pickle

import numpy as np
import pytest
import torch as th
from dqn_helpers import SMALL_NET, add_step, allowed_action_batch, make_env, tiny_buffer, updated_on_one_batch
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.addons.prioritized_replay import annealed_beta, use_prioritized_replay
from relmogen.agents.dqn import RelmogenDQN


def test_new_transitions_get_the_largest_priority_and_alpha_zero_samples_uniformly():
    buffer = tiny_buffer(8, keep=False)
    for row in range(4):
        add_step(buffer, row)
    np.testing.assert_array_equal(buffer.priorities[:, 0], [1, 1, 1, 1, 0, 0, 0, 0])
    buffer.priorities[:4, 0] = [1e-6, 1e-6, 1e-6, 3.0]
    np.random.seed(0)
    assert buffer.sample(2000).weights is None  # alpha 0: SB3's uniform sampling, no weights
    buffer.max_priority = 3.0
    add_step(buffer, 4)
    assert buffer.priorities[4, 0] == 3.0


def test_sampling_follows_priorities_to_the_power_alpha_with_importance_weights():
    buffer = tiny_buffer(8, keep=False)
    for row in range(4):
        add_step(buffer, row)
    buffer.priorities[:4, 0] = [1.0, 1.0, 1.0, 9.0]
    use_prioritized_replay(buffer, alpha=0.5, beta=1.0)  # weights 1, 1, 1, 3: P = 1/6, 1/6, 1/6, 1/2
    np.random.seed(0)
    data = buffer.sample(6000)
    actions = data.actions.numpy().ravel().astype(int)
    assert np.mean(actions == 3) == pytest.approx(0.5, abs=0.03)
    weights = data.weights.numpy().ravel()
    np.testing.assert_allclose(weights[actions == 3], 1 / 3, rtol=1e-5)  # (N P)^-1 over its max (N P_min)^-1
    np.testing.assert_allclose(weights[actions != 3], 1.0, rtol=1e-5)
    assert set(actions.tolist()) <= {0, 1, 2, 3}  # never an empty row


def test_update_priorities_sets_the_sampled_rows_to_their_td_errors():
    buffer = tiny_buffer(8, keep=False)
    for row in range(4):
        add_step(buffer, row)
    use_prioritized_replay(buffer, alpha=1.0, beta=0.4)
    np.random.seed(1)
    data = buffer.sample(3)
    rows = data.actions.numpy().ravel().astype(int)  # action = row here
    buffer.update_priorities(np.array([-2.0, 0.5, 4.0]))
    expected = dict(zip(rows.tolist(), [2.0, 0.5, 4.0]))  # a row drawn twice keeps its last error
    for row, priority in expected.items():
        assert buffer.priorities[row, 0] == pytest.approx(priority, abs=1e-5)
    assert buffer.max_priority == pytest.approx(max(expected.values()), abs=1e-5)
    buffer.update_priorities(np.array([9.0, 9.0, 9.0]))  # nothing sampled since: no change
    assert buffer.max_priority < 9.0


def test_priorities_survive_pickling_and_older_buffers_load_with_priority_one():
    buffer = tiny_buffer(8, keep=False)
    for row in range(3):
        add_step(buffer, row)
    buffer.priorities[1, 0] = 5.0
    loaded = pickle.loads(pickle.dumps(buffer))
    np.testing.assert_array_equal(loaded.priorities[:4, 0], [1, 5, 1, 0])
    state = {key: value for key, value in buffer.__dict__.items() if key not in ("priorities", "max_priority")}
    older = type(buffer).__new__(type(buffer))
    older.__setstate__(state)
    assert (older.priorities == 1).all() and older.max_priority == 1.0


def test_beta_rises_to_one_over_the_exploration_steps():
    assert annealed_beta(0.4, 0, 1000) == pytest.approx(0.4)
    assert annealed_beta(0.4, 500, 1000) == pytest.approx(0.7)
    assert annealed_beta(0.4, 5000, 1000) == pytest.approx(1.0)
    assert annealed_beta(0.4, 5000, None) == pytest.approx(0.4)


def test_importance_weights_scale_each_sample_loss():
    def halved(model):
        data = allowed_action_batch(model)
        return data._replace(weights=th.full((len(data.actions), 1), 0.5))

    weighted, _, _ = updated_on_one_batch(halved, updates=1)
    plain, _, _ = updated_on_one_batch(allowed_action_batch, updates=1)
    assert weighted["loss"][0] == pytest.approx(plain["loss"][0] / 2, rel=1e-5)  # same model, same batch


def test_learning_with_prioritized_replay_updates_the_sampled_priorities():
    model = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=300, batch_size=8, learning_starts=40, train_freq=4,
                        exploration_steps=100, policy_kwargs=SMALL_NET, seed=0, priority_alpha=0.6)
    model.learn(120)
    buffer = model.replay_buffer
    assert buffer.priority_alpha == 0.6 and buffer.priority_beta == pytest.approx(1.0)  # annealed by step 100
    stored = buffer.priorities[:120, 0]
    assert (stored > 0).all() and len(np.unique(stored)) > 10  # TD errors replaced the initial 1s
    assert np.isfinite(model.logger.name_to_value["train/loss"])
    model.env.close()
