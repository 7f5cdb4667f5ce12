"""Shared machinery of the (interactive) navigation tasks: goal, geodesic potential, SPL.

The shortest path is computed on the static floor plan only (walls and furniture; doors and
movable obstacles are ignored), once per goal, as a distance field. Per step, the task reads
the field: geodesic distance for the reward and the next waypoints for the observation.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from relmogen.scenes.navigation import GeodesicField
from relmogen.simulation.bodies import move_body, visual_marker
from relmogen.tasks.base import Task, TaskContext
from relmogen.tasks.terms import EventReward, PotentialReward, spl

NUM_WAYPOINTS = 10
WAYPOINT_SPACING = 0.2


class NavigationTask(Task):
    """Reach ``goal_xy`` within ``success_distance`` metres (xy distance of the base centre)."""

    scene_kind: ClassVar[str] = "office"
    subgoal_parts: ClassVar[tuple[str, ...]] = ("base", "arm")
    has_map_marks: ClassVar[bool] = True
    success_distance: ClassVar[float] = 0.5
    success_reward: ClassVar[float] = 10.0
    geodesic_weight: ClassVar[float] = 1.0
    # 10 waypoints xy + goal xy + the 33 proprioceptive entries = the original 55-D vector
    task_obs_dim: ClassVar[int] = 2 * NUM_WAYPOINTS + 2 + 33

    def __init__(self, ctx: TaskContext):
        super().__init__(ctx)
        self.goal_xy = np.zeros(2)
        self.field: GeodesicField | None = None
        self.shortest_path_length = 0.0
        self.driven_path_length = 0.0
        self._last_xy = np.zeros(2)
        self.reward_terms = [
            PotentialReward("geodesic", self.geodesic_distance, self.geodesic_weight),
            EventReward("success", self.is_success, self.success_reward, per_decision=True),
        ]

    def load(self) -> None:
        # Visual only: seen in third-person views; the policy gets the goal as a vector.
        self.goal_marker = visual_marker(self.ctx.world.client, 0.15, 0.02, (0.1, 0.8, 0.2, 0.8))

    def set_goal(self, goal_xy: np.ndarray, field: GeodesicField | None = None) -> None:
        """Set the goal and its distance field (computed once per episode, never per step)."""
        self.goal_xy = np.asarray(goal_xy, dtype=np.float64)
        move_body(self.ctx.world.client, self.goal_marker, (*self.goal_xy, 0.01))
        self.field = field or self.ctx.scene.geodesic_field(self.goal_xy, self.ctx.robot.spec.base_radius)

    def start_episode(self) -> None:
        """Call at the end of ``reset`` once the robot is at its start pose."""
        self._last_xy = self.robot_xy()
        self.shortest_path_length = self.geodesic_distance()
        self.driven_path_length = 0.0

    def robot_xy(self) -> np.ndarray:
        return np.asarray(self.ctx.robot.base_pose()[:2])

    def geodesic_distance(self) -> float:
        return float(self.field.distance(self.robot_xy()))

    def goal_distance(self) -> float:
        return float(np.linalg.norm(self.robot_xy() - self.goal_xy))

    def add_driven_distance(self, distance: float) -> None:
        """Subgoal controls report the length of the path they executed."""
        self.driven_path_length += float(distance)
        self._last_xy = self.robot_xy()

    def after_control_step(self) -> None:
        xy = self.robot_xy()
        self.driven_path_length += float(np.linalg.norm(xy - self._last_xy))
        self._last_xy = xy

    def is_success(self) -> bool:
        return self.goal_distance() < self.success_distance

    def task_obs(self) -> np.ndarray:
        waypoints = self.field.waypoints(self.robot_xy(), NUM_WAYPOINTS, WAYPOINT_SPACING)
        goal = self.to_robot_frame(self.goal_xy)
        path = self.to_robot_frame(waypoints).ravel()
        return np.concatenate([path, goal, self.proprioception()]).astype(np.float32)

    def map_marks(self) -> tuple[np.ndarray, np.ndarray]:
        waypoints = self.field.waypoints(self.robot_xy(), NUM_WAYPOINTS, WAYPOINT_SPACING)
        points = self.to_robot_frame(np.vstack([waypoints, self.goal_xy]))
        values = np.full(len(points), 128, dtype=np.uint8)
        values[-1] = 255
        return points, values

    def metrics(self) -> dict[str, float]:
        success = self.is_success()
        return {
            "success": float(success),
            "spl": spl(success, self.shortest_path_length, self.driven_path_length),
            "path_length": self.driven_path_length,
            "shortest_path_length": self.shortest_path_length,
            "goal_distance": self.goal_distance(),
        }
