"""Prioritized replay (``algo.priority_alpha`` = alpha > 0; ours, off by default).

Proportional prioritized experience replay (Schaul et al., 2016, "Prioritized Experience
Replay"; a Rainbow component): transition i is sampled with probability p_i^alpha / sum_k p_k^alpha,
where p_i is its latest absolute TD error (plus 1e-6) and a new transition gets the largest
priority seen so far, so it is replayed soon. The bias this sampling brings is undone by
importance weights (N P(i))^-beta, divided by their largest value in the buffer, on each sample's
Huber loss; beta rises linearly from ``algo.priority_beta`` to 1 over ``algo.exploration_steps``.

Why here: a ButtonDoorNav press (+5) is a rare transition (60 in the first 2,000 episodes of
the Boltzmann run, 0.1% of its 5e4-transition replay), and at a replay ratio of 8 each is
replayed about 8 times. After those 2,000 episodes the network valued pushes on the button cap
no higher than other pushes (``results/sgpd-explore/cap_values_boltzmann_ep2019.json``: the best
cap action at the 66th percentile). Large TD errors are what prioritized replay replays more.

Measured in ``results/sgpd-explore`` (ninth session), ButtonDoorNav seed 0 on the Boltzmann recipe:
the best cap action rose to the 98.8th percentile by episode 560 (91st at 964), but it never became
the best arm action, presses did not rise (18 in 964 episodes, against 30 in 1,000 without it), and
the periodic greedy SR stayed 0.0.

Sampling draws from the flat (rows x environments) priorities with ``numpy.random.choice``: at
5e4 transitions that is well under a millisecond, against about 0.1 s per update, so no sum
tree is needed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th

PRIORITY_FLOOR = 1e-6  # every stored transition keeps a chance to be replayed


class PrioritizedRows:
    """Replay-buffer mixin (after ``DemonstrationRows``, whose ``add`` may move ``pos``):
    ``priorities`` (rows, n_envs). With ``priority_alpha`` > 0 (set by the learner before
    sampling, ``use_prioritized_replay``), ``sample`` draws by priority and its samples carry
    importance ``weights``; ``update_priorities`` then gives the sampled transitions their new TD
    errors. With alpha = 0 sampling is uniform, as without it."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.priority_alpha, self.priority_beta, self.max_priority = 0.0, 1.0, 1.0
        self.priorities = np.zeros((self.buffer_size, self.n_envs), dtype=np.float32)
        self._sampled: tuple[np.ndarray, np.ndarray] | None = None

    def upgraded_state(self, state: dict) -> dict:
        """A buffer pickled before priorities: its stored transitions all get priority 1."""
        state = {"priority_alpha": 0.0, "priority_beta": 1.0, "max_priority": 1.0, "_sampled": None, **state}
        if "priorities" not in state:
            state["priorities"] = np.ones((state["buffer_size"], state["n_envs"]), dtype=np.float32)
        return super().upgraded_state(state)

    def nbytes(self) -> int:
        return super().nbytes() + self.priorities.nbytes

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        self.priorities[self.pos] = self.max_priority
        super().add(obs, next_obs, action, reward, done, infos)

    def sample(self, batch_size: int, env=None):
        if self.priority_alpha <= 0:
            return super().sample(batch_size, env=env)
        filled = self.buffer_size if self.full else self.pos
        weights = self.priorities[:filled].astype(np.float64).ravel() ** self.priority_alpha
        probabilities = weights / weights.sum()
        flat = np.random.choice(probabilities.size, size=batch_size, p=probabilities)
        rows, envs = np.divmod(flat, self.n_envs)
        smallest = probabilities[probabilities > 0].min()
        importance = (probabilities[flat] / smallest) ** -self.priority_beta  # (N P)^-beta over its max
        self._sampled = (rows, envs)
        samples = self.samples_at(rows, envs, env)
        return samples._replace(weights=self.to_torch(importance.astype(np.float32)).reshape(-1, 1))

    def update_priorities(self, td_errors: np.ndarray) -> None:
        """The last sampled transitions' new priorities: their (B,) absolute TD errors."""
        if self._sampled is None:
            return
        priorities = np.abs(np.asarray(td_errors, dtype=np.float32)).reshape(-1) + PRIORITY_FLOOR
        self.priorities[self._sampled] = priorities
        self.max_priority = max(self.max_priority, float(priorities.max()))
        self._sampled = None


def use_prioritized_replay(replay_buffer, alpha: float, beta: float) -> None:
    """Tell a ``PrioritizedRows`` replay the exponents to sample with (both may change on a resume)."""
    if isinstance(replay_buffer, PrioritizedRows):
        replay_buffer.priority_alpha, replay_buffer.priority_beta = alpha, beta


def annealed_beta(initial: float, timesteps: int, steps: int | None) -> float:
    """Beta rising linearly from ``initial`` to 1 over ``steps`` environment steps (constant without them)."""
    if not steps:
        return initial
    return initial + min(1.0, timesteps / steps) * (1.0 - initial)


def weighted_td_loss(errors: th.Tensor, weights: th.Tensor | None) -> th.Tensor:
    """Mean of the per-sample losses, each times its importance weight when there are weights."""
    return errors.mean() if weights is None else (weights * errors).mean()
