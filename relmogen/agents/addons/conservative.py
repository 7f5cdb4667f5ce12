"""Conservative term (``algo.conservative_weight`` > 0; ours, off by default).

Adds ``weight * (logsumexp_a Q(s, a) - Q(s, a_taken))`` over the allowed actions of the stored
state (the masks its action was chosen under, ``CellMaskReplayBuffer.masks``) to the Huber loss:
the discrete CQL(H) regulariser of Kumar et al. (2020), "Conservative Q-Learning for Offline
Reinforcement Learning". With ~3,000 arm actions of which a replay has tried few, Double DQN
targets still bootstrap from the untried ones; the term pushes those down and the taken ones up.

Measured in ``results/sgpd-cql``: offline on the ``sgpd-button`` replays it lowered the button
cell in the arm Q map further (36th to 25th percentile), so overestimation was not the limit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import torch as th

from relmogen.agents.addons import AllowedActions, LossTerm

if TYPE_CHECKING:
    from relmogen.agents.dqn import QMapReplaySamples

NAME = "conservative_gap"


def conservative_gap(q_values: th.Tensor, taken: th.Tensor, data: QMapReplaySamples,
                     allowed: AllowedActions) -> th.Tensor:
    """Mean over the batch of logsumexp over the stored state's allowed actions of Q(s, .) minus Q(s, a_taken)."""
    permitted = allowed(data.masks, q_values.shape[0])
    return (q_values.masked_fill(~permitted, -th.inf).logsumexp(dim=1, keepdim=True) - taken).mean()


def conservative_term(weight: float) -> LossTerm:
    return LossTerm(NAME, weight, conservative_gap)
