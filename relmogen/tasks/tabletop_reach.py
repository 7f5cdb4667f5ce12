"""TabletopReachM: touch a red marker on a table with the gripper.

Task Description:
    The robot stands in front of a table with its head tilted down and must bring the
    gripper within 0.1 m of a red disc drawn on the table top. The goal position is NOT in
    the observation: the policy has to find the marker in the RGB image. Only the arm is
    needed.

Randomizations:
    Robot start: one of the scene's poses in front of the table, shifted by up to 0.1 m
    along and across the table edge, yaw offset in [-0.2, 0.2] rad.
    Goal: uniform on the table top (5 cm from its edges) within the arm's reach: 0.45-0.95 m
    ahead of the base centre and at most 0.4 m to either side.

Success Conditions:
    Gripper link origin within 0.1 m (d_gth) of the goal point at any 0.1 s control step
    (subgoal controls: while the motion generator executes, before the arm tucks again).
    The episode ends on success.

Reward:
    reach: -1 x the gripper-to-goal distance in metres, every control step.
    success: +10 once, when a decision (a subgoal, or a joint step) ends with the success
        condition holding (the episode ends then); passing through the goal mid-subgoal earns nothing.

Metrics:
    success (SR), final goal_distance.
"""

from __future__ import annotations

import numpy as np

from relmogen.simulation.bodies import move_body, visual_marker
from relmogen.tasks.base import Task, register_task
from relmogen.tasks.terms import EventReward, StateReward


@register_task
class TabletopReachM(Task):
    name = "TabletopReachM"
    scene_kind = "house"
    head_tilt = "tabletop"
    subgoal_steps = 5
    subgoal_parts = ("arm",)
    task_obs_dim = 33  # proprioception only: the goal must be seen, not given
    success_distance = 0.1
    marker_rgba = (0.9, 0.05, 0.05, 1.0)

    def __init__(self, ctx):
        super().__init__(ctx)
        self.goal = np.zeros(3)
        self._reached = False
        self.reward_terms = [
            StateReward("reach", self.goal_distance, -1.0),
            EventReward("success", self.is_success, 10.0, per_decision=True),
        ]

    def load(self) -> None:
        self.marker = visual_marker(self.ctx.world.client, 0.05, 0.004, self.marker_rgba)

    def object_bodies(self) -> list[int]:
        return [self.marker]

    def reset(self, rng: np.random.Generator) -> None:
        spots = self.ctx.scene.tabletop_spots
        x, y, yaw = spots[rng.integers(len(spots))]
        x, y = np.array([x, y]) + rng.uniform(-0.1, 0.1, 2)
        yaw += rng.uniform(-0.2, 0.2)
        self.ctx.robot.reset((x, y, yaw), head_tilt=self.head_tilt_angle())
        self.goal = self._sample_goal(rng, np.array([x, y]), yaw)
        move_body(self.ctx.world.client, self.marker, self.goal + (0.0, 0.0, 0.002))
        self._reached = False

    def _sample_goal(self, rng: np.random.Generator, base_xy: np.ndarray, yaw: float) -> np.ndarray:
        table = self.ctx.scene.reach_table
        forward, left = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])
        for _ in range(1000):
            xy = base_xy + rng.uniform(0.45, 0.95) * forward + rng.uniform(-0.4, 0.4) * left
            if table.footprint.contains(xy, margin=0.05):
                return np.array([xy[0], xy[1], table.height])
        raise RuntimeError(f"no reachable point on {table.name} from {base_xy}: check the scene's tabletop_spots")

    def goal_distance(self) -> float:
        return float(np.linalg.norm(self.ctx.robot.end_effector_position() - self.goal))

    def after_control_step(self) -> None:
        self._reached = self._reached or self.goal_distance() < self.success_distance

    def is_success(self) -> bool:
        return self._reached or self.goal_distance() < self.success_distance

    def task_obs(self) -> np.ndarray:
        return self.proprioception()

    def metrics(self) -> dict[str, float]:
        return {"success": float(self.is_success()), "goal_distance": self.goal_distance()}
