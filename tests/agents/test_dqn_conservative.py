"""relmogen-d's conservative term (``relmogen/agents/addons/conservative.py``): CQL(H) over the allowed actions."""

import numpy as np
import pytest
import torch as th
from dqn_helpers import allowed_action_batch, updated_on_one_batch

from relmogen.agents.addons.conservative import conservative_gap
from relmogen.agents.dqn import allowed_actions

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_conservative_gap_is_logsumexp_over_allowed_actions_minus_the_taken_one(model):
    data = allowed_action_batch(model)
    with th.no_grad():
        q_values = model.q_net(data.observations)
        taken = q_values.gather(1, data.actions)
        gap = conservative_gap(q_values, taken, data, model.allowed)
    allowed = allowed_actions(data.masks, model.subgoal_parts)
    expected = np.mean([float(th.logsumexp(q_values[b][allowed[b]], 0) - taken[b]) for b in range(len(taken))])
    assert float(gap) == pytest.approx(expected, rel=1e-5)
    everything = conservative_gap(q_values, taken, data._replace(masks=th.ones_like(data.masks)), model.allowed)
    assert float(everything) > float(gap)  # masked cells are left out of the logsumexp


def test_conservative_updates_lower_untried_actions_below_the_taken_ones():
    losses, q_values, data = updated_on_one_batch(allowed_action_batch, 30, conservative_weight=5.0)
    gaps = losses["conservative_gap"]
    allowed = allowed_actions(data.masks)
    assert min(gaps) >= 0 and gaps[-1] < gaps[0] - 1.0  # from about log(60 allowed actions) = 4.1
    for b, action in enumerate(data.actions.ravel()):
        others = allowed[b].clone()
        others[action] = False
        assert q_values[b, action] > q_values[b][others].mean() + 1.0
