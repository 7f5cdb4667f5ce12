"""TabletopReachM oracle: reach the marker's pixel with a zero-length push."""

from __future__ import annotations

import numpy as np

from relmogen.agents.oracles.base import Oracle, arm_action, register_oracle


@register_oracle
class TabletopReachOracle(Oracle):
    task_name = "TabletopReachM"

    def act(self, obs: dict) -> np.ndarray:
        action = arm_action(self.env, self.env.task.goal, np.zeros(3))
        if action is None:  # not in view: cannot happen with the tabletop head tilt, but be safe
            return np.array([-1, 0, 0, 0, 0.5, 0, 0, 0], dtype=np.float32)
        return action
