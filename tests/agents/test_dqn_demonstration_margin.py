"""relmogen-d's demonstration margin (``relmogen/agents/addons/demonstration_margin.py``): expert
labels in the replay and DQfD's large-margin loss on them."""

import numpy as np
import pytest
import torch as th
from dqn_helpers import add_rows, add_step, allowed_action_batch, tiny_buffer, updated_on_one_batch

from relmogen.agents.addons.demonstration_margin import DQFD_MARGIN, demonstration_margin
from relmogen.agents.dqn import QMapReplayBuffer, QMapReplaySamples, allowed_actions, masked_argmax

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_rows_carry_expert_labels_into_their_samples():
    buffer = tiny_buffer(8, keep=False)
    add_rows(buffer, [20, 21], demonstrations=True)  # a demonstration is labelled by its own action
    buffer.acting_labels = np.array([3])
    add_step(buffer, 9)  # a policy step with the oracle's label
    add_step(buffer, 10)  # and one without
    assert buffer.labels[:4, 0].tolist() == [20, 21, 3, -1] and buffer.acting_labels is None
    assert buffer._get_samples(np.array([0, 2, 3])).labels.tolist() == [20, 3, -1]
    state = dict(vars(buffer))
    del state["labels"]  # a buffer saved before labels: its demonstrations get their own actions
    old = QMapReplayBuffer.__new__(QMapReplayBuffer)
    old.__setstate__(state)
    assert old.labels[:4, 0].tolist() == [20, 21, -1, -1]


def demonstration_batch(model, n: int = 6) -> QMapReplaySamples:
    data = allowed_action_batch(model, n)
    demo = th.tensor([True, False] * (n // 2))
    return data._replace(labels=th.where(demo, data.actions.reshape(-1), -1))


def test_demonstration_margin_is_dqfds_large_margin_loss_on_demonstration_rows(model):
    data = demonstration_batch(model)
    with th.no_grad():
        q_values = model.q_net(data.observations)
        margin = demonstration_margin(q_values, q_values.gather(1, data.actions), data, model.allowed)
    allowed = allowed_actions(data.masks, model.subgoal_parts)
    expected = []
    for b in np.flatnonzero(data.labels.numpy() >= 0):
        action = int(data.labels[b])
        others = allowed[b].clone()
        others[action] = False
        best_other = float(q_values[b][others].max()) + DQFD_MARGIN
        expected.append(max(best_other, float(q_values[b, action])) - float(q_values[b, action]))
    assert float(margin) == pytest.approx(np.mean(expected), rel=1e-5)
    taken = q_values.gather(1, data.actions)
    assert float(demonstration_margin(q_values, taken, data._replace(labels=th.full((6,), -1)), model.allowed)) == 0.0
    relabelled = data._replace(labels=th.where(data.labels >= 0, (data.labels + 1) % model.action_space.n, -1))
    # the margin follows the labels, not the stored actions
    assert float(demonstration_margin(q_values, taken, relabelled, model.allowed)) != pytest.approx(float(margin))


def test_margin_updates_make_each_demonstrated_action_the_greedy_one():
    losses, q_values, data = updated_on_one_batch(demonstration_batch, 40, demo_margin_weight=5.0)
    margins = losses["demo_margin_loss"]
    greedy = masked_argmax(q_values, allowed_actions(data.masks))
    assert margins[0] > DQFD_MARGIN and margins[-1] < 0.1 * margins[0]
    demo = data.labels.numpy() >= 0
    np.testing.assert_array_equal(greedy.numpy()[demo], data.labels.numpy()[demo])
