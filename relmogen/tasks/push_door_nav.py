"""PushDoorNav: push a closed door open with the arm to reach a goal inside the room behind it.

Task Description:
    The goal lies inside a closed room (the scene's ``goal_region``); its only doorway
    (``scene.goal_doorway``) holds a hinged door that is closed at the start and swings into
    the room. The robot starts in the corridor (``start_region``) and must push the door open
    with its arm, then drive through and bring its base centre within 0.5 m of the goal. The
    base cannot open the door: the motion generator stops the base before any contact, and
    with joint-velocity control touching the door ends the episode as a collision.

Randomizations:
    Hinge side (either jamb), the goal (anywhere in the room at least 1.5 m from the doorway
    centre, outside the door's swing) and the start pose (in the corridor, yaw uniform,
    geodesic distance 1.5-10 m on the static floor plan, at least 0.8 m from the doorway
    centre) every episode.

Success Conditions:
    xy distance from the base centre to the goal below 0.5 m. The episode ends on success.
    The door counts as open above 60 deg (``door_opened`` metric), which is not required
    by itself.

Reward:
    geodesic: (previous - current) geodesic distance to the goal on the static floor plan
        (doors ignored), weight 1.
    door: (current - previous) door angle in radians, weight 1 (negative if it closes).
    success: +10 once, when a decision (a subgoal, or a joint step) ends with the success
        condition holding (the episode ends then); passing through the goal mid-subgoal earns nothing.

Metrics:
    success (SR), spl, path_length, shortest_path_length, goal_distance, door_angle_deg
    (final), door_opened (1 if the door was ever above 60 deg).
"""

from __future__ import annotations

import math

import numpy as np

from relmogen.scenes.geometry import Doorway
from relmogen.scenes.objects.door import OPEN_ANGLE, HingedDoor
from relmogen.tasks.base import register_task
from relmogen.tasks.navigation import NavigationTask
from relmogen.tasks.terms import EventReward, PotentialReward

SAMPLING_TRIES = 500


@register_task
class PushDoorNav(NavigationTask):
    name = "PushDoorNav"
    min_geodesic = 1.5
    max_geodesic = 10.0
    goal_door_clearance = 1.5  # m from the doorway centre: the open door never covers the goal
    start_door_clearance = 0.8

    def __init__(self, ctx):
        super().__init__(ctx)
        self.door: HingedDoor | None = None
        self.max_door_angle = 0.0
        self.reward_terms = [
            PotentialReward("geodesic", self.geodesic_distance, self.geodesic_weight),
            PotentialReward("door", lambda: -self.door.angle, 1.0),
            EventReward("success", self.is_success, self.success_reward, per_decision=True),
        ]

    @property
    def doorway(self) -> Doorway:
        doorway = self.ctx.scene.goal_doorway
        if doorway is None:
            raise ValueError(f"scene {self.ctx.scene.name} has no doorway between its start and goal regions")
        return doorway

    def load(self) -> None:
        super().load()
        self.door = HingedDoor(self.ctx.world.client, self.doorway)

    def object_bodies(self) -> list[int]:
        return [self.door.body]

    def reset(self, rng: np.random.Generator) -> None:
        self.reset_objects(rng)
        goal, field = self.sample_goal(rng)
        self.set_goal(goal, field)
        start_xy = self.sample_start(rng)
        self.ctx.robot.reset((*start_xy, rng.uniform(-math.pi, math.pi)), head_tilt=self.head_tilt_angle())
        self.max_door_angle = 0.0
        self.start_episode()

    def reset_objects(self, rng: np.random.Generator) -> None:
        self.door.place(1 if rng.random() < 0.5 else -1)

    # ------------------------------------------------------------------ sampling
    def sample_goal(self, rng: np.random.Generator):
        scene, centre = self.ctx.scene, np.asarray(self.doorway.center)
        for _ in range(SAMPLING_TRIES):
            goal = self.sample_free_point(rng, scene.goal_region)
            if np.linalg.norm(goal - centre) >= self.goal_door_clearance:
                return goal, scene.geodesic_field(goal, self.ctx.robot.spec.base_radius)
        raise RuntimeError(f"no goal in {scene.goal_region} {self.goal_door_clearance} m from its doorway")

    def start_allowed(self, xy: np.ndarray) -> bool:
        """Beyond the door's keep-clear distance (subclasses add their objects)."""
        return np.linalg.norm(xy - np.asarray(self.doorway.center)) >= self.start_door_clearance

    def sample_start(self, rng: np.random.Generator) -> np.ndarray:
        scene = self.ctx.scene
        for _ in range(SAMPLING_TRIES):
            xy = self.sample_free_point(rng, scene.start_region)
            if self.min_geodesic <= self.field.distance(xy) <= self.max_geodesic and self.start_allowed(xy):
                return xy
        raise RuntimeError(f"no start in {scene.start_region} within [{self.min_geodesic}, {self.max_geodesic}] m")

    # ------------------------------------------------------------------ per step
    def after_control_step(self) -> None:
        super().after_control_step()
        self.max_door_angle = max(self.max_door_angle, self.door.angle)

    def metrics(self) -> dict[str, float]:
        return {
            **super().metrics(),
            "door_angle_deg": math.degrees(self.door.angle),
            "door_opened": float(max(self.max_door_angle, self.door.angle) > OPEN_ANGLE),
        }
