"""PointNav oracle: hop along the shortest path on the static floor plan.

Each step aims at the farthest of the next 10 shortest-path waypoints (2 m, the reach of one
base subgoal) whose footprint is free on the robot's current local map (what the LiDAR sees
now). When none is (the LiDAR covers 220 deg from the front, so space beside and behind the
robot is unknown to the base planner), it turns on the spot toward the path. After a step
that made no progress (something the LiDAR plane misses stopped the base), it aims nearer.
"""

from __future__ import annotations

import numpy as np

from relmogen.agents.oracles.base import (
    Oracle,
    base_action,
    base_action_robot_frame,
    register_oracle,
    wrap,
)
from relmogen.motion_generation.base_planner import FootprintChecker

LOOKAHEAD = 10  # waypoints, 0.2 m apart: 2 m, one base subgoal
LOOKAHEADS = (10, 7, 4, 2)  # the door oracles' waypoint choices, shorter after a failed plan
PROGRESS = 0.05  # m: less than this since the last step counts as stuck


@register_oracle
class PointNavOracle(Oracle):
    task_name = "PointNav"

    def reset(self) -> None:
        self._last_xy, self._stuck = None, 0

    def act(self, obs: dict) -> np.ndarray:
        xy = self.env.robot.base_pose()[:2]
        moved = self._last_xy is None or np.linalg.norm(xy - self._last_xy) > PROGRESS
        self._stuck = 0 if moved else self._stuck + 1
        self._last_xy = xy
        return follow_shortest_path(self.env, lookahead=max(2, LOOKAHEAD - 3 * self._stuck))


def visible_waypoint(env, waypoints: np.ndarray) -> np.ndarray | None:
    """The farthest waypoint whose footprint is free on the current local map."""
    local_map = env.control.mg.local_map()
    checker = FootprintChecker(local_map, env.robot.spec.base_radius)
    robot_frame = local_map.world_to_robot(waypoints)
    for index in range(len(waypoints) - 1, -1, -1):
        if bool(local_map.contains(robot_frame[index])) and not checker.in_collision(
                np.array([*robot_frame[index], 0.0])):
            return waypoints[index]
    return None


def follow_shortest_path(env, lookahead: int = LOOKAHEAD) -> np.ndarray:
    """Aim along the task's shortest path (at its goal when that is in view)."""
    task = env.task
    x, y, heading = env.robot.base_pose()
    path = task.field.waypoints(np.array([x, y]), lookahead, 0.2)
    if np.linalg.norm(task.goal_xy - (x, y)) <= lookahead * 0.2:
        path = np.vstack([path, task.goal_xy])
    target = visible_waypoint(env, path)
    if target is None:  # nothing in view: face the path
        ahead = path[min(3, len(path) - 1)]
        return base_action_robot_frame(0.0, 0.0, wrap(float(np.arctan2(ahead[1] - y, ahead[0] - x)) - heading))
    return base_action(env, target)
