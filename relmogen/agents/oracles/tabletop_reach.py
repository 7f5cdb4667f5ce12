"""TabletopReachM oracle: reach the marker's pixel with a zero-length push.

When an attempt finds no arm plan, the next one aims at a point a few centimetres from the
marker's centre (still well inside the 0.1 m success radius): a different IK solution
often has an easier path around the table edge.
"""

from __future__ import annotations

import numpy as np

from relmogen.agents.oracles.base import Oracle, arm_action, register_oracle

RETRY_OFFSET = 0.04  # m from the marker centre on later attempts


@register_oracle
class TabletopReachOracle(Oracle):
    task_name = "TabletopReachM"

    def reset(self) -> None:
        self._attempt = 0

    def act(self, obs: dict) -> np.ndarray:
        angle = self._attempt * np.pi / 2
        offset = RETRY_OFFSET * min(self._attempt, 1) * np.array([np.cos(angle), np.sin(angle), 0.0])
        self._attempt += 1
        action = arm_action(self.env, self.env.task.goal + offset, np.zeros(3))
        if action is None:  # not in view: cannot happen with the tabletop head tilt, but be safe
            return np.array([-1, 0, 0, 0, 0.5, 0, 0, 0], dtype=np.float32)
        return action
