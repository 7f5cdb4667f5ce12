"""PointNav oracle: hop along the shortest path on the static floor plan."""

from __future__ import annotations

import numpy as np

from relmogen.agents.oracles.base import Oracle, base_action, register_oracle

LOOKAHEADS = (10, 7, 4, 2)  # waypoints (0.2 m apart) to aim at; shorter after a failed plan


@register_oracle
class PointNavOracle(Oracle):
    task_name = "PointNav"

    def reset(self) -> None:
        self._attempt = 0
        self._last_pose = None

    def act(self, obs: dict) -> np.ndarray:
        pose = self.env.robot.base_pose()
        stuck = self._last_pose is not None and np.allclose(pose, self._last_pose, atol=1e-4)
        self._attempt = self._attempt + 1 if stuck else 0
        self._last_pose = pose
        return follow_shortest_path(self.env, self._attempt)


def follow_shortest_path(env, attempt: int = 0) -> np.ndarray:
    """Aim along the task's shortest path (its goal when within reach), facing onward."""
    task = env.task
    xy = env.robot.base_pose()[:2]
    if np.linalg.norm(task.goal_xy - xy) <= 1.8 and attempt == 0:
        return base_action(env, task.goal_xy)
    n = LOOKAHEADS[min(attempt, len(LOOKAHEADS) - 1)]
    waypoints = task.field.waypoints(xy, 12, 0.2)
    target = waypoints[n - 1]
    onward = waypoints[min(n + 1, len(waypoints) - 1)] - target
    yaw = float(np.arctan2(onward[1], onward[0])) if np.linalg.norm(onward) > 1e-6 else None
    return base_action(env, target, yaw)
