"""relmogen-d's n-step returns (``relmogen/agents/addons/n_step.py``): windows, discounts, bootstrap rows."""

import numpy as np
from dqn_helpers import add_step, tiny_buffer

from relmogen.agents.dqn import QMapReplayBuffer


def n_step_samples(buffer: QMapReplayBuffer, rows) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    data = buffer._get_samples(np.array(rows))
    discounts = None if data.discounts is None else data.discounts.numpy().ravel()
    return (data.rewards.numpy().ravel(), discounts, data.dones.numpy().ravel(),
            data.next_observations["depth"][:, 0, 0, 0].numpy())


def test_n_step_targets_sum_rewards_up_to_the_episode_end_and_bootstrap_from_the_last_state():
    buffer = tiny_buffer(8, keep=False)
    buffer.n_step_returns, buffer.gamma = 3, 0.5
    for row, reward in enumerate([1, 2, 3, 4, 5, 6]):  # terminal at row 2, time limit at row 4; row 5 is the newest
        add_step(buffer, row, reward, done=row == 2, timeout=row == 4)
    rewards, discounts, dones, bootstrap_rows = n_step_samples(buffer, range(6))
    np.testing.assert_allclose(rewards, [1 + 0.5 * 2 + 0.25 * 3, 2 + 0.5 * 3, 3, 4 + 0.5 * 5, 5, 6])
    np.testing.assert_allclose(discounts, [0.125, 0.25, 0.5, 0.25, 0.5, 0.5])
    np.testing.assert_array_equal(dones, [1, 1, 1, 0, 0, 0])  # a time limit still bootstraps
    np.testing.assert_array_equal(bootstrap_rows, [2, 2, 2, 4, 4, 5])
    buffer.n_step_returns = 1
    rewards, discounts, _, bootstrap_rows = n_step_samples(buffer, range(6))
    assert discounts is None  # one-step samples as before: the algorithm's gamma applies
    np.testing.assert_array_equal(rewards, [1, 2, 3, 4, 5, 6])
    np.testing.assert_array_equal(bootstrap_rows, range(6))


def test_n_step_windows_stop_where_kept_demonstrations_border_policy_rows():
    buffer = tiny_buffer(6, keep=True)
    buffer.n_step_returns, buffer.gamma = 3, 0.5
    add_step(buffer, 0, 1.0, demo=True)
    add_step(buffer, 1, 1.0, demo=True)  # the demonstration block ends without an episode end
    for row in range(10, 15):  # 5 policy rows in 4 free rows: the newest, 14, goes to row 2
        add_step(buffer, row, 1.0)
    assert buffer.actions[:, 0, 0].astype(int).tolist() == [0, 1, 14, 11, 12, 13]
    rewards, discounts, _, bootstrap_rows = n_step_samples(buffer, [5, 1, 2, 3, 0])
    np.testing.assert_array_equal(bootstrap_rows, [13, 1, 14, 13, 1])
    np.testing.assert_allclose(discounts, [0.5, 0.5, 0.5, 0.125, 0.25])
    np.testing.assert_allclose(rewards, [1, 1, 1, 1.75, 1.5])
