"""Skip no-ops (``relmogen eval --skip-no-ops``; ours, a test-time rule never used in training).

A deterministic SGP-D policy whose subgoal changed nothing it sees gets the same observation
back and chooses the same subgoal until the episode ends. ``NoOpMemory`` excludes a subgoal
after which the view was unchanged (``relmogen.envs.relmogen_env.view_unchanged``) until the
view changes, so the policy falls back to its next best subgoal. ``relmogen.agents.dqn.env_policy``
applies it with ``skip_no_ops=True``; evaluations report it as its own policy
(``deterministic-skip-no-ops``).

Measured in ``results/sgpd-nstep-long``.
"""

from __future__ import annotations

import numpy as np

from relmogen.envs.relmogen_env import VIEW_KEYS, view_unchanged


class NoOpMemory:
    """The actions to exclude in each state of one episode; call ``clear`` at every episode start."""

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        self.previous: tuple[dict, int] | None = None
        self.excluded: list[int] = []

    def excluded_now(self, obs: dict) -> list[int]:
        """The actions to exclude in ``obs``, given the previous observation and action."""
        if self.previous is not None and view_unchanged(self.previous[0], obs):
            self.excluded.append(self.previous[1])
        else:
            self.excluded = []
        return self.excluded

    def chose(self, obs: dict, action: int) -> None:
        self.previous = ({key: np.array(obs[key]) for key in VIEW_KEYS if key in obs}, int(action))
