"""Demonstration margin (``algo.demo_margin_weight`` > 0; ours, off by default).

DQfD's supervised large-margin term (Hester et al., 2018, "Deep Q-learning from
Demonstrations") on the batch's labelled rows makes the expert's action a_E exceed every other
allowed action by ``DQFD_MARGIN``: ``max_a [Q(s, a) + 0.8 [a != a_E]] - Q(s, a_E)``. The ``cpu``
preset's 16 x 16 maps hold 3,072 arm actions, and a demonstrated press is one of them: the TD
loss alone left the few demonstrated presses below their untried neighbours
(``results/sgpd-demos``).

``ExpertLabels`` keeps a_E per replay row: a demonstration row's own action
(``algo.demo_episodes``, marked by ``kept_demonstrations.DemonstrationRows``), or the oracle's
label of a policy state (``oracle_labels``); -1 for none.

Measured in ``results/sgpd-dqfd`` (with kept demonstrations; weight 1, DQfD's) and
``results/sgpd-dqfd-4h`` (the ArrangeKitchenMM runs continued to 4 h).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import torch as th
from torch.nn import functional as F

from relmogen.agents.addons import AllowedActions, LossTerm

if TYPE_CHECKING:
    from relmogen.agents.dqn import QMapReplaySamples

DQFD_MARGIN = 0.8  # the expert margin of DQfD (Hester et al., 2018)
NAME = "demo_margin_loss"
NO_LABEL = -1


def demonstration_margin(q_values: th.Tensor, taken: th.Tensor, data: QMapReplaySamples,
                         allowed: AllowedActions) -> th.Tensor:
    """DQfD's large-margin loss, mean over the batch's labelled rows (0 without any): max over
    allowed a of [Q(s, a) + 0.8 if a is not the expert's a_E] minus Q(s, a_E). a_E is
    ``data.labels``, not the taken action: a demonstration's own action or the oracle's label."""
    labelled = data.labels >= 0 if data.labels is not None else None
    if labelled is None or not labelled.any():
        return th.zeros((), device=q_values.device)
    q_values, expert_action = q_values[labelled], data.labels.long()[labelled].reshape(-1, 1)
    expert = F.one_hot(expert_action.reshape(-1), q_values.shape[1]).bool()
    masks = data.masks[labelled] if data.masks is not None else None
    permitted = allowed(masks, q_values.shape[0]) | expert
    best = (q_values + DQFD_MARGIN * ~expert).masked_fill(~permitted, -th.inf).max(dim=1).values
    return (best - q_values.gather(1, expert_action).reshape(-1)).mean()


def demonstration_margin_term(weight: float) -> LossTerm:
    return LossTerm(NAME, weight, demonstration_margin)


class ExpertLabels:
    """Replay-buffer mixin (in front of ``CellMaskReplayBuffer``, behind ``DemonstrationRows``):
    ``labels`` (rows, n_envs) holds each transition's expert action, ``NO_LABEL`` for none. Rows
    added while ``adding_demonstrations`` is set are labelled by their own action; others by
    ``acting_labels`` when set before ``add`` (``OracleLabeller.hand_over``). Samples carry them
    as ``labels``."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.acting_labels: np.ndarray | None = None
        self.labels = np.full((self.buffer_size, self.n_envs), NO_LABEL, dtype=np.int64)

    def upgraded_state(self, state: dict) -> dict:
        """A buffer pickled before labels: its demonstration rows get their own actions."""
        state = {"acting_labels": None, **state}
        if "labels" not in state:
            state["labels"] = np.where(state["demo"][:, None], state["actions"][..., 0], NO_LABEL).astype(np.int64)
        return super().upgraded_state(state)

    def nbytes(self) -> int:
        return super().nbytes() + self.labels.nbytes

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        self.labels[self.pos] = self._labels_of(action)
        super().add(obs, next_obs, action, reward, done, infos)

    def _labels_of(self, action) -> np.ndarray | int:
        """The expert actions of the row being added: its own for demonstrations, else ``acting_labels``."""
        labels = np.asarray(action).reshape(self.n_envs) if self.adding_demonstrations else self.acting_labels
        self.acting_labels = None
        return NO_LABEL if labels is None else labels

    def samples_at(self, batch_inds: np.ndarray, envs: np.ndarray, env=None) -> QMapReplaySamples:
        samples = super().samples_at(batch_inds, envs, env)
        return samples._replace(labels=self.to_torch(self.labels[batch_inds, envs]))
