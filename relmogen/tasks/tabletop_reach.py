"""TabletopReachM: touch a red marker on a table with the gripper.

Task Description:
    The robot stands in front of a table with its head tilted down and must bring the
    gripper within 0.1 m of a red disc drawn on the table top. The goal position is NOT in
    the observation: the policy has to find the marker in the RGB image. Only the arm is
    needed.

Randomizations:
    Robot start: in front of the table's long side, 0.30-0.45 m from its edge, facing it
    with a yaw offset in [-0.2, 0.2] rad and a lateral offset in [-0.3, 0.3] m.
    Goal: uniform on the table top within the arm's reach (0.05-0.45 m in from the edge,
    +-0.4 m laterally around the robot).

Success Conditions:
    Gripper link origin within 0.1 m (d_gth) of the goal point. The episode ends on success.

Reward:
    reach: -1 x the gripper-to-goal distance in metres, every control step.
    success: +10 once, when the success condition first holds.

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
        self.reward_terms = [
            StateReward("reach", self.goal_distance, -1.0),
            EventReward("success", self.is_success, 10.0),
        ]

    def load(self) -> None:
        self.marker = visual_marker(self.ctx.world.client, 0.05, 0.004, self.marker_rgba)

    def reset(self, rng: np.random.Generator) -> None:
        table = self.ctx.scene.table
        lateral = rng.uniform(-0.3, 0.3)
        standoff = self.ctx.robot.spec.base_radius + rng.uniform(0.30, 0.45)
        x, y, yaw = table.front_pose(lateral, standoff)
        self.ctx.robot.reset((x, y, yaw + rng.uniform(-0.2, 0.2)), head_tilt=self.head_tilt_angle())
        inset = rng.uniform(0.05, 0.45)
        goal_lateral = lateral + rng.uniform(-0.4, 0.4)
        self.goal = table.surface_point(goal_lateral, inset)
        move_body(self.ctx.world.client, self.marker, self.goal + (0.0, 0.0, 0.002))

    def goal_distance(self) -> float:
        return float(np.linalg.norm(self.ctx.robot.end_effector_position() - self.goal))

    def is_success(self) -> bool:
        return self.goal_distance() < self.success_distance

    def task_obs(self) -> np.ndarray:
        return self.proprioception()

    def metrics(self) -> dict[str, float]:
        return {"success": float(self.is_success()), "goal_distance": self.goal_distance()}
