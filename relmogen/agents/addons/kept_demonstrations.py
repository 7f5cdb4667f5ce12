"""Kept demonstrations (``algo.demo_keep``, the replay's ``keep_demonstrations``; ours, off by default).

``relmogen.agents.demonstrations.add_demonstrations`` puts ``algo.demo_episodes`` episodes of
the task's oracle into the replay with ``adding_demonstrations`` set; ``DemonstrationRows`` marks
those rows in ``demo``. With ``keep_demonstrations`` the ring skips them, so they stay for the
whole run, as DQfD keeps its demonstrations (Hester et al., 2018, "Deep Q-learning from
Demonstrations"); ``relmogen.agents.replay.resize_replay_buffer`` never drops them either.

Measured in ``results/sgpd-dqfd`` (with the margin term): 1,792-2,482 of the 10,000
transitions in the replay stayed demonstrations. Without keeping them (``results/sgpd-demos``)
the 10k replay had overwritten them by about episode 350.
"""

from __future__ import annotations

from typing import Any

import numpy as np


class DemonstrationRows:
    """Replay-buffer mixin (first, in front of ``CellMaskReplayBuffer``): ``demo`` (rows,) marks the
    rows added while ``adding_demonstrations`` is set; with ``keep_demonstrations`` new rows go
    past them."""

    def __init__(self, *args: Any, keep_demonstrations: bool = False, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.keep_demonstrations = bool(keep_demonstrations)
        self.adding_demonstrations = False
        self.demo = np.zeros(self.buffer_size, dtype=bool)

    def upgraded_state(self, state: dict) -> dict:
        """A buffer pickled before demonstration rows: none of its rows is one."""
        state = {"keep_demonstrations": False, "adding_demonstrations": False, **state}
        if "demo" not in state:
            state["demo"] = np.zeros(state["buffer_size"], dtype=bool)
        return super().upgraded_state(state)

    def nbytes(self) -> int:
        return super().nbytes() + self.demo.nbytes

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        if self.keep_demonstrations:
            self._skip_demonstration_rows()
        self.demo[self.pos] = self.adding_demonstrations
        super().add(obs, next_obs, action, reward, done, infos)

    def _skip_demonstration_rows(self) -> None:
        """Move ``pos`` past kept demonstration rows (wrapping round as SB3's ``add`` does)."""
        for _ in range(self.buffer_size):
            if not self.demo[self.pos]:
                return
            self.pos = (self.pos + 1) % self.buffer_size
            self.full = self.full or self.pos == 0
        raise ValueError(f"demonstrations fill all {self.buffer_size} rows of the replay buffer: raise "
                         "algo.buffer_size or lower algo.demo_episodes")
