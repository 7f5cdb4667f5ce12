"""N-step returns (``algo.n_step_returns`` = n > 1; ours, off by default; DQfD and Rainbow use them).

The target of a stored transition sums the discounted rewards of up to n consecutive stored
steps of its environment and bootstraps with gamma^k from the k-th next state (k <= n, fewer at
an episode end, at the newest row and where kept demonstration rows border policy rows): the
multi-step targets of Rainbow (Hessel et al., 2018) and DQfD (Hester et al., 2018). A +10
success reaches the press that made it possible in one update instead of n; and a subgoal that
changes nothing, repeated (its next state is its own state), loses value gamma^n per target
update instead of gamma. ``NStepReturns`` computes the windows at sampling time from the rows
the replay already stores, as SB3's ``NStepReplayBuffer`` does (which does not take Dict
observations); samples carry their own ``discounts``, which ``RelmogenDQN.double_dqn_targets``
uses in place of gamma.

Measured in ``results/sgpd-nstep`` (n = 5, on top of kept demonstrations and the margin term)
and ``results/sgpd-nstep-long`` (the same with twice the compute per run).
"""

from __future__ import annotations

from typing import Any

import numpy as np


class NStepReturns:
    """Replay-buffer mixin (in front of ``CellMaskReplayBuffer``; window borders read the ``demo``
    rows of ``DemonstrationRows``). ``n_step_returns`` and ``gamma`` are set by the learner
    before sampling (``use_n_step_returns``); with n = 1 samples are one-step, as without it."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.n_step_returns, self.gamma = 1, 0.99

    def upgraded_state(self, state: dict) -> dict:
        return super().upgraded_state({"n_step_returns": 1, "gamma": 0.99, **state})

    def returns(self, batch_inds: np.ndarray, envs: np.ndarray, env=None):
        """(B,) n-step rewards, (B,) their discounts gamma^k and the (B,) rows to bootstrap from."""
        if self.n_step_returns == 1:
            return super().returns(batch_inds, envs, env)
        rows = self.n_step_rows(batch_inds, envs)  # (B, n): the steps each target sums, rows[:, 0] = batch_inds
        steps = (rows >= 0).sum(axis=1)
        last = rows[np.arange(len(rows)), steps - 1]
        weights = np.where(rows >= 0, self.gamma ** np.arange(rows.shape[1], dtype=np.float32), 0.0)
        rewards = (self._normalize_reward(self.rewards[rows, envs[:, None]], env) * weights).sum(axis=1)
        return rewards.astype(np.float32), (self.gamma ** steps).astype(np.float32), last

    def n_step_rows(self, batch_inds: np.ndarray, envs: np.ndarray) -> np.ndarray:
        """(B, n) rows of the up to ``n_step_returns`` consecutive steps starting at each sampled row,
        -1 past the window's end: the environment's episode end (terminal or time limit), the newest
        row (the next one is older), or a row whose ``demo`` flag differs (the ring skipped kept
        demonstrations there)."""
        rows = (batch_inds[:, None] + np.arange(self.n_step_returns)) % self.buffer_size
        last_step = self.dones[rows, envs[:, None]].astype(bool) | (rows == (self.pos - 1) % self.buffer_size)
        last_step[:, :-1] |= self.demo[rows[:, 1:]] != self.demo[rows[:, :-1]]
        after_end = np.cumsum(last_step, axis=1) - last_step > 0
        return np.where(after_end, -1, rows)


def use_n_step_returns(replay_buffer, n_step_returns: int, gamma: float) -> None:
    """Tell an ``NStepReturns`` replay the horizon and discount to sample with (both may change on a
    resume); other replays are left as they are."""
    if isinstance(replay_buffer, NStepReturns):
        replay_buffer.n_step_returns, replay_buffer.gamma = n_step_returns, gamma
