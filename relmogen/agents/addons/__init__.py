"""Optional research add-ons to relmogen-d's masked Double DQN (``relmogen/agents/dqn.py``) and,
where the table says so, to the SAC family (``relmogen/agents/sac.py``).

All ours and off by default; each module says what it adds, where the idea comes from and
which results folder measured it.

| module                   | config key                      | how it composes                           |
|--------------------------|---------------------------------|-------------------------------------------|
| ``conservative``         | ``algo.conservative_weight``    | a ``LossTerm``                            |
| ``demonstration_margin`` | ``algo.demo_margin_weight``     | a ``LossTerm`` and a replay mixin         |
| ``kept_demonstrations``  | ``algo.demo_keep``              | a replay mixin                            |
| ``n_step``               | ``algo.n_step_returns``         | a replay mixin                            |
| ``oracle_labels``        | ``algo.oracle_labels``          | ``OracleLabeller``, called by the learner |
| ``boltzmann_exploration``| ``algo.exploration_temperature``| how ``RelmogenDQN.predict`` explores      |
| ``prioritized_replay``   | ``algo.priority_alpha``, ``_beta``| a replay mixin and the loss's weights   |
| ``skip_no_ops``          | ``relmogen eval --skip-no-ops`` | at test time only (SGP-R too)             |
| ``critic_select``        | ``relmogen eval --critic-select``| at test time only, SGP-R / SAC / OAC     |
| ``critic_layer_norm``    | ``algo.critic_layer_norm``      | SAC family: ``SharedEncoderSACPolicy.make_critic`` |

``dqn.py`` composes them: ``QMapReplayBuffer`` puts the replay mixins in front of the plain
``CellMaskReplayBuffer``, and ``RelmogenDQN`` builds its loss terms and labeller from its
constructor arguments. The add-ons import nothing from ``dqn.py`` at run time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import torch as th

if TYPE_CHECKING:
    from relmogen.agents.dqn import QMapReplaySamples

AllowedActions = Callable[[th.Tensor | None, int], th.Tensor]
"""``RelmogenDQN.allowed``: (N, 2, Q, Q) cell masks (None: every cell) and N -> (N, A) bool."""


@dataclass(frozen=True)
class LossTerm:
    """An extra loss on a batch's Q values: ``weight * value(...)`` joins the Huber TD loss and the
    mean value is logged as ``train/<name>``. ``value(q_values, taken, data, allowed)`` gets the
    online Q values (B, A), the taken actions' Q values (B, 1), the samples and ``allowed``."""

    name: str
    weight: float
    value: Callable[[th.Tensor, th.Tensor, QMapReplaySamples, AllowedActions], th.Tensor]
