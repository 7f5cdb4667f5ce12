"""PointNav: drive the base to a goal point without collision.

Task Description:
    The robot starts somewhere on the office floor and must bring its base centre within
    0.5 m of a goal point. Only the base is needed: subgoal policies choose base subgoals
    only (as in the original, pure navigation uses the base part of the action); touching
    anything with a part other than the gripper ends the episode (joint-velocity control).

Randomizations:
    Start position and yaw, and the goal position, sampled on the static floor plan every
    episode such that the geodesic distance between them is between 1 m and 10 m.

Success Conditions:
    xy distance from the base centre to the goal below 0.5 m (d_th). The episode ends on
    success.

Reward:
    geodesic: (previous - current) geodesic distance to the goal, weight 1 (metres of
        progress on the static floor plan; negative when moving away).
    success: +10 once, when a decision (a subgoal, or a joint step) ends with the success
        condition holding (the episode ends then); passing through the goal mid-subgoal earns nothing.

Metrics:
    success (SR), spl (success weighted by shortest path length / driven path length),
    path_length, shortest_path_length, goal_distance.
"""

from __future__ import annotations

import numpy as np

from relmogen.tasks.base import register_task
from relmogen.tasks.navigation import NavigationTask


@register_task
class PointNav(NavigationTask):
    name = "PointNav"
    subgoal_parts = ("base",)
    min_geodesic = 1.0
    max_geodesic = 10.0

    def reset(self, rng: np.random.Generator) -> None:
        sample = self.ctx.scene.sample_start_goal(
            rng, self.min_geodesic, self.max_geodesic, robot_radius=self.ctx.robot.spec.base_radius
        )
        self.set_goal(sample.goal_xy, sample.field)
        start = (*sample.start_xy, sample.start_yaw)
        self.ctx.robot.reset(start, head_tilt=self.head_tilt_angle())
        self.start_episode()
